//! What rendering a frame with a [`Method`] gives ([`RenderedFrame`]: one linear image, a
//! stereo frame's eyes side by side, left eye left) and why it can fail ([`RenderError`]).
//! Methods are dispatched in one place, [`crate::Renderer::submit`], on whichever device was
//! opened; [`render_frame`] is its CPU shorthand. A new method is added there once.

use study::Method;
use study::method::MethodSpec;
use study::scene::FrameScene;

use crate::env::EnvironmentMap;
use crate::filters::{GuertinParams, McGuireParams};
use crate::io::{LinearImage, compose_side_by_side};

/// Why a frame could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The method is part of the study's design model but its renderer has not landed.
    #[error("rendering method `{0}` is not available in this build yet; use `tracer`")]
    NotAvailable(Method),
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
    /// Whether the input is at fault (a method the build lacks, a request it cannot serve, a
    /// design's settings or scene out of a renderer's range): exit code 2 on the command line.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            RenderError::NotAvailable(_) | RenderError::NotNested(_) | RenderError::Settings(_) | RenderError::Scene(_)
        )
    }
}

/// A rendered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedFrame {
    /// Linear radiance; a stereo frame's eyes side by side (left eye left).
    pub image: LinearImage,
    /// Radiance samples that were NaN or infinite and were discarded; for the filters, the
    /// tracer's at the shutter's centre plus the G-buffer pixels the filter discarded
    /// ([`crate::filters::nonfinite_pixels`]).
    pub nonfinite_samples: u64,
    /// Camera samples traced (0 for methods that trace none).
    pub camera_samples: u64,
    /// GPU seconds from timestamp queries, for frames rendered on a GPU that has them.
    pub gpu_seconds: Option<f64>,
}

/// Whether this build renders with `method`.
pub fn is_available(method: Method) -> bool {
    matches!(method, Method::Tracer | Method::Accum | Method::Mcguire | Method::Guertin | Method::Analytic)
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

/// McGuire et al.'s filter with a design's settings (the paper's defaults where unset).
pub fn mcguire_params(spec: &MethodSpec, seed: u32) -> McGuireParams {
    let d = McGuireParams::default();
    McGuireParams {
        samples: spec.taps.unwrap_or(d.samples),
        tile: spec.tile.unwrap_or(d.tile),
        soft_z_extent: spec.soft_z_extent.map_or(d.soft_z_extent, |v| v as f32),
        seed,
    }
}

/// Guertin et al.'s filter with a design's settings (the paper's defaults where unset).
pub fn guertin_params(spec: &MethodSpec, seed: u32) -> GuertinParams {
    let d = GuertinParams::default();
    let real = |v: Option<f64>, default: f32| v.map_or(default, |v| v as f32);
    GuertinParams {
        samples: spec.taps.unwrap_or(d.samples),
        tile: spec.tile.unwrap_or(d.tile),
        tau: real(spec.tau, d.tau),
        kappa: real(spec.kappa, d.kappa),
        eta: real(spec.eta, d.eta),
        gamma: real(spec.gamma, d.gamma),
        phi: real(spec.phi, d.phi),
        tile_variance: spec.tile_variance.unwrap_or(d.tile_variance),
        seed,
    }
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
    fn every_method_renders_and_unavailable_ones_are_named() {
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
        // Every method of the design model renders now; `RenderError::NotAvailable` stays for
        // methods yet to come.
        for m in Method::ALL {
            assert!(is_available(m), "{m}");
            let frame = render_frame(m, &scene, &env).unwrap();
            assert_eq!((frame.image.width, frame.image.height), (16, 4), "{m}");
        }
        let e = RenderError::NotAvailable(Method::Analytic).to_string();
        assert!(e.contains("`analytic` is not available"), "{e}");
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
        let spec = MethodSpec { gamma: Some(0.0), ..MethodSpec::of(Method::Guertin) };
        let e = crate::Renderer::cpu(&env).render(&spec, &scene).unwrap_err();
        assert!(matches!(e, RenderError::Settings(_)) && e.is_bad_input(), "{e:?}");
        assert!(e.to_string().contains("gamma"), "{e}");
        assert!(!RenderError::Gpu("device lost".into()).is_bad_input());
        assert!(RenderError::Scene("wraps twice".into()).is_bad_input());
    }
}
