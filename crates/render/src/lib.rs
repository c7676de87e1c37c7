//! Pixels from a stimulus. `tracer` is the distribution (Monte Carlo) ray tracer whose CPU
//! path is the reference; `env` loads, generates and importance-samples environment maps;
//! `io` turns linear radiance into PNG/EXR files; `set` renders whole stimulus sets with
//! manifests and resume.

pub mod env;
pub mod io;
pub mod math;
pub mod set;
pub mod tracer;
