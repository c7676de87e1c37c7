//! The passes before the gather, twins of `tiles.wgsl`: the velocity
//! encoding, TileMax (separably, rows then columns), NeighborMax (McGuire et al. 2012's 3x3
//! maximum and Guertin et al. 2014's with off-axis culling) and Guertin's tile variance. Each
//! function runs one WGSL entry point of the same name over the whole image (the entry point
//! is its loop body for one invocation).
//!
//! Storage: every buffer here is f32. Guertin et al. store TileMax, NeighborMax and the
//! variance in UINT8 textures (and the per-pixel velocity in an integer buffer) to save
//! bandwidth; they read them with nearest-neighbour look-ups, which f32 storage buffers do
//! as well. The quantisation is not reproduced: it changes no decision the paper argues for
//! (the direction-preserving clamp of the encoding is kept, [`encode_velocity`]), and a
//! quantisation step of 2r/255 (0.3 px at r = 40) would turn a last-bit difference between
//! the GPU and its twin into a whole step, and so a different sample pixel.

use super::common::{HALF_PIXEL, PassParams, VELOCITY_EPSILON, dot2, index, is_bad, length2, scale2, tile_index};

/// One pixel's blur radius vector: half of the exposure's displacement `v`, its length
/// clamped to [1/2, `radius`] with its direction kept (zero stays zero), as Guertin et al.'s
/// section 5 encodes it: `v / (|v| + eps) * max(min(|v|, r), 1/2)`. A non-finite velocity
/// counts as zero.
///
/// Both papers' velocity is the half displacement: the gather samples `t * v` for t in
/// [-1, 1], and a pixel's blur spans its displacement centred on it.
pub fn encode_one(v: [f32; 2], radius: f32) -> [f32; 2] {
    if is_bad(v[0]) || is_bad(v[1]) {
        return [0.0, 0.0];
    }
    let h = scale2(v, 0.5);
    // Scaled by the larger component first, so that |h| neither overflows (|v| > 1e19) nor
    // underflows: `h / (|h| + eps) = u / (|u| + eps / m)` with `u = h / m`.
    let m = h[0].abs().max(h[1].abs());
    if m == 0.0 {
        return [0.0, 0.0];
    }
    let u = scale2(h, 1.0 / m);
    let lu = length2(u);
    let clamped = (m * lu).min(radius).max(HALF_PIXEL);
    scale2(u, clamped / (lu + VELOCITY_EPSILON / m))
}

/// Pass `encode_velocity`: [`encode_one`] of every pixel, clamped to the tile size, in
/// place (the GPU's velocity buffer holds the G-buffer's velocity, then the encoded one).
pub fn encode_velocity(p: &PassParams, velocity: &mut [[f32; 2]]) {
    let radius = p.tile as f32;
    for v in velocity.iter_mut() {
        *v = encode_one(*v, radius);
    }
}

/// The longer of `best` and `v` (`best` on a tie).
pub fn longer(best: [f32; 2], v: [f32; 2]) -> [f32; 2] {
    if dot2(v, v) > dot2(best, best) { v } else { best }
}

/// Pass `tile_max_x`: for each row and tile column, the longest velocity of the row's pixels
/// in that column (`tiles_x x height` values).
pub fn tile_max_x(p: &PassParams, v: &[[f32; 2]], out: &mut [[f32; 2]]) {
    for y in 0..p.height {
        for tx in 0..p.tiles_x {
            let x0 = tx * p.tile;
            let x1 = (x0 + p.tile).min(p.width);
            let mut best = [0.0, 0.0];
            for x in x0..x1 {
                best = longer(best, v[index(p, x, y)]);
            }
            out[y as usize * p.tiles_x as usize + tx as usize] = best;
        }
    }
}

/// Pass `tile_max_y`: for each tile, the longest of [`tile_max_x`]'s values over its rows:
/// TileMax.
pub fn tile_max_y(p: &PassParams, rows: &[[f32; 2]], out: &mut [[f32; 2]]) {
    for ty in 0..p.tiles_y {
        for tx in 0..p.tiles_x {
            let y0 = ty * p.tile;
            let y1 = (y0 + p.tile).min(p.height);
            let mut best = [0.0, 0.0];
            for y in y0..y1 {
                best = longer(best, rows[y as usize * p.tiles_x as usize + tx as usize]);
            }
            out[tile_index(p, tx, ty)] = best;
        }
    }
}

/// The NeighborMax of tile (tx, ty): the longest TileMax of the tile and its (in-image) 8
/// neighbours, a diagonal neighbour only where `culled` is false or its velocity can blur
/// over the centre tile.
///
/// Culling (Guertin et al. 2014, section 4.4, which gives no formula): a pixel blurs along
/// the whole line `+-v` through it, so a diagonal tile at offset (dx, dy) reaches the centre
/// tile only if `v` or `-v` points into the centre tile's quadrant as seen from the corner
/// the two tiles share: both components of `v` point the same way relative to (dx, dy),
/// `(v.x dx) (v.y dy) > 0`. An axis-aligned velocity in a diagonal tile moves along that
/// tile's own row or column of tiles and is culled.
pub fn neighbor_max_one(p: &PassParams, tile_max: &[[f32; 2]], tx: u32, ty: u32, culled: bool) -> [f32; 2] {
    let mut best = [0.0, 0.0];
    for dy in -1i32..=1 {
        for dx in -1i32..=1 {
            let nx = tx as i32 + dx;
            let ny = ty as i32 + dy;
            if nx < 0 || ny < 0 || nx >= p.tiles_x as i32 || ny >= p.tiles_y as i32 {
                continue;
            }
            let v = tile_max[tile_index(p, nx as u32, ny as u32)];
            let diagonal = dx != 0 && dy != 0;
            if culled && diagonal && (v[0] * dx as f32) * (v[1] * dy as f32) <= 0.0 {
                continue;
            }
            best = longer(best, v);
        }
    }
    best
}

/// Pass `neighbor_max` (McGuire et al. 2012): the 3x3 maximum of TileMax.
pub fn neighbor_max(p: &PassParams, tile_max: &[[f32; 2]], out: &mut [[f32; 2]]) {
    for ty in 0..p.tiles_y {
        for tx in 0..p.tiles_x {
            out[tile_index(p, tx, ty)] = neighbor_max_one(p, tile_max, tx, ty, false);
        }
    }
}

/// Pass `neighbor_max_culled` (Guertin et al. 2014): NeighborMax without the diagonal tiles
/// that cannot blur over the centre tile.
pub fn neighbor_max_culled(p: &PassParams, tile_max: &[[f32; 2]], out: &mut [[f32; 2]]) {
    for ty in 0..p.tiles_y {
        for tx in 0..p.tiles_x {
            out[tile_index(p, tx, ty)] = neighbor_max_one(p, tile_max, tx, ty, true);
        }
    }
}

/// `v / |v|`, or zero for a zero vector.
pub fn direction(v: [f32; 2]) -> [f32; 2] {
    let len = length2(v);
    if len > 0.0 { scale2(v, 1.0 / len) } else { [0.0, 0.0] }
}

/// Pass `tile_variance` (Guertin et al. 2014, equation 2): per tile, 1 minus the mean of
/// `|n(t) . n(u)|` over the (in-image) 3x3 tiles u around and including t, where n is the
/// direction of NeighborMax (the paper's v_max); the absolute value keeps opposite
/// directions from cancelling. 0 where all agree, up to 1.
pub fn tile_variance(p: &PassParams, neighbor_max: &[[f32; 2]], out: &mut [f32]) {
    for ty in 0..p.tiles_y {
        for tx in 0..p.tiles_x {
            let n = direction(neighbor_max[tile_index(p, tx, ty)]);
            let mut sum = 0.0f32;
            let mut count = 0.0f32;
            for dy in -1i32..=1 {
                for dx in -1i32..=1 {
                    let nx = tx as i32 + dx;
                    let ny = ty as i32 + dy;
                    if nx < 0 || ny < 0 || nx >= p.tiles_x as i32 || ny >= p.tiles_y as i32 {
                        continue;
                    }
                    let m = direction(neighbor_max[tile_index(p, nx as u32, ny as u32)]);
                    sum += dot2(n, m).abs();
                    count += 1.0;
                }
            }
            // Rounding can take the mean a last bit above 1.
            out[tile_index(p, tx, ty)] = (1.0 - sum / count).max(0.0);
        }
    }
}

/// Every intermediate buffer of one run of the passes.
#[derive(Clone, Debug, PartialEq)]
pub struct Tiles {
    /// Encoded per-pixel velocities.
    pub velocity: Vec<[f32; 2]>,
    /// [`tile_max_x`]'s output.
    pub rows: Vec<[f32; 2]>,
    /// TileMax.
    pub tile_max: Vec<[f32; 2]>,
    /// NeighborMax.
    pub neighbor_max: Vec<[f32; 2]>,
    /// Tile variance (zeros unless asked for).
    pub variance: Vec<f32>,
}

/// Runs the passes before the gather: culled NeighborMax and the variance for Guertin et al.
/// (`guertin`), the plain 3x3 NeighborMax for McGuire et al.
pub fn run(p: &PassParams, velocity: &[[f32; 2]], guertin: bool) -> Tiles {
    let mut t = Tiles {
        velocity: velocity.to_vec(),
        rows: vec![[0.0; 2]; p.tiles_x as usize * p.height as usize],
        tile_max: vec![[0.0; 2]; p.tiles()],
        neighbor_max: vec![[0.0; 2]; p.tiles()],
        variance: vec![0.0; p.tiles()],
    };
    encode_velocity(p, &mut t.velocity);
    tile_max_x(p, &t.velocity, &mut t.rows);
    tile_max_y(p, &t.rows, &mut t.tile_max);
    if guertin {
        neighbor_max_culled(p, &t.tile_max, &mut t.neighbor_max);
        if p.variance != 0 {
            tile_variance(p, &t.neighbor_max, &mut t.variance);
        }
    } else {
        neighbor_max(p, &t.tile_max, &mut t.neighbor_max);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_encoding_halves_clamps_and_keeps_direction() {
        assert_eq!(encode_one([0.0, 0.0], 40.0), [0.0, 0.0]);
        assert_eq!(encode_one([f32::NAN, 1.0], 40.0), [0.0, 0.0]);
        assert_eq!(encode_one([1e-45, 0.0], 40.0), [0.0, 0.0]);
        let e = encode_one([3e38, -3e38], 40.0);
        assert!((e[0] - 28.284271).abs() < 1e-4 && e[0] == -e[1], "{e:?}");
        let e = encode_one([16.0, 0.0], 40.0);
        assert!((e[0] - 8.0).abs() < 1e-4 && e[1] == 0.0, "{e:?}");
        // Far beyond r: length r, same direction (not (+-r, +-r)).
        let e = encode_one([3000.0, 4000.0], 40.0);
        assert!((length2(e) - 40.0).abs() < 1e-3 && (e[0] / e[1] - 0.75).abs() < 1e-6, "{e:?}");
        // Slow but moving: at least half a pixel.
        let e = encode_one([0.1, 0.0], 40.0);
        assert!((e[0] - 0.5).abs() < 1e-3, "{e:?}");
    }

    #[test]
    fn tile_variance_is_zero_for_one_direction_and_grows_with_disagreement() {
        let p = PassParams::new(60, 60, 20, 1, 0);
        let mut out = vec![0.0; 9];
        // One direction, either sign (the absolute value): no variance.
        let same: Vec<[f32; 2]> = (0..9).map(|i| if i % 2 == 0 { [3.0, 4.0] } else { [-6.0, -8.0] }).collect();
        tile_variance(&p, &same, &mut out);
        assert!(out.iter().all(|&u| u.abs() < 1e-6), "{out:?}");
        // The centre tile's direction against eight perpendicular neighbours: 1 - 1/9.
        let mut cross = vec![[0.0f32, 5.0]; 9];
        cross[4] = [5.0, 0.0];
        tile_variance(&p, &cross, &mut out);
        assert!((out[4] - 8.0 / 9.0).abs() < 1e-6, "{out:?}");
        // A corner tile sees its own three neighbours only: one of four disagrees.
        assert!((out[0] - 0.25).abs() < 1e-6, "{out:?}");
    }

    #[test]
    fn off_axis_tiles_count_only_when_they_point_at_the_centre() {
        let p = PassParams::new(60, 60, 20, 1, 0);
        let mut tm = vec![[0.0f32; 2]; 9];
        // Top-left diagonal tile (offset (-1, -1) from the centre).
        for (v, kept) in [([5.0, 5.0], true), ([-5.0, -5.0], true), ([5.0, -5.0], false), ([9.0, 0.0], false)] {
            tm[0] = v;
            assert_eq!(neighbor_max_one(&p, &tm, 1, 1, true) == v, kept, "{v:?}");
            assert_eq!(neighbor_max_one(&p, &tm, 1, 1, false), v);
        }
        // On-axis tiles always count.
        tm[0] = [0.0, 0.0];
        tm[1] = [0.0, 7.0];
        assert_eq!(neighbor_max_one(&p, &tm, 1, 1, true), [0.0, 7.0]);
    }
}
