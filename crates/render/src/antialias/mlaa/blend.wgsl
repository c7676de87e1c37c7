// MLAA pass 3, blending with the 4-neighbourhood: one invocation per pixel. The CPU twin is
// `render::antialias::mlaa::blend` (`blend_pixel`, `blend`).
//! include mlaa_common

@group(0) @binding(1) var<storage, read> color: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> weights: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> out_color: array<vec4<f32>>;

fn mix3(a: vec3<f32>, b: vec3<f32>, t: f32) -> vec3<f32> {
    return a + (b - a) * t;
}

fn blend_pixel(x: u32, y: u32) -> vec3<f32> {
    let w = params.width;
    let i = y * w + x;
    let own = weights[i];
    var south = 0.0;
    if y + 1u < params.height {
        south = weights[i + w].y;
    }
    var east = 0.0;
    if x + 1u < w {
        east = weights[i + 1u].w;
    }
    let c = color[i].xyz;
    var sum = vec3<f32>(0.0, 0.0, 0.0);
    var total = 0.0;
    if own.x > 0.0 && y > 0u {
        sum = sum + mix3(c, color[i - w].xyz, own.x) * own.x;
        total += own.x;
    }
    if south > 0.0 {
        sum = sum + mix3(c, color[i + w].xyz, south) * south;
        total += south;
    }
    if own.z > 0.0 && x > 0u {
        sum = sum + mix3(c, color[i - 1u].xyz, own.z) * own.z;
        total += own.z;
    }
    if east > 0.0 {
        sum = sum + mix3(c, color[i + 1u].xyz, east) * east;
        total += east;
    }
    if total > 0.0 {
        return sum / total;
    }
    return c;
}

@compute @workgroup_size(8, 8, 1)
fn blend(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    out_color[gid.y * params.width + gid.x] = vec4<f32>(blend_pixel(gid.x, gid.y), 1.0);
}
