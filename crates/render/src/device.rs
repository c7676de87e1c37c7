//! Which device renders: the CPU tracer or the GPU tracer ([`DeviceChoice`], the
//! `--device auto|cpu|gpu` of the command line), opened once per run with its environment
//! map ([`Renderer`]). `auto` takes a hardware GPU adapter when there is one and the CPU
//! otherwise: a software adapter (lavapipe) is slower than the CPU tracer, so only
//! `--device gpu` uses one.

use std::fmt;
use std::str::FromStr;

use gpu::{AdapterChoice, GpuError, GpuInfo};
use study::Method;
use study::manifest::GpuRecord;
use study::method::MethodSpec;
use study::scene::FrameScene;

use crate::analytic::gpu::{GpuAnalytic, GpuAnalyticError};
use crate::env::EnvironmentMap;
use crate::filters::{FilterError, GpuFilters};
use crate::gbuffer::{centre_time, gbuffers, instant_scene};
use crate::io::LinearImage;
use crate::method::{RenderError, RenderedFrame, compose_eyes, filter_seed, guertin_params, mcguire_params};
use crate::tracer::gpu::{GpuEnvironment, GpuTracer, GpuTracerError, PendingFrame};

/// The `--device` of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DeviceChoice {
    /// A hardware GPU adapter if there is one, else the CPU.
    #[default]
    Auto,
    /// The CPU tracer.
    Cpu,
    /// A GPU adapter, hardware first, then software (lavapipe); an error without one.
    Gpu,
}

impl fmt::Display for DeviceChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DeviceChoice::Auto => "auto",
            DeviceChoice::Cpu => "cpu",
            DeviceChoice::Gpu => "gpu",
        })
    }
}

impl FromStr for DeviceChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "auto" => Ok(DeviceChoice::Auto),
            "cpu" => Ok(DeviceChoice::Cpu),
            "gpu" => Ok(DeviceChoice::Gpu),
            other => Err(format!("unknown device `{other}`; expected auto, cpu or gpu")),
        }
    }
}

/// Why a device could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// `--device gpu` without a usable adapter.
    #[error("--device gpu: {0}")]
    NoGpu(GpuError),
    /// The GPU tracer could not be set up on the adapter.
    #[error("GPU tracer on {adapter}: {source}")]
    Setup {
        /// The adapter.
        adapter: String,
        /// Cause.
        source: crate::tracer::gpu::GpuTracerError,
    },
    /// The post-process filters could not be set up on the adapter.
    #[error("GPU filters on {adapter}: {source}")]
    Filters {
        /// The adapter.
        adapter: String,
        /// Cause.
        source: Box<FilterError>,
    },
}

/// The GPU half of a [`Renderer`].
struct GpuDevice {
    tracer: GpuTracer,
    env: GpuEnvironment,
    filters: GpuFilters,
    analytic: GpuAnalytic,
}

/// The eyes of one tracer render and what it cost.
struct Traced {
    eyes: Vec<LinearImage>,
    nonfinite_samples: u64,
    camera_samples: u64,
    gpu_seconds: Option<f64>,
}

fn filter_error(e: FilterError) -> RenderError {
    match e {
        FilterError::BadParam { .. } => RenderError::Settings(format!("motion blur filter: {e}")),
        e => RenderError::Filter(e.to_string()),
    }
}

/// A GPU tracer's error: a frame its parameters cannot express is the scene's fault.
fn tracer_error(e: GpuTracerError) -> RenderError {
    match e {
        GpuTracerError::Params(_) => RenderError::Scene(e.to_string()),
        e => RenderError::Gpu(e.to_string()),
    }
}

fn add_seconds(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    }
}

/// A device ready to render frames lit by one environment map.
pub struct Renderer<'env> {
    env: &'env EnvironmentMap,
    gpu: Option<GpuDevice>,
}

/// A frame on its way: rendered already (CPU) or submitted to the GPU.
pub enum Submitted<'r> {
    /// Rendered: one frame per level, fewest samples first.
    Ready(Vec<RenderedFrame>),
    /// On the GPU.
    Gpu(PendingFrame<'r>),
}

impl Submitted<'_> {
    /// The frame at each level, fewest samples first (waits for the GPU).
    pub fn finish(self) -> Result<Vec<RenderedFrame>, RenderError> {
        match self {
            Submitted::Ready(levels) => Ok(levels),
            Submitted::Gpu(pending) => {
                let frame = pending.finish().map_err(tracer_error)?;
                let mut levels: Vec<RenderedFrame> = frame
                    .prefixes
                    .into_iter()
                    .map(|p| RenderedFrame {
                        image: compose_eyes(p.eyes),
                        nonfinite_samples: p.nonfinite_samples,
                        camera_samples: p.camera_samples,
                        gpu_seconds: p.gpu_seconds,
                    })
                    .collect();
                levels.push(RenderedFrame {
                    image: compose_eyes(frame.eyes),
                    nonfinite_samples: frame.nonfinite_samples,
                    camera_samples: frame.camera_samples,
                    gpu_seconds: frame.gpu_seconds,
                });
                Ok(levels)
            }
        }
    }
}

impl<'env> Renderer<'env> {
    /// Opens the device `choice` asks for, for frames lit by `env`.
    pub fn open(choice: DeviceChoice, env: &'env EnvironmentMap) -> Result<Self, DeviceError> {
        let adapters = match choice {
            DeviceChoice::Cpu => return Ok(Renderer::cpu(env)),
            DeviceChoice::Auto => AdapterChoice::HardwareOnly,
            DeviceChoice::Gpu => AdapterChoice::HardwareThenSoftware,
        };
        let ctx = match gpu::acquire(adapters, &crate::tracer::gpu::device::device_request()) {
            Ok(ctx) => ctx,
            Err(_) if choice == DeviceChoice::Auto => return Ok(Renderer::cpu(env)),
            Err(e) => return Err(DeviceError::NoGpu(e)),
        };
        let adapter = ctx.info.short();
        let setup = |source| DeviceError::Setup { adapter: adapter.clone(), source };
        let filters = GpuFilters::new(ctx.clone())
            .map_err(|e| DeviceError::Filters { adapter: adapter.clone(), source: Box::new(e) });
        let opened = filters.and_then(|filters| {
            let analytic = GpuAnalytic::new(ctx.clone()).map_err(|e| setup(e.into()))?;
            GpuTracer::new(ctx).map_err(|e| setup(e.into())).and_then(|tracer| {
                Ok(GpuDevice { env: tracer.environment(env).map_err(setup)?, tracer, filters, analytic })
            })
        });
        match opened {
            Ok(gpu) => Ok(Renderer { env, gpu: Some(gpu) }),
            // `auto` promises a render: a GPU that cannot run the tracer leaves it to the CPU.
            Err(e) if choice == DeviceChoice::Auto => {
                eprintln!("warning: {e}; rendering on the CPU instead");
                Ok(Renderer::cpu(env))
            }
            Err(e) => Err(e),
        }
    }

    /// The CPU tracer.
    pub fn cpu(env: &'env EnvironmentMap) -> Self {
        Renderer { env, gpu: None }
    }

    /// The GPU adapter, when rendering on one.
    pub fn gpu_info(&self) -> Option<&GpuInfo> {
        self.gpu.as_ref().map(|g| g.tracer.info())
    }

    /// The GPU adapter as manifests record it.
    pub fn gpu_record(&self) -> Option<GpuRecord> {
        self.gpu_info().map(|i| GpuRecord {
            adapter: i.name.clone(),
            backend: format!("{:?}", i.backend),
            driver: i.driver.clone(),
            driver_info: i.driver_info.clone(),
            software: i.is_software,
        })
    }

    /// `cpu: N threads` or `gpu: NAME (BACKEND)`, the manifests' `device`.
    pub fn device_name(&self) -> String {
        match self.gpu_info() {
            Some(info) => format!("gpu: {}", info.short()),
            None => format!("cpu: {} threads", rayon::current_num_threads()),
        }
    }

    /// Whether frames can be submitted ahead (the GPU renders while the CPU encodes).
    pub fn is_asynchronous(&self) -> bool {
        self.gpu.is_some()
    }

    /// Renders `scene` with `method` and its settings.
    pub fn render(&self, method: &MethodSpec, scene: &FrameScene) -> Result<RenderedFrame, RenderError> {
        let mut levels = self.submit(method, scene, &[])?.finish()?;
        Ok(levels.pop().expect("a submission has its full sample count"))
    }

    /// Starts `scene` with `method`, also reading it out at each sample count of
    /// `checkpoints` below the scene's (nested sampling, the tracer's only); the CPU renders,
    /// and methods other than the tracer finish, before returning.
    pub fn submit(
        &self,
        method: &MethodSpec,
        scene: &FrameScene,
        checkpoints: &[u32],
    ) -> Result<Submitted<'_>, RenderError> {
        if method.kind != Method::Tracer && checkpoints.iter().any(|&k| k > 0 && k < scene.samples_per_pixel) {
            return Err(RenderError::NotNested(method.kind));
        }
        match method.kind {
            Method::Tracer => self.submit_tracer(scene, checkpoints),
            Method::Accum => Ok(Submitted::Ready(vec![self.render_accum(method, scene)?])),
            Method::Mcguire | Method::Guertin => Ok(Submitted::Ready(vec![self.render_filtered(method, scene)?])),
            Method::Analytic => Ok(Submitted::Ready(vec![self.render_analytic(method, scene)?])),
        }
    }

    /// The tracer's frame of `scene`, rendered to the end.
    fn trace(&self, scene: &FrameScene) -> Result<Traced, RenderError> {
        Ok(match &self.gpu {
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
                let f = crate::tracer::render_frame(scene, self.env);
                Traced {
                    eyes: f.eyes,
                    nonfinite_samples: f.nonfinite_samples,
                    camera_samples: f.camera_samples,
                    gpu_seconds: None,
                }
            }
        })
    }

    /// The accumulation buffer: the mean of instantaneous tracer renders over the shutter.
    fn render_accum(&self, method: &MethodSpec, scene: &FrameScene) -> Result<RenderedFrame, RenderError> {
        let instants = crate::accum::instant_scenes(scene, method);
        let mut images = Vec::with_capacity(instants.len());
        let mut total = Traced { eyes: Vec::new(), nonfinite_samples: 0, camera_samples: 0, gpu_seconds: None };
        for instant in &instants {
            let traced = self.trace(instant)?;
            total.nonfinite_samples += traced.nonfinite_samples;
            total.camera_samples += traced.camera_samples;
            total.gpu_seconds = add_seconds(total.gpu_seconds, traced.gpu_seconds);
            images.push(traced.eyes);
        }
        Ok(RenderedFrame {
            image: compose_eyes(crate::accum::average(&images)),
            nonfinite_samples: total.nonfinite_samples,
            camera_samples: total.camera_samples,
            gpu_seconds: total.gpu_seconds,
        })
    }

    /// A post-process filter over the G-buffer at the shutter's centre, eye by eye (each with
    /// its own velocities, so nothing crosses the side-by-side seam). A frame without motion
    /// during an open shutter has zero velocity everywhere, where the filters return their
    /// input: it is the tracer's instant, unfiltered.
    fn render_filtered(&self, method: &MethodSpec, scene: &FrameScene) -> Result<RenderedFrame, RenderError> {
        let centre = instant_scene(scene, centre_time(&scene.shutter));
        let traced = self.trace(&centre)?;
        let mut gpu_seconds = traced.gpu_seconds;
        let mut nonfinite_samples = traced.nonfinite_samples;
        let eyes = if scene.needs_time_sampling() {
            let mut eyes = Vec::with_capacity(scene.views.len());
            for (g, view) in gbuffers(scene, traced.eyes).iter().zip(&scene.views) {
                nonfinite_samples += crate::filters::nonfinite_pixels(g);
                let seed = filter_seed(view.seed);
                let color = match (&self.gpu, method.kind) {
                    (Some(d), Method::Mcguire) => {
                        let out = d.filters.mcguire(g, &mcguire_params(method, seed)).map_err(filter_error)?;
                        gpu_seconds = add_seconds(gpu_seconds, out.gpu_seconds);
                        out.color
                    }
                    (Some(d), _) => {
                        let out = d.filters.guertin(g, &guertin_params(method, seed)).map_err(filter_error)?;
                        gpu_seconds = add_seconds(gpu_seconds, out.gpu_seconds);
                        out.color
                    }
                    (None, Method::Mcguire) => {
                        crate::filters::mcguire::try_mcguire_cpu(g, &mcguire_params(method, seed))
                            .map_err(filter_error)?
                    }
                    (None, _) => crate::filters::guertin::try_guertin_cpu(g, &guertin_params(method, seed))
                        .map_err(filter_error)?,
                };
                eyes.push(LinearImage { width: g.width, height: g.height, pixels: color });
            }
            eyes
        } else {
            traced.eyes
        };
        Ok(RenderedFrame {
            image: compose_eyes(eyes),
            nonfinite_samples,
            camera_samples: traced.camera_samples,
            gpu_seconds,
        })
    }

    /// The analytic rasterizer: its WGSL kernel on a GPU, else the f64 CPU rasterizer.
    fn render_analytic(&self, method: &MethodSpec, scene: &FrameScene) -> Result<RenderedFrame, RenderError> {
        let settings = |e: crate::analytic::AnalyticError| RenderError::Settings(e.to_string());
        let params = crate::analytic::AnalyticParams::from_spec(method).map_err(settings)?;
        let frame = match &self.gpu {
            Some(d) => d.analytic.render_frame(scene, &d.env, &params).map_err(|e| match e {
                GpuAnalyticError::Settings(e) => settings(e),
                e @ GpuAnalyticError::Params(_) => RenderError::Scene(e.to_string()),
                e => RenderError::Gpu(e.to_string()),
            })?,
            None => crate::analytic::render_frame(scene, self.env, &params).map_err(settings)?,
        };
        Ok(RenderedFrame {
            image: compose_eyes(frame.eyes),
            nonfinite_samples: frame.stats.nonfinite,
            camera_samples: frame.lighting_samples,
            gpu_seconds: frame.gpu_seconds,
        })
    }

    fn submit_tracer(&self, scene: &FrameScene, checkpoints: &[u32]) -> Result<Submitted<'_>, RenderError> {
        match &self.gpu {
            Some(g) => g.tracer.submit_nested(scene, &g.env, checkpoints).map(Submitted::Gpu).map_err(tracer_error),
            None => Ok(Submitted::Ready(
                crate::tracer::render_frame_nested(scene, self.env, checkpoints)
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
