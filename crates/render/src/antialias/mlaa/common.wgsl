// What MLAA's three passes share: their parameters and the edge test. The CPU twins are in
// `render::antialias::mlaa::edges` (`luminance`, `is_bad`, `is_edge`).

struct Params {
    width: u32,
    height: u32,
    threshold: f32,
    search_distance: u32,
}

@group(0) @binding(0) var<uniform> params: Params;

fn luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

fn is_bad(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

fn is_edge(a: f32, b: f32, threshold: f32) -> bool {
    return !is_bad(a) && !is_bad(b) && abs(a - b) >= threshold;
}
