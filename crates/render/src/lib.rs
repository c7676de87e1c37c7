//! Pixels from a stimulus. [`Renderer`] (`device`) renders a frame with any rendering
//! method on the chosen device; `method` holds what a render gives and [`render_frame`],
//! the CPU shorthand. `tracer` is the distribution (Monte Carlo) ray tracer whose CPU
//! path is the reference; `env` loads, generates and importance-samples environment maps;
//! `accum` is the accumulation buffer; `analytic` the analytic motion blur rasterizer
//! (Gribel et al. 2010); `gbuffer` the G-buffer (radiance at the shutter's
//! centre, depth, analytic velocity) that the post-process motion blur `filters` read;
//! `io` turns linear radiance into PNG/EXR files; `numeric` holds the robust numerics every
//! method shares. Whole sets (folders, manifests, resume, shards) are the `sets` crate's.

pub mod accum;
pub mod analytic;
pub mod env;
pub mod filters;
pub mod gbuffer;
pub mod io;
pub mod measure;
pub mod method;
pub mod methods;
pub mod numeric;
pub mod renderer;
pub mod shading;
pub mod tracer;

pub use method::{RenderError, RenderedFrame, render_frame};
pub use renderer::{DeviceChoice, Renderer};
