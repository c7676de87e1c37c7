//! Stimulus design files (stimuli/*.toml): factors, levels, scene, viewing geometry, presets; and the scene of any frame.
