// The motion blur filters' shared declarations and functions, twin of
// `crates/render/src/filters/common.rs` (same names, same f32 operations in the same order).
// Include with `//! include filters_common`. Every pass binds the same group 0, so one
// bind group serves them all; each pass reads and writes only what its twin does.

struct Params {
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    tile: u32,
    samples: u32,
    seed: u32,
    variance: u32,
    soft_z_extent: f32,
    tau: f32,
    kappa: f32,
    eta: f32,
    gamma: f32,
    phi: f32,
    // Reciprocals computed on the host (see `PassParams::inv_samples_plus_one`).
    inv_samples_plus_one: f32,
    inv_tile: f32,
    inv_soft_z_extent: f32,
    inv_gamma: f32,
    jitter_scale: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
// Linear radiance, three floats per pixel, row-major.
@group(0) @binding(1) var<storage, read> color: array<f32>;
@group(0) @binding(2) var<storage, read> depth: array<f32>;
// The G-buffer's velocity (pixels per exposure), which `encode_velocity` replaces in place
// by the encoded one: half the displacement, clamped. (In place: the WebGPU default, and
// the GL backend, allow 8 storage buffers per stage.)
@group(0) @binding(3) var<storage, read_write> velocity: array<vec2<f32>>;
// TileMax of rows (`tile_max_x`), tiles_x per image row.
@group(0) @binding(4) var<storage, read_write> rows: array<vec2<f32>>;
@group(0) @binding(5) var<storage, read_write> tile_max: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read_write> neighbor_max_tiles: array<vec2<f32>>;
@group(0) @binding(7) var<storage, read_write> variance: array<f32>;
// The filtered image, three floats per pixel.
@group(0) @binding(8) var<storage, read_write> out_color: array<f32>;

const VELOCITY_EPSILON: f32 = 1.0e-5;
const HALF_PIXEL: f32 = 0.5;
const Z_MIN: f32 = 1.0e-6;

// A gather's second try scales every colour by 2^-64 and the mean back by 2^64 (exact
// powers of two; see `OVERFLOW_SCALE` in the twin), taken only where the first try's mean
// overflowed.
const OVERFLOW_SCALE: f32 = 0x1p-64f;
const OVERFLOW_UNSCALE: f32 = 0x1p+64f;

// A gather's running sums (twin: `Gathered`).
struct Gathered {
    sum: vec3<f32>,
    weight: f32,
    lo: vec3<f32>,
    hi: vec3<f32>,
}

fn gathered_start(c: vec3<f32>, w: f32, scale: f32) -> Gathered {
    return Gathered(vec3<f32>(c.x * scale * w, c.y * scale * w, c.z * scale * w), w, c, c);
}

fn gathered_add(g: ptr<function, Gathered>, c: vec3<f32>, w: f32, scale: f32) {
    (*g).weight += w;
    let s = (*g).sum;
    (*g).sum = vec3<f32>(s.x + c.x * scale * w, s.y + c.y * scale * w, s.z + c.z * scale * w);
    (*g).lo = min((*g).lo, c);
    (*g).hi = max((*g).hi, c);
}

fn gathered_mean(g: Gathered) -> vec3<f32> {
    return vec3<f32>(g.sum.x / g.weight, g.sum.y / g.weight, g.sum.z / g.weight);
}

// The mean of a gather at OVERFLOW_SCALE, multiplied back and held between the smallest and
// the largest colour gathered (only rounding can take it past them).
fn gathered_rescaled_mean(g: Gathered) -> vec3<f32> {
    let m = gathered_mean(g);
    return clamp(vec3<f32>(m.x * OVERFLOW_UNSCALE, m.y * OVERFLOW_UNSCALE, m.z * OVERFLOW_UNSCALE), g.lo, g.hi);
}

// NaN or infinite: an all-ones exponent (comparisons with NaN may be optimised away).
fn is_bad(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

fn is_bad3(c: vec3<f32>) -> bool {
    return is_bad(c.x) || is_bad(c.y) || is_bad(c.z);
}

fn dot2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.x + a.y * b.y;
}

fn length2(v: vec2<f32>) -> f32 {
    return sqrt(dot2(v, v));
}

fn scale2(v: vec2<f32>, s: f32) -> vec2<f32> {
    return vec2<f32>(v.x * s, v.y * s);
}

fn smooth_step(e0: f32, e1: f32, x: f32) -> f32 {
    let t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

fn cone(dist: f32, radius: f32) -> f32 {
    return clamp(1.0 - dist / radius, 0.0, 1.0);
}

fn cylinder(dist: f32, radius: f32) -> f32 {
    return 1.0 - smooth_step(0.95 * radius, 1.05 * radius, dist);
}

// 1 where zb is in front of or level with za (positive depths), 0 `extent` behind.
fn soft_depth_compare(za: f32, zb: f32, inv_extent: f32) -> f32 {
    return clamp(1.0 - (zb - za) * inv_extent, 0.0, 1.0);
}

// Guertin et al.'s relative comparison, the sign fixed for positive depths.
fn z_compare(za: f32, zb: f32) -> f32 {
    let d = zb - za;
    if d <= 0.0 {
        return 1.0;
    }
    return clamp(1.0 - d / max(min(za, zb), Z_MIN), 0.0, 1.0);
}

fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn to_unit(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

fn pixel_hash(x: u32, y: u32, seed: u32) -> u32 {
    return pcg_hash(x + pcg_hash(y + pcg_hash(seed)));
}

fn hash_jitter(x: u32, y: u32, seed: u32) -> f32 {
    return to_unit(pixel_hash(x, y, seed)) - 0.5;
}

fn halton_jitter(x: u32, y: u32, width: u32, seed: u32) -> f32 {
    let n = y * width + x + pcg_hash(seed);
    return 2.0 * to_unit(reverseBits(n)) - 1.0;
}

fn tile_offset_random(x: u32, y: u32, seed: u32) -> f32 {
    return to_unit(pixel_hash(x, y, seed ^ 0x9e3779b9u));
}

fn index(x: u32, y: u32) -> u32 {
    return y * params.width + x;
}

fn tile_index(tx: u32, ty: u32) -> u32 {
    return ty * params.tiles_x + tx;
}

fn offset_pixel(x: u32, y: u32, o: vec2<f32>) -> vec2<u32> {
    let sx = clamp(f32(x) + floor(o.x + 0.5), 0.0, f32(params.width - 1u));
    let sy = clamp(f32(y) + floor(o.y + 0.5), 0.0, f32(params.height - 1u));
    return vec2<u32>(u32(sx), u32(sy));
}

fn load_color(i: u32) -> vec3<f32> {
    return vec3<f32>(color[3u * i], color[3u * i + 1u], color[3u * i + 2u]);
}

fn store_color(i: u32, c: vec3<f32>) {
    out_color[3u * i] = c.x;
    out_color[3u * i + 1u] = c.y;
    out_color[3u * i + 2u] = c.z;
}
