// McGuire et al. 2012's gather, twin of `crates/render/src/filters/mcguire.rs`
// (`mcguire_gather_one` is the body of one invocation). One invocation per pixel.

//! include filters_common

@compute @workgroup_size(8, 8)
fn mcguire_gather(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let x = id.x;
    let y = id.y;
    let i = index(x, y);
    let cx = load_color(i);
    if is_bad3(cx) || is_bad(depth[i]) {
        store_color(i, cx);
        return;
    }
    let vn = neighbor_max_tiles[tile_index(x / params.tile, y / params.tile)];
    if length2(vn) <= HALF_PIXEL {
        store_color(i, cx);
        return;
    }
    var g = mcguire_weigh(x, y, vn, 1.0);
    var mean = gathered_mean(g);
    if is_bad3(mean) {
        // Colours near the f32 maximum overflowed the sums (see OVERFLOW_SCALE).
        g = mcguire_weigh(x, y, vn, OVERFLOW_SCALE);
        mean = gathered_rescaled_mean(g);
    }
    store_color(i, mean);
}

// The weighted sums of pixel (x, y)'s gather along `vn`, every colour times `scale`.
fn mcguire_weigh(x: u32, y: u32, vn: vec2<f32>, scale: f32) -> Gathered {
    let i = index(x, y);
    let zx = depth[i];
    let rx = max(length2(velocity[i]), HALF_PIXEL);
    var g = gathered_start(load_color(i), 1.0 / rx, scale);
    let j = hash_jitter(x, y, params.seed);
    let n = params.samples;
    let centre = (n - 1u) / 2u;
    for (var s = 0u; s < n; s++) {
        if s == centre && n > 1u {
            continue;
        }
        // `s + 1` in integers (see the twin).
        let t = -1.0 + 2.0 * ((f32(s + 1u) + j) * params.inv_samples_plus_one);
        let sp = offset_pixel(x, y, vec2<f32>(vn.x * t, vn.y * t));
        let k = index(sp.x, sp.y);
        let cy = load_color(k);
        if is_bad3(cy) || is_bad(depth[k]) {
            continue;
        }
        let d = vec2<f32>(f32(sp.x) - f32(x), f32(sp.y) - f32(y));
        let dist = sqrt(dot2(d, d));
        let zy = depth[k];
        let ry = max(length2(velocity[k]), HALF_PIXEL);
        let f = soft_depth_compare(zx, zy, params.inv_soft_z_extent);
        let b = soft_depth_compare(zy, zx, params.inv_soft_z_extent);
        let a = f * cone(dist, ry) + b * cone(dist, rx) + cylinder(dist, ry) * cylinder(dist, rx) * 2.0;
        gathered_add(&g, cy, a, scale);
    }
    return g;
}
