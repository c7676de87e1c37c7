//! The accumulation buffer as a method: the mean of instantaneous tracer renders over the
//! shutter ([`instants`]), on whichever device traces. It has no kernel of its own: each
//! instant is the tracer's.

pub mod instants;

use study::method::AccumSettings;
use study::scene::FrameScene;

use super::tracer::trace;
use super::{GpuHosts, RenderMethod};
use crate::method::{RenderError, RenderedFrame, compose_eyes};
use crate::renderer::{DeviceError, Renderer, Submitted, add_seconds};

/// The accumulation buffer.
pub struct Accum;

impl RenderMethod for Accum {
    type Settings = AccumSettings;
    const NESTED: bool = false;

    fn open_gpu(_: &mut GpuHosts) -> Result<(), DeviceError> {
        Ok(())
    }

    fn submit<'r>(
        renderer: &'r Renderer<'_>,
        settings: &AccumSettings,
        scene: &FrameScene,
        _: &[u32],
    ) -> Result<Submitted<'r>, RenderError> {
        let instants = instants::instant_scenes(scene, settings);
        let mut images = Vec::with_capacity(instants.len());
        let (mut nonfinite_samples, mut camera_samples, mut gpu_seconds) = (0, 0, None);
        for instant in &instants {
            let traced = trace(renderer, instant)?;
            nonfinite_samples += traced.nonfinite_samples;
            camera_samples += traced.camera_samples;
            gpu_seconds = add_seconds(gpu_seconds, traced.gpu_seconds);
            images.push(traced.eyes);
        }
        Ok(Submitted::Ready(vec![RenderedFrame {
            image: compose_eyes(instants::average(&images)),
            nonfinite_samples,
            camera_samples,
            gpu_seconds,
        }]))
    }
}
