//! Post-process motion blur from one G-buffer (colour, depth and velocity at the shutter's
//! centre instant): McGuire et al. 2012, "A reconstruction filter for plausible motion blur"
//! ([`mcguire_cpu`], [`GpuFilters::mcguire`]) and Guertin, McGuire and Nowrouzezahrai 2014,
//! "A fast and stable feature-aware motion blur filter" ([`guertin_cpu`],
//! [`GpuFilters::guertin`]).
//!
//! Both filters run the same passes, each a WGSL entry point (`tiles.wgsl` here, `gather.wgsl` in each filter's folder) with a CPU
//! twin of the same name (same arguments, same f32 operations in the same order):
//!
//! | pass | WGSL | twin |
//! | --- | --- | --- |
//! | clamp and halve the velocity | `tiles.wgsl` `encode_velocity` | [`tiles::encode_velocity`] |
//! | TileMax, rows then columns | `tile_max_x`, `tile_max_y` | [`tiles::tile_max_x`], [`tiles::tile_max_y`] |
//! | NeighborMax (2012: 3x3; 2014: diagonals culled) | `neighbor_max`, `neighbor_max_culled` | [`tiles::neighbor_max`], [`tiles::neighbor_max_culled`] |
//! | tile variance (2014, optional) | `tile_variance` | [`tiles::tile_variance`] |
//! | gather | `mcguire/gather.wgsl` `mcguire_gather`, `guertin/gather.wgsl` `guertin_gather` | [`crate::methods::mcguire::gather::mcguire_gather`], [`crate::methods::guertin::gather::guertin_gather`] |
//!
//! Shared functions (hashes, jitter, depth comparisons, cone and cylinder weights) are in
//! `common.wgsl` and [`common`]. The intermediate buffers are f32 (see [`tiles`] for why the
//! 2014 paper's UINT8 quantisation is not reproduced).
//!
//! Non-finite input: a pixel whose colour has a NaN or infinite channel, or whose depth is
//! NaN or infinite (the sky is [`SKY_DEPTH`], not infinity), passes through unchanged (the
//! filter invents no value for it), and as a sample it has zero weight in every gather, so
//! it never spreads. A non-finite velocity counts as zero. [`nonfinite_pixels`] counts the
//! pixels passed through so, which the renderer reports with the tracer's discarded samples.
//!
//! Huge finite input: the weighted sums of colours near `f32::MAX` overflow where their mean
//! does not; such a pixel (only such a pixel, so ordinary images keep their bits) is gathered
//! a second time with every colour scaled by an exact power of two
//! ([`common::OVERFLOW_SCALE`]), which gives the same mean. Finite input gives finite output.

use super::common;

/// The depth of sky pixels: nothing is behind them.
pub const SKY_DEPTH: f32 = 1.0e6;

/// One eye's G-buffer at the shutter's centre instant.
#[derive(Clone, Debug, PartialEq)]
pub struct GBuffer {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear radiance, row-major, y down.
    pub color: Vec<[f32; 3]>,
    /// Positive view-space depth in metres (distance along the camera's forward axis); the
    /// sky is [`SKY_DEPTH`].
    pub depth: Vec<f32>,
    /// Screen-space velocity in pixels per exposure (the full displacement over the open
    /// shutter), x right, y down.
    pub velocity: Vec<[f32; 2]>,
}

/// Why a filter refused or failed.
#[derive(Debug, thiserror::Error)]
pub enum FilterError {
    /// The image has no pixels.
    #[error("the G-buffer is {width}x{height}: both sides must be at least 1")]
    EmptyImage {
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
    },
    /// A buffer's length is not width x height.
    #[error("the G-buffer's {buffer} has {got} entries, not {expected} (width x height)")]
    BufferLength {
        /// `color`, `depth` or `velocity`.
        buffer: &'static str,
        /// width x height.
        expected: usize,
        /// What it has.
        got: usize,
    },
    /// A setting out of its range.
    #[error("filter setting {name} = {value}: {why}")]
    BadParam {
        /// The setting.
        name: &'static str,
        /// Its value, printed.
        value: String,
        /// The range it must be in.
        why: &'static str,
    },
    /// The device failed or rejected the work.
    #[error(transparent)]
    Gpu(#[from] ::gpu::GpuError),
    /// The image needs more than the device allows.
    #[error("motion blur filter on {adapter}: {what}")]
    Limit {
        /// The adapter.
        adapter: String,
        /// The limit and the need.
        what: String,
    },
}

/// Largest sample count and tile size accepted (a gather of 1024 taps per pixel is already
/// far beyond either paper).
pub const MAX_SAMPLES: u32 = *study::method::FILTER_COUNT_RANGE.end();
/// Largest tile size accepted.
pub const MAX_TILE: u32 = *study::method::FILTER_COUNT_RANGE.end();

/// The pixels of `g` whose colour has a NaN or infinite channel or whose depth is NaN or
/// infinite: both filters pass each through unchanged and give it zero weight as a sample.
pub fn nonfinite_pixels(g: &GBuffer) -> u64 {
    g.color.iter().zip(&g.depth).filter(|(c, z)| common::is_bad3(**c) || common::is_bad(**z)).count() as u64
}

/// Checks the G-buffer's sizes.
pub fn check_gbuffer(g: &GBuffer) -> Result<(), FilterError> {
    if g.width == 0 || g.height == 0 {
        return Err(FilterError::EmptyImage { width: g.width, height: g.height });
    }
    let expected = g.width as usize * g.height as usize;
    for (buffer, got) in [("color", g.color.len()), ("depth", g.depth.len()), ("velocity", g.velocity.len())] {
        if got != expected {
            return Err(FilterError::BufferLength { buffer, expected, got });
        }
    }
    Ok(())
}

pub(crate) fn check_count(name: &'static str, v: u32, max: u32) -> Result<(), FilterError> {
    if v == 0 || v > max {
        return Err(FilterError::BadParam { name, value: v.to_string(), why: "must be between 1 and 1024" });
    }
    Ok(())
}

pub(crate) fn check_real(name: &'static str, v: f32, positive: bool) -> Result<(), FilterError> {
    let ok = v.is_finite() && if positive { v > 0.0 } else { v >= 0.0 };
    if !ok {
        let why = if positive { "must be finite and positive" } else { "must be finite and not negative" };
        return Err(FilterError::BadParam { name, value: v.to_string(), why });
    }
    Ok(())
}
