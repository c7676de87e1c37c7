//! Rendering whole stimulus sets: sequence folders, manifests, index, resume, progress.
