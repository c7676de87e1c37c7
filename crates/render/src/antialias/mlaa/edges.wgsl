// MLAA pass 1, edge detection: one invocation per texel of the edges texture, which has a
// one-texel border of zeros around the image; (west, north) as 0 or 1. Two entry points:
// from the display values' luminance, and from inverse view depth. The CPU twin is
// `render::antialias::mlaa::edges` (`edgels`, `detect_edge`, `detect_edges`,
// `detect_depth_edge`, `detect_depth_edges`).
//! include mlaa_common

@group(0) @binding(1) var<storage, read> color: array<vec4<f32>>;
@group(0) @binding(2) var edges_out: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(3) var<storage, read> inverse_depth: array<f32>;

fn lum_at(x: u32, y: u32) -> f32 {
    return luminance(color[y * params.width + x].xyz);
}

// The west and north edgels of pixel (x, y) whose value is `v`, its western and northern
// neighbours' `west` and `north` (read at the pixel itself on the image's first column and row).
fn edgels(v: f32, west: f32, north: f32, x: u32, y: u32) -> vec2<f32> {
    var e = vec2<f32>(0.0, 0.0);
    if x > 0u && is_edge(v, west, params.threshold) {
        e.x = 1.0;
    }
    if y > 0u && is_edge(v, north, params.threshold) {
        e.y = 1.0;
    }
    return e;
}

fn detect_edge(x: u32, y: u32) -> vec2<f32> {
    return edgels(lum_at(x, y), lum_at(max(x, 1u) - 1u, y), lum_at(x, max(y, 1u) - 1u), x, y);
}

fn depth_at(x: u32, y: u32) -> f32 {
    return inverse_depth[y * params.width + x];
}

fn detect_depth_edge(x: u32, y: u32) -> vec2<f32> {
    return edgels(depth_at(x, y), depth_at(max(x, 1u) - 1u, y), depth_at(x, max(y, 1u) - 1u), x, y);
}

fn inside(gid: vec3<u32>) -> bool {
    return gid.x >= 1u && gid.y >= 1u && gid.x <= params.width && gid.y <= params.height;
}

@compute @workgroup_size(8, 8, 1)
fn detect_edges(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width + 2u || gid.y >= params.height + 2u {
        return;
    }
    var e = vec2<f32>(0.0, 0.0);
    if inside(gid) {
        e = detect_edge(gid.x - 1u, gid.y - 1u);
    }
    textureStore(edges_out, vec2<i32>(gid.xy), vec4<f32>(e, 0.0, 0.0));
}

@compute @workgroup_size(8, 8, 1)
fn detect_depth_edges(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width + 2u || gid.y >= params.height + 2u {
        return;
    }
    var e = vec2<f32>(0.0, 0.0);
    if inside(gid) {
        e = detect_depth_edge(gid.x - 1u, gid.y - 1u);
    }
    textureStore(edges_out, vec2<i32>(gid.xy), vec4<f32>(e, 0.0, 0.0));
}
