//! The rendering methods behind one contract, [`RenderMethod`]: each method is one folder
//! here holding its registration (`mod.rs`: how it renders a frame on the renderer's device
//! and which GPU state it needs there), its CPU reference, its WGSL passes beside their CPU
//! twins of the same name and its GPU host, and one line of `register!`. Its settings
//! (keys, defaults, ranges, cost estimate, cost-sweep knob and report label) are the study
//! model's (`study::method::NAME`). `post_process` is what the two filters share.
//!
//! Set rendering, `render-frame`, shards, the cost sweep and the benchmarks all render
//! through [`crate::Renderer::submit`], which dispatches here.

use std::any::{Any, TypeId};
use std::collections::HashMap;

use gpu::GpuContext;
use study::Method;
use study::method::MethodSpec;
use study::scene::FrameScene;

use crate::method::RenderError;
use crate::renderer::{DeviceError, Renderer, Submitted};

pub mod accum;
pub mod analytic;
pub mod guertin;
pub mod marcher;
pub mod mcguire;
pub mod post_process;
pub mod tracer;

pub use tracer::TracerHost;
pub(crate) use tracer::{open_tracer_host, tracer_error};

/// A rendering method as the renderer sees it.
pub trait RenderMethod {
    /// Its settings as the study model types them.
    type Settings;
    /// Whether one render can also be read out at lower sample counts (nested sampling).
    const NESTED: bool;
    /// Opens what the method needs on a GPU (pipelines, buffers) into `hosts`, once per
    /// renderer; a host another method opened already is shared.
    fn open_gpu(hosts: &mut GpuHosts) -> Result<(), DeviceError>;
    /// Renders (CPU) or submits (GPU) `scene` on `renderer`'s device, reading it out also at
    /// each of `checkpoints` where [`RenderMethod::NESTED`].
    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &Self::Settings,
        scene: &FrameScene,
        checkpoints: &[u32],
    ) -> Result<Submitted<'r>, RenderError>;
}

/// The GPU state of a renderer's methods, one value per type: methods that need the same
/// host (the tracer's, the filters') share it.
pub struct GpuHosts {
    ctx: GpuContext,
    hosts: HashMap<TypeId, Box<dyn Any + Send + Sync>>,
}

impl GpuHosts {
    pub(crate) fn new(ctx: GpuContext) -> Self {
        GpuHosts { ctx, hosts: HashMap::new() }
    }

    /// The device.
    pub fn ctx(&self) -> &GpuContext {
        &self.ctx
    }

    /// Opens a host of type `T` unless one is open.
    pub fn open<T: Any + Send + Sync>(
        &mut self,
        open: impl FnOnce(&GpuHosts) -> Result<T, DeviceError>,
    ) -> Result<(), DeviceError> {
        if !self.hosts.contains_key(&TypeId::of::<T>()) {
            let host = open(self)?;
            self.hosts.insert(TypeId::of::<T>(), Box::new(host));
        }
        Ok(())
    }

    /// The open host of type `T`.
    pub fn get<T: Any>(&self) -> Option<&T> {
        self.hosts.get(&TypeId::of::<T>()).and_then(|h| h.downcast_ref())
    }
}

/// Registers the methods: one line per `study::Method` variant and its [`RenderMethod`].
macro_rules! register {
    ($( $variant:ident => $method:ty ),* $(,)?) => {
        /// Renders or submits `scene` with the method and settings of `spec`.
        pub(crate) fn submit<'r>(
            renderer: &'r Renderer<'_>,
            spec: &MethodSpec,
            scene: &FrameScene,
            checkpoints: &[u32],
        ) -> Result<Submitted<'r>, RenderError> {
            match spec {
                $( MethodSpec::$variant(s) => <$method as RenderMethod>::submit(renderer, s, scene, checkpoints), )*
            }
        }

        /// Whether `method` renders nested sample levels.
        pub fn nests(method: Method) -> bool {
            match method { $( Method::$variant => <$method as RenderMethod>::NESTED, )* }
        }

        /// Opens every method's GPU hosts.
        pub(crate) fn open_gpu(hosts: &mut GpuHosts) -> Result<(), DeviceError> {
            $( <$method as RenderMethod>::open_gpu(hosts)?; )*
            Ok(())
        }
    };
}

register! {
    Tracer => tracer::Tracer,
    Accum => accum::Accum,
    Mcguire => post_process::PostProcess<mcguire::McGuire>,
    Guertin => post_process::PostProcess<guertin::Guertin>,
    Analytic => analytic::Analytic,
    Marcher => marcher::Marcher,
}
