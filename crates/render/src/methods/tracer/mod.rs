//! The distribution ray tracer as a method: on the CPU the wide tracer ([`wide`], the
//! kernel's f32 algorithm in SIMD lanes) or the f64 reference ([`reference`]), its WGSL kernel (`trace_batch.wgsl`, with its f32 CPU twin [`trace_batch`]) on a GPU
//! through its host ([`host`]: [`GpuTracer`]). Both shade with the shading layer
//! (`crate::shading`). The tracer's host, [`TracerHost`], is also the shared shading device
//! of the methods built on traced images (the accumulation buffer, the post-process
//! filters' G-buffer, the analytic rasterizer's environment).

pub mod host;
pub mod reference;
pub mod trace_batch;
pub mod wide;

pub use host::{GpuEnvironment, GpuFrame, GpuPrefix, GpuTracer, GpuTracerError, PendingFrame};
pub use reference::{FrameOutput, FrameSetup, render_frame, render_frame_nested};
use study::method::TracerSettings;
use study::scene::FrameScene;

use super::{GpuHosts, RenderMethod};
use crate::io::LinearImage;
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::renderer::{CpuTracer, DeviceError, Renderer, Submitted};

/// The GPU tracer with the renderer's environment map uploaded.
pub struct TracerHost {
    /// The tracer's pipelines.
    pub tracer: GpuTracer,
    /// The environment map's tables.
    pub env: GpuEnvironment,
}

/// The eyes of one tracer render and what it cost.
pub(crate) struct Traced {
    pub eyes: Vec<LinearImage>,
    pub nonfinite_samples: u64,
    pub camera_samples: u64,
    pub gpu_seconds: Option<f64>,
}

/// A GPU tracer's error: a frame its parameters cannot express is the scene's fault.
pub(crate) fn tracer_error(e: GpuTracerError) -> RenderError {
    match e {
        GpuTracerError::Params(_) => RenderError::Scene(e.to_string()),
        e => RenderError::Gpu(e.to_string()),
    }
}

/// Opens the tracer's host unless open.
pub(crate) fn open_tracer_host(hosts: &mut GpuHosts, env: &crate::env::EnvironmentMap) -> Result<(), DeviceError> {
    hosts.open(|h| {
        let setup = |e: GpuTracerError| DeviceError::Setup { adapter: h.ctx().info.short(), source: e };
        let tracer = GpuTracer::new(h.ctx().clone()).map_err(|e| setup(e.into()))?;
        let env = tracer.environment(env).map_err(setup)?;
        Ok(TracerHost { tracer, env })
    })
}

/// The tracer's frame of `scene` on `renderer`'s device, rendered to the end.
pub(crate) fn trace(renderer: &Renderer<'_>, scene: &FrameScene) -> Result<Traced, RenderError> {
    Ok(match renderer.gpu_host::<TracerHost>() {
        Some(g) => {
            let f = g.tracer.render_frame(scene, &g.env).map_err(tracer_error)?;
            Traced {
                eyes: f.eyes,
                nonfinite_samples: f.nonfinite_samples,
                camera_samples: f.camera_samples,
                gpu_seconds: f.gpu_seconds,
            }
        }
        None => {
            let f = match renderer.cpu_tracer() {
                CpuTracer::Wide(tables) => {
                    wide::render_frame(scene, tables).map_err(|e| RenderError::Scene(e.to_string()))?
                }
                CpuTracer::Reference => crate::methods::tracer::render_frame(scene, renderer.env())
                    .map_err(|e| RenderError::Scene(e.to_string()))?,
            };
            Traced {
                eyes: f.eyes,
                nonfinite_samples: f.nonfinite_samples,
                camera_samples: f.camera_samples,
                gpu_seconds: None,
            }
        }
    })
}

/// The tracer.
pub struct Tracer;

impl RenderMethod for Tracer {
    type Settings = TracerSettings;
    const NESTED: bool = true;

    fn open_gpu(_: &mut GpuHosts) -> Result<(), DeviceError> {
        // The renderer opens the tracer's host for every method (it holds the environment).
        Ok(())
    }

    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &TracerSettings,
        scene: &FrameScene,
        checkpoints: &[u32],
    ) -> Result<Submitted<'r>, RenderError> {
        let centred;
        let scene = if settings.pixel_jitter() == scene.pixel_jitter {
            scene
        } else {
            centred = FrameScene { pixel_jitter: settings.pixel_jitter(), ..scene.clone() };
            &centred
        };
        match renderer.gpu_host::<TracerHost>() {
            Some(g) => g.tracer.submit_nested(scene, &g.env, checkpoints).map(Submitted::Gpu).map_err(tracer_error),
            None => Ok(Submitted::Ready(
                match renderer.cpu_tracer() {
                    CpuTracer::Wide(tables) => {
                        wide::render_frame_nested(scene, tables, checkpoints, wide::Isa::widest())
                            .map_err(|e| RenderError::Scene(e.to_string()))?
                    }
                    CpuTracer::Reference => {
                        crate::methods::tracer::render_frame_nested(scene, renderer.env(), checkpoints)
                            .map_err(|e| RenderError::Scene(e.to_string()))?
                    }
                }
                .into_iter()
                .map(|o| RenderedFrame {
                    image: compose_eyes(o.eyes),
                    nonfinite_samples: o.nonfinite_samples,
                    camera_samples: o.camera_samples,
                    gpu_seconds: None,
                })
                .collect(),
            )),
        }
    }
}
