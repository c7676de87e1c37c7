// The passes before the gather, twin of `crates/render/src/filters/tiles.rs`: velocity
// encoding, TileMax (rows, then columns), NeighborMax (plain and culled) and the tile
// variance. One invocation per pixel, row or tile; 8 x 8 workgroups.

//! include filters_common

fn encode_one(v: vec2<f32>, radius: f32) -> vec2<f32> {
    if is_bad(v.x) || is_bad(v.y) {
        return vec2<f32>(0.0);
    }
    let h = scale2(v, 0.5);
    let m = max(abs(h.x), abs(h.y));
    if m == 0.0 {
        return vec2<f32>(0.0);
    }
    let u = scale2(h, 1.0 / m);
    let lu = length2(u);
    let clamped = max(min(m * lu, radius), HALF_PIXEL);
    return scale2(u, clamped / (lu + VELOCITY_EPSILON / m));
}

@compute @workgroup_size(8, 8)
fn encode_velocity(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let i = index(id.x, id.y);
    velocity[i] = encode_one(velocity[i], f32(params.tile));
}

fn longer(best: vec2<f32>, v: vec2<f32>) -> vec2<f32> {
    return select(best, v, dot2(v, v) > dot2(best, best));
}

// id.x: tile column, id.y: image row.
@compute @workgroup_size(8, 8)
fn tile_max_x(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.tiles_x || id.y >= params.height {
        return;
    }
    let x0 = id.x * params.tile;
    let x1 = min(x0 + params.tile, params.width);
    var best = vec2<f32>(0.0);
    for (var x = x0; x < x1; x++) {
        best = longer(best, velocity[index(x, id.y)]);
    }
    rows[id.y * params.tiles_x + id.x] = best;
}

@compute @workgroup_size(8, 8)
fn tile_max_y(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.tiles_x || id.y >= params.tiles_y {
        return;
    }
    let y0 = id.y * params.tile;
    let y1 = min(y0 + params.tile, params.height);
    var best = vec2<f32>(0.0);
    for (var y = y0; y < y1; y++) {
        best = longer(best, rows[y * params.tiles_x + id.x]);
    }
    tile_max[tile_index(id.x, id.y)] = best;
}

fn neighbor_max_one(tx: u32, ty: u32, culled: bool) -> vec2<f32> {
    var best = vec2<f32>(0.0);
    for (var dy = -1i; dy <= 1i; dy++) {
        for (var dx = -1i; dx <= 1i; dx++) {
            let nx = i32(tx) + dx;
            let ny = i32(ty) + dy;
            if nx < 0i || ny < 0i || nx >= i32(params.tiles_x) || ny >= i32(params.tiles_y) {
                continue;
            }
            let v = tile_max[tile_index(u32(nx), u32(ny))];
            let diagonal = dx != 0i && dy != 0i;
            if culled && diagonal && (v.x * f32(dx)) * (v.y * f32(dy)) <= 0.0 {
                continue;
            }
            best = longer(best, v);
        }
    }
    return best;
}

@compute @workgroup_size(8, 8)
fn neighbor_max(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.tiles_x || id.y >= params.tiles_y {
        return;
    }
    neighbor_max_tiles[tile_index(id.x, id.y)] = neighbor_max_one(id.x, id.y, false);
}

@compute @workgroup_size(8, 8)
fn neighbor_max_culled(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.tiles_x || id.y >= params.tiles_y {
        return;
    }
    neighbor_max_tiles[tile_index(id.x, id.y)] = neighbor_max_one(id.x, id.y, true);
}

fn direction(v: vec2<f32>) -> vec2<f32> {
    let len = length2(v);
    if len > 0.0 {
        return scale2(v, 1.0 / len);
    }
    return vec2<f32>(0.0);
}

@compute @workgroup_size(8, 8)
fn tile_variance(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.tiles_x || id.y >= params.tiles_y {
        return;
    }
    let n = direction(neighbor_max_tiles[tile_index(id.x, id.y)]);
    var sum = 0.0;
    var count = 0.0;
    for (var dy = -1i; dy <= 1i; dy++) {
        for (var dx = -1i; dx <= 1i; dx++) {
            let nx = i32(id.x) + dx;
            let ny = i32(id.y) + dy;
            if nx < 0i || ny < 0i || nx >= i32(params.tiles_x) || ny >= i32(params.tiles_y) {
                continue;
            }
            let m = direction(neighbor_max_tiles[tile_index(u32(nx), u32(ny))]);
            sum += abs(dot2(n, m));
            count += 1.0;
        }
    }
    variance[tile_index(id.x, id.y)] = max(1.0 - sum / count, 0.0);
}
