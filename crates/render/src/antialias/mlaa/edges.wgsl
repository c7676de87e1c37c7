// MLAA pass 1, edge detection: one invocation per texel of the edges texture, which has a
// one-texel border of zeros around the image; (west, north) as 0 or 1. The CPU twin is
// `render::antialias::mlaa::edges` (`detect_edge`, `detect_edges`).
//! include mlaa_common

@group(0) @binding(1) var<storage, read> color: array<vec4<f32>>;
@group(0) @binding(2) var edges_out: texture_storage_2d<rgba8unorm, write>;

fn lum_at(x: u32, y: u32) -> f32 {
    return luminance(color[y * params.width + x].xyz);
}

fn detect_edge(x: u32, y: u32) -> vec2<f32> {
    let l = lum_at(x, y);
    var e = vec2<f32>(0.0, 0.0);
    if x > 0u && is_edge(l, lum_at(x - 1u, y), params.threshold) {
        e.x = 1.0;
    }
    if y > 0u && is_edge(l, lum_at(x, y - 1u), params.threshold) {
        e.y = 1.0;
    }
    return e;
}

@compute @workgroup_size(8, 8, 1)
fn detect_edges(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width + 2u || gid.y >= params.height + 2u {
        return;
    }
    var e = vec2<f32>(0.0, 0.0);
    if gid.x >= 1u && gid.y >= 1u && gid.x <= params.width && gid.y <= params.height {
        e = detect_edge(gid.x - 1u, gid.y - 1u);
    }
    textureStore(edges_out, vec2<i32>(gid.xy), vec4<f32>(e, 0.0, 0.0));
}
