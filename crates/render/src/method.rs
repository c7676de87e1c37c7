//! What rendering a frame with a [`Method`] gives ([`RenderedFrame`]: one linear image, a
//! stereo frame's eyes side by side, left eye left) and why it can fail ([`RenderError`]).
//! Methods are dispatched in one place, [`crate::Renderer::submit`], through
//! [`crate::methods`]; [`render_frame`] is its CPU shorthand.

use study::Method;
use study::method::MethodSpec;
use study::scene::FrameScene;

use crate::env::EnvironmentMap;
use crate::io::{LinearImage, compose_side_by_side};

/// Why a frame could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Nested sampling (one sample stream read out at several counts) is the tracer's alone.
    #[error("rendering method `{0}` cannot render nested sample levels (--nested): only the tracer can")]
    NotNested(Method),
    /// The GPU failed while rendering (device lost, out of memory, a limit).
    #[error("{0}")]
    Gpu(String),
    /// A method's settings are out of range.
    #[error("{0}")]
    Settings(String),
    /// A post-process filter refused its input or settings, or its device failed.
    #[error("motion blur filter: {0}")]
    Filter(String),
    /// The frame's scene is beyond what the method or device renders (e.g. the GPU's one
    /// wrap of the sphere's path per exposure): the design's values, not the device, are
    /// at fault.
    #[error("{0}")]
    Scene(String),
}

impl RenderError {
    /// Whether the input is at fault (a request it cannot serve, a
    /// design's settings or scene out of a renderer's range): exit code 2 on the command line.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, RenderError::NotNested(_) | RenderError::Settings(_) | RenderError::Scene(_))
    }
}

/// A rendered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedFrame {
    /// Linear radiance; a stereo frame's eyes side by side (left eye left).
    pub image: LinearImage,
    /// Radiance samples that were NaN or infinite and were discarded; for the filters, the
    /// tracer's at the shutter's centre plus the G-buffer pixels the filter discarded
    /// ([`crate::methods::post_process::nonfinite_pixels`]).
    pub nonfinite_samples: u64,
    /// Camera samples traced (0 for methods that trace none).
    pub camera_samples: u64,
    /// GPU seconds from timestamp queries, for frames rendered on a GPU that has them.
    pub gpu_seconds: Option<f64>,
}

/// Renders the frame `scene` with `method` (its default settings) on the CPU
/// ([`crate::Renderer::cpu`]).
pub fn render_frame(method: Method, scene: &FrameScene, env: &EnvironmentMap) -> Result<RenderedFrame, RenderError> {
    crate::Renderer::cpu(env).render(&MethodSpec::of(method), scene)
}

/// The filters' per-pixel jitter seed of an eye (its 64-bit seed folded to the 32 bits the
/// GPU hashes).
pub fn filter_seed(eye_seed: u64) -> u32 {
    (eye_seed ^ (eye_seed >> 32)) as u32
}

/// One image of a frame's eyes: the single eye of a mono frame, or the eyes side by side.
pub fn compose_eyes(eyes: Vec<LinearImage>) -> LinearImage {
    if eyes.len() == 1 {
        eyes.into_iter().next().unwrap_or_else(|| LinearImage::new(0, 0))
    } else {
        compose_side_by_side(&eyes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_registered_method_renders_a_stereo_frame() {
        let design = study::design::Design::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml"),
        )
        .unwrap();
        let mut preset = design.preset("quick").unwrap();
        (preset.width, preset.height, preset.samples_per_pixel) = (8, 4, vec![1; preset.samples_per_pixel.len()]);
        let scene = design.frame_scene_with(&preset, &"M1-S1-T1-A1-stereo".parse().unwrap(), 0).unwrap();
        let env = EnvironmentMap::from_lighting(&scene.lighting).unwrap();
        let frame = render_frame(Method::Tracer, &scene, &env).unwrap();
        assert_eq!((frame.image.width, frame.image.height), (16, 4));
        assert_eq!(frame.camera_samples, 2 * 8 * 4);
        // Every registered method renders both eyes at the frame's size.
        for m in Method::ALL {
            let frame = render_frame(m, &scene, &env).unwrap();
            assert_eq!((frame.image.width, frame.image.height), (16, 4), "{m}");
        }
    }

    #[test]
    fn settings_a_filter_refuses_are_bad_input() {
        let design = study::design::Design::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml"),
        )
        .unwrap();
        let mut preset = design.preset("quick").unwrap();
        (preset.width, preset.height, preset.samples_per_pixel) = (8, 4, vec![1; preset.samples_per_pixel.len()]);
        let scene = design.frame_scene_with(&preset, &"M1-S3-T5-A1".parse().unwrap(), 3).unwrap();
        let env = EnvironmentMap::from_lighting(&scene.lighting).unwrap();
        let spec = MethodSpec::Guertin(study::method::GuertinSettings { gamma: Some(0.0), ..Default::default() });
        let e = crate::Renderer::cpu(&env).render(&spec, &scene).unwrap_err();
        assert!(matches!(e, RenderError::Settings(_)) && e.is_bad_input(), "{e:?}");
        assert!(e.to_string().contains("gamma"), "{e}");
        assert!(!RenderError::Gpu("device lost".into()).is_bad_input());
        assert!(RenderError::Scene("wraps twice".into()).is_bad_input());
    }
}
