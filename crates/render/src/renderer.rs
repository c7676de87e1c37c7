//! Which device renders: the CPU tracer or the GPU tracer ([`DeviceChoice`], the
//! `--device auto|cpu|cpu-reference|gpu` of the command line), opened once per run with its
//! environment map ([`Renderer`]). `auto` takes a hardware GPU adapter when there is one and
//! the CPU otherwise: a software adapter (lavapipe) is slower than the CPU tracer, so only
//! `--device gpu` uses one. On the CPU the tracer is the wide one
//! ([`crate::methods::tracer::wide`], the GPU kernel's f32 algorithm in SIMD lanes);
//! `cpu-reference` renders with the f64 reference tracer instead, for checks.

use std::fmt;
use std::str::FromStr;

use gpu::{AdapterChoice, GpuError, GpuInfo};
use study::manifest::GpuRecord;
use study::method::MethodSpec;
use study::scene::FrameScene;

use crate::antialias::mlaa::host::GpuMlaa;
use crate::env::EnvironmentMap;
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::methods::GpuHosts;
use crate::methods::post_process::FilterError;
use crate::methods::tracer::PendingFrame;
use crate::methods::tracer::wide::Isa;
use crate::shading::gpu::params::EnvTables;

/// The `--device` of a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DeviceChoice {
    /// A hardware GPU adapter if there is one, else the CPU.
    #[default]
    Auto,
    /// The CPU: the wide tracer.
    Cpu,
    /// The CPU: the f64 reference tracer (slower; for tests and checks).
    CpuReference,
    /// A GPU adapter, hardware first, then software (lavapipe); an error without one.
    Gpu,
}

impl fmt::Display for DeviceChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DeviceChoice::Auto => "auto",
            DeviceChoice::Cpu => "cpu",
            DeviceChoice::CpuReference => "cpu-reference",
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
            "cpu-reference" => Ok(DeviceChoice::CpuReference),
            "gpu" => Ok(DeviceChoice::Gpu),
            other => Err(format!("unknown device `{other}`; expected auto, cpu, cpu-reference or gpu")),
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
        source: crate::methods::tracer::GpuTracerError,
    },
    /// The post-process filters could not be set up on the adapter.
    #[error("GPU filters on {adapter}: {source}")]
    Filters {
        /// The adapter.
        adapter: String,
        /// Cause.
        source: Box<FilterError>,
    },
    /// The participating-media marcher could not be set up on the adapter.
    #[error("GPU marcher on {adapter}: {source}")]
    Marcher {
        /// The adapter.
        adapter: String,
        /// Cause.
        source: Box<GpuError>,
    },
    /// Morphological antialiasing could not be set up on the adapter.
    #[error("GPU MLAA on {adapter}: {source}")]
    Antialias {
        /// The adapter.
        adapter: String,
        /// Cause.
        source: Box<GpuError>,
    },
}

pub(crate) fn add_seconds(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, b) => a.or(b),
    }
}

/// A device ready to render frames lit by one environment map.
pub struct Renderer<'env> {
    env: &'env EnvironmentMap,
    gpu: Option<GpuHosts>,
    /// The tracer frames go to when `gpu` is `None`. A GPU renderer never uses it and holds
    /// [`CpuTracer::Reference`], which builds no tables.
    cpu: CpuTracer,
}

/// The tracer a renderer without a GPU uses.
pub enum CpuTracer {
    /// The wide tracer, with the environment's tables in its layout.
    Wide(EnvTables),
    /// The f64 reference tracer.
    Reference,
}

/// A frame on its way: rendered already (CPU) or submitted to the GPU.
pub enum Submitted<'r> {
    /// Rendered: one frame per level, fewest samples first.
    Ready(Vec<RenderedFrame>),
    /// On the GPU.
    Gpu(PendingFrame<'r>),
    /// A frame whose scene asks for antialiasing, applied to every level when it finishes.
    Antialiased(Box<Submitted<'r>>, Box<FrameScene>, Option<&'r GpuMlaa>),
}

impl Submitted<'_> {
    /// The frame at each level, fewest samples first (waits for the GPU).
    pub fn finish(self) -> Result<Vec<RenderedFrame>, RenderError> {
        match self {
            Submitted::Ready(levels) => Ok(levels),
            Submitted::Antialiased(inner, scene, gpu) => {
                let mut levels = inner.finish()?;
                for level in &mut levels {
                    crate::antialias::frame::antialias_frame(&mut level.image, &scene, gpu)?;
                }
                Ok(levels)
            }
            Submitted::Gpu(pending) => {
                let frame = pending.finish().map_err(crate::methods::tracer_error)?;
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
            DeviceChoice::CpuReference => return Ok(Renderer::cpu_reference(env)),
            DeviceChoice::Auto => AdapterChoice::HardwareOnly,
            DeviceChoice::Gpu => AdapterChoice::HardwareThenSoftware,
        };
        let ctx = match gpu::acquire(adapters, &crate::methods::tracer::host::device_request()) {
            Ok(ctx) => ctx,
            Err(_) if choice == DeviceChoice::Auto => return Ok(Renderer::cpu(env)),
            Err(e) => return Err(DeviceError::NoGpu(e)),
        };
        let mut hosts = GpuHosts::new(ctx);
        let opened = crate::methods::open_tracer_host(&mut hosts, env)
            .and_then(|()| crate::methods::open_gpu(&mut hosts))
            .and_then(|()| {
                hosts.open(|h| {
                    GpuMlaa::new(h.ctx().clone())
                        .map_err(|e| DeviceError::Antialias { adapter: h.ctx().info.short(), source: Box::new(e) })
                })
            })
            .map(|()| hosts);
        match opened {
            Ok(gpu) => Ok(Renderer { env, gpu: Some(gpu), cpu: CpuTracer::Reference }),
            // `auto` promises a render: a GPU that cannot run the tracer leaves it to the CPU.
            Err(e) if choice == DeviceChoice::Auto => {
                eprintln!("warning: {e}; rendering on the CPU instead");
                Ok(Renderer::cpu(env))
            }
            Err(e) => Err(e),
        }
    }

    /// The wide CPU tracer.
    pub fn cpu(env: &'env EnvironmentMap) -> Self {
        Renderer { env, gpu: None, cpu: CpuTracer::Wide(EnvTables::new(env)) }
    }

    /// The f64 reference CPU tracer.
    pub fn cpu_reference(env: &'env EnvironmentMap) -> Self {
        Renderer { env, gpu: None, cpu: CpuTracer::Reference }
    }

    /// The tracer frames are rendered with when not on a GPU.
    pub fn cpu_tracer(&self) -> &CpuTracer {
        &self.cpu
    }

    /// The GPU adapter, when rendering on one.
    pub fn gpu_info(&self) -> Option<&GpuInfo> {
        self.gpu.as_ref().map(|g| &g.ctx().info)
    }

    /// The environment map the frames are lit by.
    pub fn env(&self) -> &'env EnvironmentMap {
        self.env
    }

    /// A method's GPU host of type `T`, when rendering on a GPU.
    pub fn gpu_host<T: std::any::Any>(&self) -> Option<&T> {
        self.gpu.as_ref().and_then(GpuHosts::get)
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
            None => match &self.cpu {
                CpuTracer::Wide(_) => {
                    format!("cpu: {} threads (wide tracer, {})", rayon::current_num_threads(), Isa::widest())
                }
                CpuTracer::Reference => format!("cpu-reference: {} threads (f64 tracer)", rayon::current_num_threads()),
            },
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
        if scene.medium.is_some()
            && !matches!(method.kind(), study::Method::Tracer | study::Method::Accum | study::Method::Marcher)
        {
            return Err(RenderError::Scene(format!(
                "the scene has a participating medium (the design's [medium]); the `{}` method does not render \
                 media: the marcher does on every device, the tracer and the accumulation buffer on --device \
                 cpu-reference",
                method.kind()
            )));
        }
        if !crate::methods::nests(method.kind()) && checkpoints.iter().any(|&k| k > 0 && k < scene.samples_per_pixel) {
            return Err(RenderError::NotNested(method.kind()));
        }
        let submitted = crate::methods::submit(self, method, scene, checkpoints)?;
        Ok(match scene.antialias {
            None => submitted,
            Some(_) => Submitted::Antialiased(Box::new(submitted), Box::new(scene.clone()), self.gpu_host::<GpuMlaa>()),
        })
    }
}
