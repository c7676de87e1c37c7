//! What the two post-process filters (`super::mcguire`, `super::guertin`) share: the
//! tracer's instant at the shutter's centre and its G-buffer ([`gbuffer`]); the passes
//! before the gather (`tiles.wgsl` and its twin [`tiles`]); the functions every pass uses
//! (`common.wgsl` and [`common`]); the G-buffer type, the errors and the non-finite rules
//! ([`filter`]); their GPU host ([`host`]: [`GpuFilters`]); and the generic method
//! [`PostProcess`] each filter registers as.

pub mod common;
pub mod filter;
pub mod gbuffer;
pub mod host;
pub mod tiles;

use std::marker::PhantomData;

pub use filter::{FilterError, GBuffer, MAX_SAMPLES, MAX_TILE, SKY_DEPTH, check_gbuffer, nonfinite_pixels};
use gbuffer::{FloorMotion, gbuffers};
pub use host::{FilteredImage, GpuFilters};
use study::scene::FrameScene;

use super::tracer::trace;
use super::{GpuHosts, RenderMethod};
use crate::io::LinearImage;
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::renderer::{DeviceError, Renderer, Submitted, add_seconds};

/// A filter's error: settings it refuses are the design's fault.
fn filter_error(e: FilterError) -> RenderError {
    match e {
        FilterError::BadParam { .. } => RenderError::Settings(format!("motion blur filter: {e}")),
        e => RenderError::Filter(e.to_string()),
    }
}

/// A post-process filter: its parameters from a design's settings, its WGSL passes and its
/// CPU twin.
pub trait Filter {
    /// Its settings as the study model types them.
    type Settings;
    /// Its parameters as the passes read them.
    type Params;
    /// The parameters of `settings` with the per-pixel jitter `seed`.
    fn params(settings: &Self::Settings, seed: u32) -> Self::Params;
    /// How the G-buffer moves the floor under `settings`.
    fn floor_motion(settings: &Self::Settings) -> FloorMotion;
    /// The WGSL passes on the filters' GPU host.
    fn gpu(gpu: &GpuFilters, g: &GBuffer, params: &Self::Params) -> Result<FilteredImage, FilterError>;
    /// The CPU twin.
    fn cpu(g: &GBuffer, params: &Self::Params) -> Result<Vec<[f32; 3]>, FilterError>;
}

/// The method of a post-process [`Filter`]: the filter over the tracer's G-buffer at the
/// shutter's centre, on the renderer's device.
pub struct PostProcess<F>(PhantomData<F>);

impl<F: Filter> RenderMethod for PostProcess<F> {
    type Settings = F::Settings;
    const NESTED: bool = false;

    fn open_gpu(hosts: &mut GpuHosts) -> Result<(), DeviceError> {
        open_filters(hosts)
    }

    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &F::Settings,
        scene: &FrameScene,
        _: &[u32],
    ) -> Result<Submitted<'r>, RenderError> {
        let frame = render_filtered(renderer, scene, F::floor_motion(settings), |g, seed, gpu| {
            let params = F::params(settings, seed);
            match gpu {
                Some(gpu) => F::gpu(gpu, g, &params).map(|out| (out.color, out.gpu_seconds)),
                None => F::cpu(g, &params).map(|color| (color, None)),
            }
        })?;
        Ok(Submitted::Ready(vec![frame]))
    }
}

/// Opens the filters' host unless open.
fn open_filters(hosts: &mut GpuHosts) -> Result<(), DeviceError> {
    hosts.open(|h| {
        GpuFilters::new(h.ctx().clone())
            .map_err(|e| DeviceError::Filters { adapter: h.ctx().info.short(), source: Box::new(e) })
    })
}

/// The filter's colour of one eye's G-buffer, and its GPU seconds where measured.
type Filtered = (Vec<[f32; 3]>, Option<f64>);

/// A post-process filter over the G-buffer at the shutter's centre, eye by eye (each with
/// its own velocities, so nothing crosses the side-by-side seam). A frame without motion
/// during an open shutter has zero velocity everywhere, where the filters return their
/// input: it is the tracer's instant, unfiltered. `filter` gets the eye's G-buffer, its
/// jitter seed and the filters' GPU host where the renderer has one.
fn render_filtered(
    renderer: &Renderer<'_>,
    scene: &FrameScene,
    floor: FloorMotion,
    filter: impl Fn(&GBuffer, u32, Option<&GpuFilters>) -> Result<Filtered, FilterError>,
) -> Result<RenderedFrame, RenderError> {
    let centre = scene.at_instant(scene.shutter.centre());
    let traced = trace(renderer, &centre)?;
    let mut gpu_seconds = traced.gpu_seconds;
    let mut nonfinite_samples = traced.nonfinite_samples;
    let eyes = if scene.needs_time_sampling() {
        let mut eyes = Vec::with_capacity(scene.views.len());
        for (g, view) in gbuffers(scene, traced.eyes, floor).iter().zip(&scene.views) {
            nonfinite_samples += crate::methods::post_process::nonfinite_pixels(g);
            let (color, seconds) = filter(g, crate::method::filter_seed(view.seed), renderer.gpu_host::<GpuFilters>())
                .map_err(filter_error)?;
            gpu_seconds = add_seconds(gpu_seconds, seconds);
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
