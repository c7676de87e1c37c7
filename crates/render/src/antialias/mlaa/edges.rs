//! Pass 1, edge detection (thesis section 3.4): an edge lies on a pixel's west or north
//! boundary where the luminance of the display values on its two sides differs by at least
//! the threshold, or, with depth edges, where the inverse view depth at the two pixels'
//! centres does. The CPU twin of `edges.wgsl`'s two entry points.
//!
//! Depth edges: the thesis thresholds the depth buffer's differences, and adds a condition
//! on the normals where polygons meet at an angle without a depth step. blurlab thresholds
//! inverse depth (1/m), which is what a perspective depth buffer stores up to scale and
//! which is an affine function of the image position on any plane, so a plane seen at a
//! grazing angle (the floor towards the horizon) makes no edge however fast its depth grows.
//! The normals' condition is left out: the study scene has no creases (a sphere and a plane
//! meet only at the contact point, where their depths agree).
//!
//! The result is the edges texture with a one-texel border of zeros around the image
//! (texel `(x + 1, y + 1)` is pixel `(x, y)`), `[west, north]` per texel as 0 or 1: the
//! searches of pass 2 then stop at the image's border by themselves (the text clamps
//! instead, which would carry a line on along the border).

/// The display luminance the edges are found on (the thesis's Eq. 3.1, Rec. 709
/// weights, on the display-encoded values).
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Width of the padded edges texture of an image `width` pixels wide.
pub fn padded(width: u32) -> u32 {
    width + 2
}

/// Whether `x` is NaN or infinite, by its exponent bits (WGSL has no `isNan`, and a
/// comparison with NaN may be optimised away).
pub fn is_bad(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) == 0x7f80_0000
}

/// Whether the boundary between two pixels of luminances `a` and `b` is an edge. A
/// non-finite luminance makes no edge, so its pixel takes part in no line and no blend:
/// it stays as it is and spreads to no neighbour.
pub fn is_edge(a: f32, b: f32, threshold: f32) -> bool {
    !is_bad(a) && !is_bad(b) && (a - b).abs() >= threshold
}

/// `[west, north]` of pixel `(x, y)` whose value is `v`, given its western and northern
/// neighbours' `west` and `north` (read at the pixel itself on the first column and row).
pub fn edgels(v: f32, west: f32, north: f32, (x, y): (u32, u32), threshold: f32) -> [f32; 2] {
    let west = x > 0 && is_edge(v, west, threshold);
    let north = y > 0 && is_edge(v, north, threshold);
    [f32::from(u8::from(west)), f32::from(u8::from(north))]
}

/// `[west, north]` of pixel `(x, y)`: `color` is row-major, `width x height`.
pub fn detect_edge(width: u32, color: &[[f32; 3]], threshold: f32, x: u32, y: u32) -> [f32; 2] {
    let at = |x: u32, y: u32| luminance(color[(y * width + x) as usize]);
    edgels(at(x, y), at(x.max(1) - 1, y), at(x, y.max(1) - 1), (x, y), threshold)
}

/// `[west, north]` of pixel `(x, y)` from depth: `inverse_depth` is row-major, `width x
/// height`, 1/m (0 for the sky).
pub fn detect_depth_edge(width: u32, inverse_depth: &[f32], threshold: f32, x: u32, y: u32) -> [f32; 2] {
    let at = |x: u32, y: u32| inverse_depth[(y * width + x) as usize];
    edgels(at(x, y), at(x.max(1) - 1, y), at(x, y.max(1) - 1), (x, y), threshold)
}

/// The padded edges texture from depth ([`detect_depth_edge`] at each pixel).
pub fn detect_depth_edges(width: u32, height: u32, inverse_depth: &[f32], threshold: f32) -> Vec<[f32; 2]> {
    padded_edges(width, height, |x, y| detect_depth_edge(width, inverse_depth, threshold, x, y))
}

fn padded_edges(width: u32, height: u32, edge: impl Fn(u32, u32) -> [f32; 2] + Sync) -> Vec<[f32; 2]> {
    use rayon::prelude::*;
    let pw = padded(width) as usize;
    let mut edges = vec![[0.0; 2]; pw * padded(height) as usize];
    // Rows in parallel; the border rows and columns stay zero.
    edges.par_chunks_mut(pw).enumerate().skip(1).take(height as usize).for_each(|(ty, row)| {
        for x in 0..width {
            row[x as usize + 1] = edge(x, ty as u32 - 1);
        }
    });
    edges
}

/// The padded edges texture of the image.
pub fn detect_edges(width: u32, height: u32, color: &[[f32; 3]], threshold: f32) -> Vec<[f32; 2]> {
    padded_edges(width, height, |x, y| detect_edge(width, color, threshold, x, y))
}
