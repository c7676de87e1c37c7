// Guertin et al. 2014's gather, twin of `crates/render/src/filters/guertin.rs`
// (`guertin_gather_one` is the body of one invocation; the fixes to the paper's pseudocode
// are listed and argued there). One invocation per pixel.

//! include filters_common

fn stochastic_tile(x: u32, y: u32, u: f32) -> vec2<u32> {
    let tx = x / params.tile;
    let ty = y / params.tile;
    let r = f32(params.tile);
    let lx = f32(x - tx * params.tile) + 0.5;
    let ly = f32(y - ty * params.tile) + 0.5;
    let dx = min(lx, r - lx);
    let dy = min(ly, r - ly);
    let sx = select(1i, -1i, lx < r - lx);
    let sy = select(1i, -1i, ly < r - ly);
    var d = dy;
    var step = vec2<i32>(0i, sy);
    if dx <= dy {
        d = dx;
        step = vec2<i32>(sx, 0i);
    }
    let prob = clamp(0.5 - params.tau * d * params.inv_tile, 0.0, 0.5);
    if u >= prob {
        return vec2<u32>(tx, ty);
    }
    let nx = i32(tx) + step.x;
    let ny = i32(ty) + step.y;
    if nx < 0i || ny < 0i || nx >= i32(params.tiles_x) || ny >= i32(params.tiles_y) {
        return vec2<u32>(tx, ty);
    }
    return vec2<u32>(u32(nx), u32(ny));
}

fn variance_at(x: u32, y: u32) -> f32 {
    let u = clamp((f32(x) + 0.5) * params.inv_tile - 0.5, 0.0, f32(params.tiles_x - 1u));
    let v = clamp((f32(y) + 0.5) * params.inv_tile - 0.5, 0.0, f32(params.tiles_y - 1u));
    let x0f = floor(u);
    let y0f = floor(v);
    let fx = u - x0f;
    let fy = v - y0f;
    let x0 = u32(x0f);
    let y0 = u32(y0f);
    let x1 = min(x0 + 1u, params.tiles_x - 1u);
    let y1 = min(y0 + 1u, params.tiles_y - 1u);
    let a = variance[tile_index(x0, y0)];
    let b = variance[tile_index(x1, y0)];
    let c = variance[tile_index(x0, y1)];
    let d = variance[tile_index(x1, y1)];
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

fn along_centre(i: u32, share: f32) -> bool {
    return floor(f32(i + 1u) * share) > floor(f32(i) * share);
}

fn mix_normalize(a: vec2<f32>, b: vec2<f32>, t: f32) -> vec2<f32> {
    let m = vec2<f32>(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t);
    return scale2(m, 1.0 / length2(m));
}

@compute @workgroup_size(8, 8)
fn guertin_gather(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let x = id.x;
    let y = id.y;
    let i = index(x, y);
    let cp = load_color(i);
    if is_bad3(cp) || is_bad(depth[i]) {
        store_color(i, cp);
        return;
    }
    let j = halton_jitter(x, y, params.width, params.seed);
    let tile = stochastic_tile(x, y, tile_offset_random(x, y, params.seed));
    let vmax = neighbor_max_tiles[tile_index(tile.x, tile.y)];
    let rmax = length2(vmax);
    if rmax <= HALF_PIXEL {
        store_color(i, cp);
        return;
    }
    let wn = scale2(vmax, 1.0 / rmax);
    let vc = velocity[i];
    let lc = length2(vc);
    var wp = vec2<f32>(-wn.y, wn.x);
    if dot2(wp, vc) < 0.0 {
        wp = vec2<f32>(-wp.x, -wp.y);
    }
    let rc = max(lc, HALF_PIXEL);
    let nc = scale2(vc, 1.0 / rc);
    let wc = mix_normalize(wp, nc, clamp((lc - HALF_PIXEL) * params.inv_gamma, 0.0, 1.0));
    var share = 0.5;
    if params.variance != 0u {
        share = variance_at(x, y);
    }
    let dirs = Directions(wn, wc, rmax, rc, share, j * params.jitter_scale);
    var g = guertin_weigh(x, y, dirs, 1.0);
    var mean = gathered_mean(g);
    if is_bad3(mean) {
        // Colours near the f32 maximum overflowed the sums (see OVERFLOW_SCALE).
        g = guertin_weigh(x, y, dirs, OVERFLOW_SCALE);
        mean = gathered_rescaled_mean(g);
    }
    store_color(i, mean);
}

// What a pixel's gather needs from its NeighborMax and its own velocity (twin:
// `GuertinDirections`).
struct Directions {
    wn: vec2<f32>,
    wc: vec2<f32>,
    rmax: f32,
    rc: f32,
    share: f32,
    jj: f32,
}

// The weighted sums of pixel (x, y)'s gather, every colour times `scale`.
fn guertin_weigh(x: u32, y: u32, dirs: Directions, scale: f32) -> Gathered {
    let i = index(x, y);
    let zp = depth[i];
    let nf = f32(params.samples);
    var g = gathered_start(load_color(i), nf / (params.kappa * dirs.rc), scale);
    for (var s = 0u; s < params.samples; s++) {
        // `s + 1` in integers (see the twin).
        let t = -1.0 + 2.0 * ((f32(s + 1u) + dirs.jj) * params.inv_samples_plus_one);
        let d = select(dirs.wn, dirs.wc, along_centre(s, dirs.share));
        let tt = t * dirs.rmax;
        let sp = offset_pixel(x, y, scale2(d, tt));
        let k = index(sp.x, sp.y);
        let cs = load_color(k);
        if is_bad3(cs) || is_bad(depth[k]) {
            continue;
        }
        let vs = velocity[k];
        let rs = max(length2(vs), HALF_PIXEL);
        let zs = depth[k];
        let f = z_compare(zp, zs);
        let b = z_compare(zs, zp);
        let wa = abs(dot2(dirs.wc, d));
        let wb = abs(dot2(scale2(vs, 1.0 / rs), d));
        let o = vec2<f32>(f32(sp.x) - f32(x), f32(sp.y) - f32(y));
        let dist = sqrt(dot2(o, o));
        var w = f * cone(dist, rs) * wb;
        w += b * cone(dist, dirs.rc) * wa;
        w += cylinder(dist, min(rs, dirs.rc)) * max(wa, wb) * 2.0;
        gathered_add(&g, cs, w, scale);
    }
    return g;
}
