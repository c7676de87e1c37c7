//! Experiment definitions (experiments/*.toml): task, stimuli, pairing, randomisation, briefing, practice, presentation.
