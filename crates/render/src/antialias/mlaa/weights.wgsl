// MLAA pass 2, blending weights: one invocation per pixel; for each edgel of its north and
// west boundaries, the distances to the line's ends by the bilinear search (two edgels per
// fetch), the crossing edges by a quarter-offset bilinear fetch, and the areas from the area
// texture. The CPU twin is `render::antialias::mlaa::weights` (same function names); the
// area texture is `render::antialias::mlaa::area`, uploaded once. Needs the constants
// AREA_SIDE and AREA_WIDTH.
//! include mlaa_common

@group(0) @binding(1) var edges_tex: texture_2d<f32>;
@group(0) @binding(2) var edges_sampler: sampler;
@group(0) @binding(3) var<storage, read> area_tex: array<vec2<f32>>;
@group(0) @binding(4) var<storage, read_write> weights: array<vec4<f32>>;

// The bilinear fetch at (u, v) in texel units of the padded texture.
fn fetch_linear(u: f32, v: f32) -> vec2<f32> {
    let size = vec2<f32>(f32(params.width + 2u), f32(params.height + 2u));
    return textureSampleLevel(edges_tex, edges_sampler, vec2<f32>(u, v) / size, 0.0).xy;
}

fn texel(t: vec2<i32>) -> vec2<f32> {
    let last = vec2<i32>(i32(params.width) + 1, i32(params.height) + 1);
    return textureLoad(edges_tex, clamp(t, vec2<i32>(0, 0), last), 0).xy;
}

fn channel(v: vec2<f32>, c: u32) -> f32 {
    if c == 0u {
        return v.x;
    }
    return v.y;
}

fn search(t: vec2<i32>, d: vec2<i32>, c: u32, max_d: u32) -> u32 {
    let steps = (max_d + 1u) / 2u;
    var n = 0u;
    for (var k = 0; k < i32(steps); k++) {
        let near = t + d * (2 * k + 1);
        let far = t + d * (2 * k + 2);
        let p = 0.5 * vec2<f32>(near + far) + 0.5;
        let e = channel(fetch_linear(p.x, p.y), c);
        if e > 0.9 {
            n += 2u;
            continue;
        }
        if e > 0.25 && channel(texel(near), c) > 0.5 {
            n += 1u;
        }
        break;
    }
    return min(n, max_d);
}

// The crossing class of a quarter-offset fetch: 0 none, 1 opposite, 2 current, 3 both.
fn crossing(e: f32) -> u32 {
    let r = i32(round(4.0 * e));
    if r == 1 {
        return 1u;
    }
    if r == 3 {
        return 2u;
    }
    if r == 4 {
        return 3u;
    }
    return 0u;
}

fn area(c1: u32, c2: u32, left: u32, right: u32) -> vec2<f32> {
    return area_tex[(c2 * AREA_SIDE + right) * AREA_WIDTH + c1 * AREA_SIDE + left];
}

fn blending_weight(x: u32, y: u32) -> vec4<f32> {
    let t = vec2<i32>(i32(x) + 1, i32(y) + 1);
    let e = texel(t);
    var w = vec4<f32>(0.0, 0.0, 0.0, 0.0);
    if e.y > 0.5 {
        let left = search(t, vec2<i32>(-1, 0), 1u, params.search_distance);
        let right = search(t, vec2<i32>(1, 0), 1u, params.search_distance);
        let v = f32(t.y) + 0.25;
        let e1 = fetch_linear(f32(t.x - i32(left)) + 0.5, v).x;
        let e2 = fetch_linear(f32(t.x + i32(right) + 1) + 0.5, v).x;
        let a = area(crossing(e1), crossing(e2), left, right);
        w.x = a.x;
        w.y = a.y;
    }
    if e.x > 0.5 {
        let up = search(t, vec2<i32>(0, -1), 0u, params.search_distance);
        let down = search(t, vec2<i32>(0, 1), 0u, params.search_distance);
        let u = f32(t.x) + 0.25;
        let e1 = fetch_linear(u, f32(t.y - i32(up)) + 0.5).y;
        let e2 = fetch_linear(u, f32(t.y + i32(down) + 1) + 0.5).y;
        let a = area(crossing(e1), crossing(e2), up, down);
        w.z = a.x;
        w.w = a.y;
    }
    return w;
}

@compute @workgroup_size(8, 8, 1)
fn blending_weights(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    weights[gid.y * params.width + gid.x] = blending_weight(gid.x, gid.y);
}
