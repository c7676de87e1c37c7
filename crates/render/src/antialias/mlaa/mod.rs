//! Morphological antialiasing (MLAA), as the thesis's Part II (chapter 3, after Reshetov
//! 2009 and Jimenez et al.'s GPU version) describes it: three passes over a finished
//! image, each a function of the same name as its WGSL pass:
//!
//! 1. [`edges`]: edgels on the west and north boundaries of each pixel where the display
//!    luminance (or, given a depth buffer, the inverse view depth) jumps by at least the
//!    threshold;
//! 2. [`weights`]: for each edgel, the distances to its line's ends (searched two edgels
//!    per bilinear fetch), the crossing edges there (one fetch at a quarter-pixel offset)
//!    and the areas the revectorised line cuts, from the [`area`] texture;
//! 3. [`blend`]: each pixel blended with its 4-neighbourhood by those areas.
//!
//! Where in the pipeline: on display values, after tone mapping and the sRGB encoding and
//! before the 8-bit quantisation, one eye at a time (a side-by-side frame is never
//! filtered across its seam). HDR radiance is therefore never blended: the luminance jumps
//! are those a viewer sees, and a pixel's blend stays within the range of its neighbours'
//! display values. Where the code departs from the text it says so in the pass's module.
//!
//! The CPU functions here are the twins of the WGSL passes (`edges.wgsl`, `weights.wgsl`,
//! `blend.wgsl`, with `common.wgsl`) and the fallback without a GPU; [`host::GpuMlaa`] runs
//! the passes on a device.

pub mod area;
pub mod blend;
pub mod edges;
pub mod host;
pub mod weights;

/// The thesis's good trade for the search distance, in pixels ("between 8 and 12"): the
/// study model's default.
pub const DEFAULT_SEARCH_DISTANCE: u32 = study::method::antialias::DEFAULT_MLAA_SEARCH_DISTANCE;
/// The luminance step that makes an edge, in display units: the study model's default.
pub const DEFAULT_THRESHOLD: f32 = study::method::antialias::DEFAULT_MLAA_THRESHOLD as f32;

/// MLAA's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MlaaParams {
    /// Smallest display-luminance step that is an edge, in (0, 1].
    pub threshold: f32,
    /// Longest distance searched towards each end of a line, in pixels, 1 to
    /// [`area::MAX_DISTANCE`].
    pub search_distance: u32,
}

impl Default for MlaaParams {
    fn default() -> Self {
        MlaaParams { threshold: DEFAULT_THRESHOLD, search_distance: DEFAULT_SEARCH_DISTANCE }
    }
}

/// Why MLAA refused its input.
#[derive(Debug, thiserror::Error)]
pub enum MlaaError {
    /// The threshold is not in (0, 1].
    #[error("MLAA threshold {0}: must lie in (0, 1]")]
    Threshold(f32),
    /// The search distance is not in 1..=64.
    #[error("MLAA search distance {0}: must lie in 1..={max}", max = area::MAX_DISTANCE)]
    SearchDistance(u32),
    /// The image's size and pixel count disagree.
    #[error("image of {width}x{height} has {got} pixels")]
    Size {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Pixels given.
        got: usize,
    },
    /// The device failed or rejected the work.
    #[error(transparent)]
    Gpu(#[from] gpu::GpuError),
}

impl MlaaParams {
    /// Checks the settings' ranges.
    pub fn check(&self) -> Result<(), MlaaError> {
        if !(self.threshold > 0.0 && self.threshold <= 1.0) {
            return Err(MlaaError::Threshold(self.threshold));
        }
        if !(1..=area::MAX_DISTANCE).contains(&self.search_distance) {
            return Err(MlaaError::SearchDistance(self.search_distance));
        }
        Ok(())
    }
}

/// MLAA on one eye's display values (`width x height`, row-major, sRGB-encoded in [0, 1]),
/// on the CPU.
pub fn mlaa_cpu(width: u32, height: u32, color: &[[f32; 3]], params: &MlaaParams) -> Result<Vec<[f32; 3]>, MlaaError> {
    params.check()?;
    if color.len() != width as usize * height as usize {
        return Err(MlaaError::Size { width, height, got: color.len() });
    }
    let e = edges::detect_edges(width, height, color, params.threshold);
    let w = weights::blending_weights(&e, width, height, params.search_distance);
    Ok(blend::blend(width, height, color, &w))
}

/// MLAA with edges found in depth ([`edges::detect_depth_edges`]): `inverse_depth` (1/m,
/// row-major, one per pixel) at the threshold, on the CPU.
pub fn mlaa_cpu_depth(
    width: u32,
    height: u32,
    color: &[[f32; 3]],
    inverse_depth: &[f32],
    params: &MlaaParams,
) -> Result<Vec<[f32; 3]>, MlaaError> {
    params.check()?;
    let n = width as usize * height as usize;
    if color.len() != n || inverse_depth.len() != n {
        return Err(MlaaError::Size { width, height, got: color.len().min(inverse_depth.len()) });
    }
    let e = edges::detect_depth_edges(width, height, inverse_depth, params.threshold);
    let w = weights::blending_weights(&e, width, height, params.search_distance);
    Ok(blend::blend(width, height, color, &w))
}
