//! Pixels from a stimulus. `method` is the one entry point per rendering method
//! ([`render_frame`]). `tracer` is the distribution (Monte Carlo) ray tracer whose CPU
//! path is the reference; `env` loads, generates and importance-samples environment maps;
//! `device` chooses the CPU or the GPU tracer (`--device`) and renders through it;
//! `io` turns linear radiance into PNG/EXR files; `set` renders whole stimulus sets with
//! manifests and resume; `numeric` holds the robust numerics every method shares.

pub mod device;
pub mod env;
pub mod io;
pub mod method;
pub mod numeric;
pub mod set;
pub mod tracer;

pub use device::{DeviceChoice, Renderer};
pub use method::{RenderError, RenderedFrame, render_frame};
