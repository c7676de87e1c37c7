//! Pixels from a stimulus. [`Renderer`] (`renderer`) renders a frame with any rendering
//! method on the chosen device; `method` holds what a render gives and [`render_frame`],
//! the CPU shorthand. `methods` holds the rendering methods, one folder each (its CPU
//! reference, its WGSL passes beside their CPU twins, its GPU host) behind one contract:
//! the distribution ray tracer, the accumulation buffer, the post-process filters of
//! McGuire 2012 and Guertin 2014 and the analytic rasterizer of Gribel 2010. `shading` is
//! the shading layer the tracer and the analytic rasterizer share, in f64 and in f32/WGSL;
//! `env` loads, generates and importance-samples environment maps; `io` turns linear
//! radiance into PNG/EXR files; `numeric` holds the robust numerics every method shares;
//! `measure` measures the methods (cost, accuracy, benchmarks); `antialias` filters a
//! finished display frame (morphological antialiasing); `volume` makes a scene's
//! participating medium (its grids, placed in the world). Whole sets (folders,
//! manifests, resume, shards) are the `sets` crate's.

pub mod antialias;
pub mod env;
pub mod io;
pub mod measure;
pub mod method;
pub mod methods;
pub mod numeric;
pub mod renderer;
pub mod shading;
pub mod volume;

pub use method::{RenderError, RenderedFrame, render_frame};
pub use renderer::{DeviceChoice, Renderer};
