//! Loading a scene's environment: the map file (EXR, Radiance HDR), the built-in default or
//! the uniform map, with intensity and rotation applied and radiance held to what f32 holds.

use std::path::Path;

use study::scene::{Environment, Lighting};

use super::procedural::default_map;
use super::{EnvError, EnvironmentMap};
use crate::io::{LinearImage, decode_exr, decode_hdr};

/// The most radiance (times intensity) a map may hold: the largest f32, which the GPU's
/// tables must represent. Designs are held to `study::scene::MAX_RADIANCE` (2^20 below it)
/// when they are validated, so that sums stay finite; a map file's pixels are known only
/// here, and the renderers keep their sums finite up to this limit (the tracer discards and
/// counts samples that overflow f32, the filters and the analytic kernel rescale).
pub(super) const LOADER_LIMIT: f64 = f32::MAX as f64;

impl EnvironmentMap {
    /// Builds the map a scene's lighting asks for: loads the file, generates the default,
    /// or builds the uniform map; applies intensity and rotation.
    pub fn from_lighting(lighting: &Lighting) -> Result<EnvironmentMap, EnvError> {
        if !(lighting.intensity.is_finite() && lighting.intensity >= 0.0) {
            return Err(EnvError::Parameter(format!("intensity {:e} must be finite and >= 0", lighting.intensity)));
        }
        if !lighting.rotation_y.is_finite() {
            return Err(EnvError::Parameter(format!("rotation_y {} must be finite", lighting.rotation_y)));
        }
        let (image, name) = match &lighting.environment {
            Environment::Default { width } => {
                if *width < 2 || width % 2 != 0 {
                    return Err(EnvError::Parameter(format!("default map width {width} must be even and at least 2")));
                }
                (default_map(*width), "(built-in default)".to_string())
            }
            Environment::File { path } => (load_image(path)?, path.display().to_string()),
            Environment::Uniform { radiance } => {
                if radiance.iter().any(|c| !(c.is_finite() && *c >= 0.0 && *c <= LOADER_LIMIT)) {
                    return Err(EnvError::Parameter(format!(
                        "uniform radiance [{:e}, {:e}, {:e}] must be finite, >= 0 and at most {LOADER_LIMIT:e}",
                        radiance[0], radiance[1], radiance[2]
                    )));
                }
                let mut img = LinearImage::new(8, 4);
                img.pixels.fill(radiance.map(|c| c as f32));
                (img, "(uniform)".to_string())
            }
        };
        EnvironmentMap::from_image(&image, lighting.intensity, lighting.rotation_y, &name)
    }
}

fn load_image(path: &Path) -> Result<LinearImage, EnvError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(EnvError::Missing { path: path.to_path_buf() });
        }
        Err(source) => return Err(EnvError::Read { path: path.to_path_buf(), source }),
    };
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let decoded = match ext.as_deref() {
        Some("exr") => decode_exr(&bytes),
        Some("hdr") | Some("pic") => decode_hdr(&bytes),
        _ => return Err(EnvError::Format { path: path.to_path_buf() }),
    };
    decoded.map_err(|e| EnvError::Corrupt { path: path.to_path_buf(), reason: e.to_string() })
}
