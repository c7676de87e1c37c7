//! The analytic motion blur rasterizer of Gribel, Doggett and Akenine-Moeller (2010): for
//! each pixel's sample point, the exact time intervals in which each moving triangle covers
//! it, instead of sampled instants; visibility has no noise, only shading does.
//!
//! The pipeline, one file each: [`geometry`] (the study scene as triangles moving linearly
//! over the shutter, the sphere tessellated from the settings, the floor clipped to the near
//! plane), [`edge`] (time-dependent edge equations `e(t) = alpha t^2 + beta t + gamma`, the
//! visibility function as disjoint intervals, the cubic-rational depth of Eq. 15 and its
//! linear approximation), [`interval`] (per-pixel lists sorted by start time, opaque
//! insertion with the `LESS_EQUAL` rules, the oracle compression of Eq. 19 and the merge of
//! Eq. 20), [`resolve`] (the sweep over time, opaque and translucent), [`shade`] (one
//! evaluation per interval at its midpoint with the tracer's material and lighting code),
//! [`frame`] (tiles in parallel, deterministic), and [`reference`] (the frame).
//! On a GPU the same rasterizer is the WGSL kernel `analytic_pixel.wgsl` (the paper's
//! future work) with its f32 CPU twin [`analytic_pixel`], what both read prepared by
//! [`prepare`], and its host [`host`]; `render::Renderer` uses it wherever a GPU is open.
//! [`sphere`] is the exact visibility of the untessellated moving sphere, the closed form the
//! triangles approximate. [`crate::measure::analytic_accuracy`] holds the measurements the tests check and
//! `blurlab bench analytic-accuracy` draws (the depth approximation's error histogram of the
//! paper's Figure 10, the tessellation's coverage error, the contact shadow per speed).
//!
//! Limits, measured rather than hidden: shading is one evaluation per interval at its
//! temporal midpoint, as the paper specifies, and the floor's interval spans the whole
//! shutter, so the sphere's moving contact shadow is shaded as it stands mid-shutter: a
//! sharp dark ellipse where the tracer shows a smear (visible from about 30 deg/s on the
//! study frame; [`crate::measure::analytic_accuracy::contact_shadow_error`], `analysis/analytic/contact-shadow.csv`).
//! The triangles move in one straight line per exposure: a sphere that travels its path's
//! whole wrap length within one shutter is refused ([`check_motion`]) on every device.
//!
//! Settings (`study::method::MethodSpec`): `intervals`, the per-pixel budget (4-64, default
//! [`DEFAULT_INTERVALS`]); `tessellation`, the sphere's segments around its equator (at
//! least 3, default [`DEFAULT_TESSELLATION`]); `lighting_samples` per shading evaluation
//! (default: the frame's samples per pixel, so the A levels keep their meaning);
//! `supersampling`, sample points per pixel along each axis ([`supersample`]; default 1, the
//! paper's one point at the pixel's centre).

pub mod analytic_pixel;
pub mod edge;
pub mod frame;
pub mod geometry;
pub mod host;
pub mod interval;
pub mod prepare;
pub mod reference;
pub mod resolve;
pub mod shade;
pub mod sphere;
pub mod supersample;

pub use host::{GpuAnalytic, GpuAnalyticError};
pub use reference::{
    AnalyticError, AnalyticFrame, AnalyticParams, DEFAULT_INTERVALS, DEFAULT_TESSELLATION, INTERVALS_RANGE,
    MAX_TESSELLATION, SUPERSAMPLING_RANGE, check_motion, render_frame,
};
use study::method::AnalyticSettings;
use study::scene::FrameScene;

use super::tracer::TracerHost;
use super::{GpuHosts, RenderMethod};
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::renderer::{DeviceError, Renderer, Submitted};

/// The analytic rasterizer.
pub struct Analytic;

impl RenderMethod for Analytic {
    type Settings = AnalyticSettings;
    const NESTED: bool = false;

    fn open_gpu(hosts: &mut GpuHosts) -> Result<(), DeviceError> {
        hosts.open(|h| {
            GpuAnalytic::new(h.ctx().clone())
                .map_err(|e| DeviceError::Setup { adapter: h.ctx().info.short(), source: e.into() })
        })
    }

    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &AnalyticSettings,
        scene: &FrameScene,
        _: &[u32],
    ) -> Result<Submitted<'r>, RenderError> {
        let bad_settings = |e: AnalyticError| RenderError::Settings(e.to_string());
        let params = AnalyticParams::from_settings(settings).map_err(bad_settings)?;
        let gpu = renderer.gpu_host::<GpuAnalytic>().zip(renderer.gpu_host::<TracerHost>());
        let frame = match gpu {
            Some((analytic, t)) => analytic.render_frame(scene, &t.env, &params).map_err(|e| match e {
                GpuAnalyticError::Settings(e) => bad_settings(e),
                e @ GpuAnalyticError::Params(_) => RenderError::Scene(e.to_string()),
                e => RenderError::Gpu(e.to_string()),
            })?,
            None => crate::methods::analytic::render_frame(scene, renderer.env(), &params).map_err(bad_settings)?,
        };
        Ok(Submitted::Ready(vec![RenderedFrame {
            image: compose_eyes(frame.eyes),
            nonfinite_samples: frame.stats.nonfinite,
            camera_samples: frame.lighting_samples,
            gpu_seconds: frame.gpu_seconds,
        }]))
    }
}
