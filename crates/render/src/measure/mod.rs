//! Measuring the methods: what they cost and how close they come to the reference. `cost`
//! sweeps every method's accuracy knob against a converged tracer reference (`blurlab
//! cost`); `methods` renders each method level of a design against the tracer (`bench
//! methods`); `tracer`, `tracer_gpu`, `analytic` and `filters` are the benchmarks of `blurlab
//! bench` (the tracer's benchmark frame and its peers, the GPU tracer, the analytic
//! rasterizer, the post-process filters); `mlaa`, morphological antialiasing's time per
//! frame (`bench mlaa`); `antialiasing`, each antialiasing level's error on edge pixels
//! against a converged reference (`bench antialiasing`); `analytic_accuracy` measures the rasterizer's
//! depth, coverage and contact-shadow errors (`bench analytic-accuracy`); `media_reference`
//! sets the reference tracer with a participating medium beside Mitsuba 3's volumetric path
//! tracer (`bench media-reference`). Nothing here is
//! needed to render a frame.

pub mod analytic;
pub mod analytic_accuracy;
pub mod antialiasing;
pub mod cost;
pub mod filters;
pub mod media_reference;
pub mod methods;
pub mod mlaa;
pub mod tracer;
pub mod tracer_gpu;
