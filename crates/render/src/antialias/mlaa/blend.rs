//! Pass 3, blending with the 4-neighbourhood (thesis section 3.6): each pixel moves towards
//! each neighbour across one of its boundaries by that boundary's weight (Eq. 3.2,
//! `c_new = (1 - a) c_old + a c_opp`), and a pixel on several lines takes the average of
//! those blends weighted by their weights. The CPU twin of `blend.wgsl`. Its own north
//! and west weights are in its texel of the weights; the south and east ones are the
//! opposite-pixel weights of its south and east neighbours' north and west edges.
//!
//! Departure from the text: the blends are explicit linear interpolations rather than
//! bilinear fetches at fractional offsets, so the kernel and its twin agree to rounding
//! (a sampler's fixed-point weights would not), and a term of weight zero is skipped, so a
//! non-finite neighbour never enters a sum (`0 x NaN` is NaN).

use super::weights::Weights;

fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

/// The blended colour of pixel `(x, y)`.
pub fn blend_pixel(width: u32, height: u32, color: &[[f32; 3]], weights: &[Weights], x: u32, y: u32) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let own = weights[i];
    let south = if y + 1 < height { weights[i + width as usize][1] } else { 0.0 };
    let east = if x + 1 < width { weights[i + 1][3] } else { 0.0 };
    let c = color[i];
    let mut sum = [0.0f32; 3];
    let mut total = 0.0f32;
    let neighbours = [
        (own[0], y > 0, i.wrapping_sub(width as usize)),
        (south, true, i + width as usize),
        (own[2], x > 0, i.wrapping_sub(1)),
        (east, true, i + 1),
    ];
    for (a, exists, j) in neighbours {
        if a > 0.0 && exists {
            let m = mix(c, color[j], a);
            sum = [sum[0] + m[0] * a, sum[1] + m[1] * a, sum[2] + m[2] * a];
            total += a;
        }
    }
    if total > 0.0 { [sum[0] / total, sum[1] / total, sum[2] / total] } else { c }
}

/// Every pixel blended (rows in parallel).
pub fn blend(width: u32, height: u32, color: &[[f32; 3]], weights: &[Weights]) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    let mut out = vec![[0.0; 3]; color.len()];
    out.par_chunks_mut(width as usize).enumerate().for_each(|(y, row)| {
        for (x, c) in row.iter_mut().enumerate() {
            *c = blend_pixel(width, height, color, weights, x as u32, y as u32);
        }
    });
    out
}
