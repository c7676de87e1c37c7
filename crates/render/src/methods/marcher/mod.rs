//! The thesis's participating-media renderer (Part I, chapter 2) as a method: the tracer
//! renders the sphere, the floor and the sky at the A level's samples on the renderer's
//! device with the medium left out, and the medium of the design's `[medium]` is ray marched
//! over them under the environment's light constellation ([`composite`]). A scene without a
//! medium is the tracer's frame, byte for byte.
//!
//! The march runs on the renderer's GPU where it has one (`media::gpu::GpuMarcher`, the
//! WGSL marcher given each pixel's ray up to its surface), else on the CPU with its f32 twin
//! (`media::march`).

pub mod composite;

use media::gpu::GpuMarcher;
use study::method::MarcherSettings;
use study::scene::FrameScene;

use super::tracer::trace;
use super::{GpuHosts, RenderMethod};
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::renderer::{DeviceError, Renderer, Submitted, add_seconds};
use crate::volume::grids_for;

/// The marcher.
pub struct Marcher;

impl RenderMethod for Marcher {
    type Settings = MarcherSettings;
    const NESTED: bool = false;

    fn open_gpu(hosts: &mut GpuHosts) -> Result<(), DeviceError> {
        hosts.open(|h| {
            GpuMarcher::new(h.ctx().clone())
                .map_err(|e| DeviceError::Marcher { adapter: h.ctx().info.short(), source: Box::new(e) })
        })
    }

    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &MarcherSettings,
        scene: &FrameScene,
        _: &[u32],
    ) -> Result<Submitted<'r>, RenderError> {
        let surfaces = FrameScene { medium: None, ..scene.clone() };
        let traced = trace(renderer, &surfaces)?;
        let mut gpu_seconds = traced.gpu_seconds;
        let eyes = match &scene.medium {
            None => traced.eyes,
            Some(medium) => {
                let grids = grids_for(medium, &mut |_, _| {}).map_err(|e| RenderError::Scene(e.to_string()))?;
                let constellation = renderer
                    .env()
                    .light_constellation(settings.lights() as usize)
                    .map_err(|e| RenderError::Settings(format!("lights: {e}")))?;
                let marcher = renderer.gpu_host::<GpuMarcher>();
                let mut per_eye: Vec<Vec<Vec<composite::PixelMedium>>> = vec![Vec::new(); scene.views.len()];
                for t in composite::instants(scene, settings.sub_frames()) {
                    let instant = composite::Instant::new(scene, medium, &grids, t, settings.distance_map());
                    let volume = marcher.map(|m| instant.upload(m));
                    for (eye, view) in per_eye.iter_mut().zip(&scene.views) {
                        let gpu = marcher.zip(volume.as_ref());
                        let (pixels, seconds) =
                            composite::march_eye(&instant, &view.camera, &constellation, settings, gpu)
                                .map_err(|e| RenderError::Gpu(format!("the GPU marcher: {e}")))?;
                        gpu_seconds = add_seconds(gpu_seconds, seconds);
                        eye.push(pixels);
                    }
                }
                traced.eyes.iter().zip(&per_eye).map(|(image, eye)| composite::composite(image, eye)).collect()
            }
        };
        Ok(Submitted::Ready(vec![RenderedFrame {
            image: compose_eyes(eyes),
            nonfinite_samples: traced.nonfinite_samples,
            camera_samples: traced.camera_samples,
            gpu_seconds,
        }]))
    }
}
