//! The thesis's participating-media renderer (Part I, chapter 2) as a method: the tracer
//! renders the sphere, the floor and the sky at the A level's samples on the renderer's
//! device with the medium left out, and the medium of the design's `[medium]` is ray marched
//! over them under the environment's light constellation ([`composite`]). A scene without a
//! medium is the tracer's frame, byte for byte.
//!
//! The march runs on the CPU with `media::march`, the f32 twin of `media`'s WGSL marcher, on
//! every device: the GPU marcher (`media::gpu`) renders the thesis's Table 2.1 benchmark,
//! not yet this method's frames (it has no depth limit per pixel nor the surfaces' shadow).

pub mod composite;

use study::method::MarcherSettings;
use study::scene::FrameScene;

use super::tracer::trace;
use super::{GpuHosts, RenderMethod};
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::renderer::{DeviceError, Renderer, Submitted};
use crate::volume::grids_for;

/// The marcher.
pub struct Marcher;

impl RenderMethod for Marcher {
    type Settings = MarcherSettings;
    const NESTED: bool = false;

    fn open_gpu(_: &mut GpuHosts) -> Result<(), DeviceError> {
        Ok(())
    }

    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &MarcherSettings,
        scene: &FrameScene,
        _: &[u32],
    ) -> Result<Submitted<'r>, RenderError> {
        let surfaces = FrameScene { medium: None, ..scene.clone() };
        let traced = trace(renderer, &surfaces)?;
        let eyes = match &scene.medium {
            None => traced.eyes,
            Some(medium) => {
                let grids = grids_for(medium, &mut |_, _| {}).map_err(|e| RenderError::Scene(e.to_string()))?;
                let constellation = renderer
                    .env()
                    .light_constellation(settings.lights() as usize)
                    .map_err(|e| RenderError::Settings(format!("lights: {e}")))?;
                let instants: Vec<composite::Instant> = composite::instants(scene, settings.sub_frames())
                    .into_iter()
                    .map(|t| composite::Instant::new(scene, medium, &grids, t, settings.distance_map()))
                    .collect();
                traced
                    .eyes
                    .iter()
                    .zip(&scene.views)
                    .map(|(image, view)| {
                        let per_instant: Vec<_> = instants
                            .iter()
                            .map(|i| composite::march_eye(i, &view.camera, &constellation, settings))
                            .collect();
                        composite::composite(image, &per_instant)
                    })
                    .collect()
            }
        };
        Ok(Submitted::Ready(vec![RenderedFrame {
            image: compose_eyes(eyes),
            nonfinite_samples: traced.nonfinite_samples,
            camera_samples: traced.camera_samples,
            gpu_seconds: traced.gpu_seconds,
        }]))
    }
}
