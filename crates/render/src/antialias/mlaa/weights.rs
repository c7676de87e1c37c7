//! Pass 2, blending weights (thesis section 3.5): for each edgel, the distances to both
//! ends of its line, the crossing edges there, and from them the areas of the area
//! texture. The CPU twin of `weights.wgsl`: the bilinear fetches are computed as the
//! sampler computes them (texel centres at `i + 1/2`, weights from the fractional
//! position), on the padded edges texture of [`super::edges`].
//!
//! Searches (section 3.5.1) fetch between two texels, so one fetch reads two edgels: 1 means
//! both are edgels and the search goes on by two pixels; below 1 it stops. Departure from
//! the text: a fetch of 1/2 does not say which of the two is the edgel, and the text counts
//! both cases alike, which puts the end one pixel too far when the line ended just before
//! the pair. One point fetch of the nearer texel, made only where a search stops on 1/2,
//! settles it.
//!
//! Crossing edges (section 3.5.2) are fetched a quarter pixel from the line's boundary,
//! so the value (0, 1/4, 3/4, 1) says on which side they are ([`Crossing::from_fetch`]).

use super::area::{Crossing, area};

/// `[north current, north opposite, west current, west opposite]` for each pixel.
pub type Weights = [f32; 4];

/// The bilinear fetch of channel `c` of the padded texture at `(u, v)` (texel units),
/// clamped to its edge texels.
pub fn fetch_linear(edges: &[[f32; 2]], pw: u32, ph: u32, u: f32, v: f32, c: usize) -> f32 {
    let texel = |x: i64, y: i64| {
        let x = x.clamp(0, i64::from(pw) - 1) as usize;
        let y = y.clamp(0, i64::from(ph) - 1) as usize;
        edges[y * pw as usize + x][c]
    };
    let (x, y) = (u - 0.5, v - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let top = texel(x0, y0) + (texel(x0 + 1, y0) - texel(x0, y0)) * fx;
    let bottom = texel(x0, y0 + 1) + (texel(x0 + 1, y0 + 1) - texel(x0, y0 + 1)) * fx;
    top + (bottom - top) * fy
}

/// The edgels from texel `(tx, ty)` (padded coordinates) towards `(dx, dy)` along channel
/// `c` before the line ends, at most `max` (pixels).
pub fn search(
    edges: &[[f32; 2]],
    pw: u32,
    ph: u32,
    (tx, ty): (i32, i32),
    (dx, dy): (i32, i32),
    c: usize,
    max: u32,
) -> u32 {
    let steps = max.div_ceil(2);
    let mut d = 0u32;
    for k in 0..steps as i32 {
        // The boundary between the texels 2k + 1 and 2k + 2 away: texel centres are at
        // i + 1/2, so the boundary of texels i and i + 1 is at i + 1.
        let near = (tx + dx * (2 * k + 1), ty + dy * (2 * k + 1));
        let far = (tx + dx * (2 * k + 2), ty + dy * (2 * k + 2));
        let (u, v) = (0.5 * (near.0 + far.0) as f32 + 0.5, 0.5 * (near.1 + far.1) as f32 + 0.5);
        let e = fetch_linear(edges, pw, ph, u, v, c);
        if e > 0.9 {
            d += 2;
            continue;
        }
        if e > 0.25 {
            let nx = near.0 as f32 + 0.5;
            let ny = near.1 as f32 + 0.5;
            if fetch_linear(edges, pw, ph, nx, ny, c) > 0.5 {
                d += 1;
            }
        }
        break;
    }
    d.min(max)
}

/// The weights of pixel `(x, y)` of an image `width x height` from its padded edges.
pub fn blending_weight(edges: &[[f32; 2]], width: u32, height: u32, search_distance: u32, x: u32, y: u32) -> Weights {
    let (pw, ph) = (width + 2, height + 2);
    let (tx, ty) = (x as i32 + 1, y as i32 + 1);
    let e = edges[ty as usize * pw as usize + tx as usize];
    let mut w = [0.0; 4];
    if e[1] > 0.5 {
        // North edge: a horizontal line; its crossing edges are west edges (channel 0) at
        // its ends, fetched a quarter pixel above the current row's centre.
        let left = search(edges, pw, ph, (tx, ty), (-1, 0), 1, search_distance);
        let right = search(edges, pw, ph, (tx, ty), (1, 0), 1, search_distance);
        let v = ty as f32 + 0.25;
        let e1 = fetch_linear(edges, pw, ph, (tx - left as i32) as f32 + 0.5, v, 0);
        let e2 = fetch_linear(edges, pw, ph, (tx + right as i32 + 1) as f32 + 0.5, v, 0);
        let [cur, opp] = area(Crossing::from_fetch(e1), Crossing::from_fetch(e2), left, right);
        w[0] = cur;
        w[1] = opp;
    }
    if e[0] > 0.5 {
        // West edge: a vertical line; its crossing edges are north edges (channel 1).
        let up = search(edges, pw, ph, (tx, ty), (0, -1), 0, search_distance);
        let down = search(edges, pw, ph, (tx, ty), (0, 1), 0, search_distance);
        let u = tx as f32 + 0.25;
        let e1 = fetch_linear(edges, pw, ph, u, (ty - up as i32) as f32 + 0.5, 1);
        let e2 = fetch_linear(edges, pw, ph, u, (ty + down as i32 + 1) as f32 + 0.5, 1);
        let [cur, opp] = area(Crossing::from_fetch(e1), Crossing::from_fetch(e2), up, down);
        w[2] = cur;
        w[3] = opp;
    }
    w
}

/// Every pixel's weights (rows in parallel).
pub fn blending_weights(edges: &[[f32; 2]], width: u32, height: u32, search_distance: u32) -> Vec<Weights> {
    use rayon::prelude::*;
    let mut out = vec![[0.0; 4]; width as usize * height as usize];
    out.par_chunks_mut(width as usize).enumerate().for_each(|(y, row)| {
        for (x, w) in row.iter_mut().enumerate() {
            *w = blending_weight(edges, width, height, search_distance, x as u32, y as u32);
        }
    });
    out
}
