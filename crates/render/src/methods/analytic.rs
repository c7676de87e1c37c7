//! Gribel et al. 2010's analytic motion blur rasterizer as a method: the f64 CPU rasterizer
//! (`crate::analytic`) or its WGSL kernel (`crate::analytic::gpu`).

use study::method::AnalyticSettings;
use study::scene::FrameScene;

use super::tracer::TracerHost;
use super::{GpuHosts, RenderMethod};
use crate::analytic::gpu::{GpuAnalytic, GpuAnalyticError};
use crate::analytic::{AnalyticError, AnalyticParams};
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
            None => crate::analytic::render_frame(scene, renderer.env(), &params).map_err(bad_settings)?,
        };
        Ok(Submitted::Ready(vec![RenderedFrame {
            image: compose_eyes(frame.eyes),
            nonfinite_samples: frame.stats.nonfinite,
            camera_samples: frame.lighting_samples,
            gpu_seconds: frame.gpu_seconds,
        }]))
    }
}
