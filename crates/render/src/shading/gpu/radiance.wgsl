// The f32 shading layer on the GPU: the frame's parameters and buffers, the scene's
// geometry, the environment's tables and importance sampling, the materials and the
// integrator (`radiance`, `radiance_from`). The tracer's kernel (`trace_batch.wgsl`) and the
// analytic kernel (`analytic_pixel.wgsl`) include it. The CPU twin is
// `render::shading::gpu::radiance` (same function names, same operations in the same order);
// read its docs for what differs from the f64 tracer and why. Specialised per frame by the
// override constants TIME_SAMPLING and MATERIAL (0 flat, 1 checker, 2 noise).
//! include sampler32

override TIME_SAMPLING: bool = true;
override MATERIAL: u32 = 2u;
// Camera samples jittered within the pixel; false: all through its centre (the tracer's
// kernel reads it, the analytic kernel samples pixel centres anyway).
override PIXEL_JITTER: bool = true;

struct FrameParams {
    cam_origin: vec4<f32>,
    cam_corner: vec4<f32>,
    cam_step_x: vec4<f32>,
    cam_step_y: vec4<f32>,
    centre_open: vec4<f32>,
    travel: vec4<f32>,
    wrap_jump: vec4<f32>,
    w2o_row0: vec4<f32>,
    w2o_row1: vec4<f32>,
    w2o_row2: vec4<f32>,
    spin: vec4<f32>,
    albedo_a: vec4<f32>,
    albedo_b: vec4<f32>,
    floor_albedo: vec4<f32>,
    width: u32,
    height: u32,
    eye_seed: u32,
    max_bounces: u32,
    russian_roulette_from: u32,
    octaves: u32,
    noise_seed: u32,
    env_width: u32,
    env_height: u32,
    env_cell_shift: u32,
    env_dist_width: u32,
    env_dist_height: u32,
    env_samplable: u32,
    marginal_guide_len: u32,
    marginal_guide_shift: u32,
    marginal_stride: u32,
    rows_guide_len: u32,
    rows_guide_shift: u32,
    rows_stride: u32,
    off_row_edge_cos: u32,
    off_col_edge: u32,
    off_row_bins: u32,
    off_col_bins: u32,
    off_marginal: u32,
    off_rows: u32,
    env_rot_cos: f32,
    env_rot_sin: f32,
    pad: u32,
}

struct Batch {
    first_sample: u32,
    count: u32,
    pad0: u32,
    pad1: u32,
}

struct Accum {
    r: f32,
    g: f32,
    b: f32,
    nonfinite: u32,
}

@group(0) @binding(0) var<storage, read> params: FrameParams;
@group(0) @binding(1) var<storage, read> env: array<u32>;
@group(0) @binding(2) var<storage, read_write> accum: array<Accum>;
@group(0) @binding(3) var<uniform> batch: Batch;

const PI: f32 = 3.14159265358979323846;
const TAU: f32 = 6.28318530717958647692;
const FRAC_1_PI: f32 = 0.318309886183790671538;
const DIFFUSE_SPREAD: f32 = 0.25;
// 16 f32 epsilons (2^-23 each).
const HIT_POINT_ERROR: f32 = 1.9073486328125e-6;
const CDF_STEP: f32 = 1.0 / 65535.0;
const F32_MAX: f32 = 3.40282347e38;
const ONE_MINUS_EPS: f32 = 0.99999988079071044921875;

const NONE: u32 = 0u;
const SPHERE: u32 = 1u;
const FLOOR: u32 = 2u;

fn normalize3(v: vec3<f32>) -> vec3<f32> {
    return v / sqrt(dot3(v, v));
}

// dot written out, in the twin's order.
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

fn copysign(m: f32, s: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(m) & 0x7fffffffu) | (bitcast<u32>(s) & 0x80000000u));
}

fn sin_cos_turns(t: f32) -> vec2<f32> {
    let q = floor(t * 4.0 + 0.5);
    let x = (t - q * 0.25) * TAU;
    let y = x * x;
    let s = x + x * y * (-1.0 / 6.0 + y * (1.0 / 120.0 + y * (-1.0 / 5040.0 + y * (1.0 / 362880.0))));
    let c = 1.0 + y * (-0.5 + y * (1.0 / 24.0 + y * (-1.0 / 720.0 + y * (1.0 / 40320.0 + y * (-1.0 / 3628800.0)))));
    switch (i32(q) & 3) {
        case 0: { return vec2<f32>(s, c); }
        case 1: { return vec2<f32>(c, -s); }
        case 2: { return vec2<f32>(-s, -c); }
        default: { return vec2<f32>(-c, s); }
    }
}

fn atan_unit(x: f32) -> f32 {
    let reduce = x > 0.41421357;
    var z = x;
    if reduce {
        z = (x - 1.0) / (x + 1.0);
    }
    let y = z * z;
    let p = 1.0
        + y * (-1.0 / 3.0
            + y * (1.0 / 5.0 + y * (-1.0 / 7.0 + y * (1.0 / 9.0 + y * (-1.0 / 11.0 + y * (1.0 / 13.0 + y * (-1.0 / 15.0)))))));
    let r = z * p;
    if reduce {
        return 0.25 * PI + r;
    }
    return r;
}

fn atan2_poly(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let hi = max(ax, ay);
    if hi == 0.0 {
        return 0.0;
    }
    var r = atan_unit(min(ax, ay) / hi);
    if ay > ax {
        r = 0.5 * PI - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        return -r;
    }
    return r;
}

struct SphereAt {
    centre: vec3<f32>,
    radius: f32,
    spin_sc: vec2<f32>,
}

struct Hit {
    t: f32,
    point: vec3<f32>,
    normal: vec3<f32>,
    surface: u32,
}

fn intersect_sphere(o: vec3<f32>, d: vec3<f32>, centre: vec3<f32>, radius: f32) -> f32 {
    let f = o - centre;
    let b = -dot3(f, d);
    let v = f + d * b;
    let disc = radius * radius - dot3(v, v);
    if !(disc >= 0.0) {
        return -1.0;
    }
    let c = dot3(f, f) - radius * radius;
    let q = b + copysign(sqrt(disc), b);
    if q == 0.0 {
        return -1.0;
    }
    let a0 = c / q;
    let a1 = q;
    var t0 = a1;
    var t1 = a0;
    if a0 < a1 {
        t0 = a0;
        t1 = a1;
    }
    if t0 > 0.0 {
        return t0;
    }
    if t1 > 0.0 {
        return t1;
    }
    return -1.0;
}

fn sphere_blocks(o: vec3<f32>, d: vec3<f32>, centre: vec3<f32>, radius: f32) -> bool {
    let f = o - centre;
    let b = -dot3(f, d);
    let v = f + d * b;
    let disc = radius * radius - dot3(v, v);
    if !(disc >= 0.0) {
        return false;
    }
    let c = dot3(f, f) - radius * radius;
    return c < 0.0 || b > 0.0;
}

fn intersect_floor(o: vec3<f32>, d: vec3<f32>, height: f32) -> f32 {
    if d.y == 0.0 {
        return -1.0;
    }
    let t = (height - o.y) / d.y;
    if t > 0.0 && t < F32_MAX {
        return t;
    }
    return -1.0;
}

fn intersect(o: vec3<f32>, d: vec3<f32>, skip: u32, s: SphereAt, floor_height: f32) -> Hit {
    var ts = -1.0;
    if skip != SPHERE {
        ts = intersect_sphere(o, d, s.centre, s.radius);
    }
    var tf = -1.0;
    if skip != FLOOR {
        tf = intersect_floor(o, d, floor_height);
    }
    if ts > 0.0 && (tf <= 0.0 || ts <= tf) {
        let p = o + d * ts;
        let n = normalize3(p - s.centre);
        return Hit(ts, s.centre + n * s.radius, n, SPHERE);
    }
    if tf > 0.0 {
        var p = o + d * tf;
        p.y = floor_height;
        return Hit(tf, p, vec3<f32>(0.0, 1.0, 0.0), FLOOR);
    }
    return Hit(-1.0, vec3<f32>(0.0), vec3<f32>(0.0), NONE);
}

fn occluded(o: vec3<f32>, d: vec3<f32>, skip: u32, s: SphereAt, floor_height: f32) -> bool {
    if skip != FLOOR && intersect_floor(o, d, floor_height) > 0.0 {
        return true;
    }
    return skip != SPHERE && sphere_blocks(o, d, s.centre, s.radius);
}

fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let err = HIT_POINT_ERROR * (max(max(abs(p.x), abs(p.y)), abs(p.z)) + 1.0);
    return p + n * err;
}

fn is_bad(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

fn is_finite3(v: vec3<f32>) -> bool {
    return !(is_bad(v.x) || is_bad(v.y) || is_bad(v.z));
}

// ---- Environment. ----

fn env_f32(i: u32) -> f32 {
    return bitcast<f32>(env[i]);
}

fn env_u16(offset: u32, i: u32) -> u32 {
    return (env[offset + (i >> 1u)] >> ((i & 1u) * 16u)) & 0xffffu;
}

fn env_texel(index: u32) -> vec3<f32> {
    return vec3<f32>(env_f32(3u * index), env_f32(3u * index + 1u), env_f32(3u * index + 2u));
}

fn pseudo_angle(a: f32, b: f32) -> f32 {
    let sum = abs(a) + abs(b);
    if sum == 0.0 {
        return 0.0;
    }
    let r = a / sum;
    if b >= 0.0 {
        if a >= 0.0 {
            return r;
        }
        return 4.0 + r;
    }
    return 2.0 - r;
}

fn col_after(m: vec3<f32>, j: u32) -> bool {
    let s = env_f32(params.off_col_edge + 2u * j);
    let c = env_f32(params.off_col_edge + 2u * j + 1u);
    return m.x * c + m.z * s >= 0.0;
}

struct TexelHit {
    index: u32,
    cell_x: u32,
    cell_y: u32,
    sin_theta: f32,
}

fn texel_of(d: vec3<f32>) -> TexelHit {
    let rc = params.env_rot_cos;
    let rs = params.env_rot_sin;
    let m = vec3<f32>(rc * d.x - rs * d.z, d.y, rs * d.x + rc * d.z);
    let inv_len = 1.0 / sqrt(dot3(m, m));
    let cos_theta = clamp(m.y * inv_len, -1.0, 1.0);
    let sin_theta = sqrt(m.x * m.x + m.z * m.z) * inv_len;
    let w = params.env_width;
    let h = params.env_height;
    let row_bins = 16u * h;
    let kr = min(u32((1.0 - cos_theta) * (0.5 * f32(row_bins))), row_bins - 1u);
    var y = env[params.off_row_bins + kr];
    while y + 1u < h && cos_theta <= env_f32(params.off_row_edge_cos + y + 1u) {
        y += 1u;
    }
    while y > 0u && cos_theta > env_f32(params.off_row_edge_cos + y) {
        y -= 1u;
    }
    let col_bins = 4u * w;
    let kc = min(u32(pseudo_angle(m.x, -m.z) * (0.25 * f32(col_bins))), col_bins - 1u);
    var x = env[params.off_col_bins + kc];
    for (var i = 0; i < 4; i++) {
        if !col_after(m, x) {
            if x == 0u {
                x = w - 1u;
            } else {
                x = x - 1u;
            }
        } else if col_after(m, x + 1u) {
            if x + 1u == w {
                x = 0u;
            } else {
                x = x + 1u;
            }
        } else {
            break;
        }
    }
    let shift = params.env_cell_shift;
    return TexelHit(y * w + x, x >> shift, y >> shift, sin_theta);
}

fn cell_density(x: u32, y: u32) -> f32 {
    if params.env_samplable == 0u {
        return 0.0;
    }
    let m = params.off_marginal;
    let row_cdf = params.marginal_guide_len;
    let p_row = f32(env_u16(m, row_cdf + y + 1u) - env_u16(m, row_cdf + y)) * CDF_STEP;
    let base = y * params.rows_stride + params.rows_guide_len;
    let p_col = f32(env_u16(params.off_rows, base + x + 1u) - env_u16(params.off_rows, base + x)) * CDF_STEP;
    return p_row * p_col * f32(params.env_dist_width * params.env_dist_height);
}

struct CdfSample {
    cell: u32,
    f: f32,
    p: f32,
}

fn cdf_sample(offset: u32, row: u32, guide_len: u32, guide_shift: u32, stride: u32, width: u32, u: f32) -> CdfSample {
    let base = row * stride;
    let t = u * 65535.0;
    let ti = min(u32(t), 65534u);
    let k = ti >> guide_shift;
    var x = env_u16(offset, base + k);
    var hi = width - 1u;
    if k + 1u < guide_len {
        hi = env_u16(offset, base + k + 1u);
    }
    let cdf = base + guide_len;
    while x < hi && env_u16(offset, cdf + x + 1u) <= ti {
        x += 1u;
    }
    let start = f32(env_u16(offset, cdf + x));
    let cell = f32(env_u16(offset, cdf + x + 1u) - env_u16(offset, cdf + x));
    let f = clamp((t - start) / cell, 0.0, ONE_MINUS_EPS);
    return CdfSample(x, f, cell * CDF_STEP);
}

struct EnvSample {
    direction: vec3<f32>,
    density: f32,
    jacobian: f32,
    texel: u32,
}

fn env_sample(u: vec2<f32>) -> EnvSample {
    let none = EnvSample(vec3<f32>(0.0), 0.0, 0.0, 0u);
    if params.env_samplable == 0u {
        return none;
    }
    let wd = params.env_dist_width;
    let hd = params.env_dist_height;
    let ys = cdf_sample(params.off_marginal, 0u, params.marginal_guide_len, params.marginal_guide_shift, params.marginal_stride, hd, u.x);
    let xs = cdf_sample(params.off_rows, ys.cell, params.rows_guide_len, params.rows_guide_shift, params.rows_stride, wd, u.y);
    let density = ys.p * xs.p * f32(wd * hd);
    if density <= 0.0 {
        return none;
    }
    let st = sin_cos_turns(0.5 * (f32(ys.cell) + ys.f) / f32(hd));
    let sp = sin_cos_turns((f32(xs.cell) + xs.f) / f32(wd));
    let sin_theta = st.x;
    if sin_theta <= 0.0 {
        return none;
    }
    let f = 1u << params.env_cell_shift;
    let px = clamp(u32((f32(xs.cell) + xs.f) * f32(f)), xs.cell * f, xs.cell * f + f - 1u);
    let py = clamp(u32((f32(ys.cell) + ys.f) * f32(f)), ys.cell * f, ys.cell * f + f - 1u);
    let m = vec3<f32>(sp.x * sin_theta, st.y, -sp.y * sin_theta);
    let rc = params.env_rot_cos;
    let rs = params.env_rot_sin;
    let world = vec3<f32>(rc * m.x + rs * m.z, m.y, -rs * m.x + rc * m.z);
    return EnvSample(world, density, 2.0 * PI * PI * sin_theta, py * params.env_width + px);
}

// ---- Materials. ----

fn smooth_step(e0: f32, e1: f32, x: f32) -> f32 {
    let t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

fn fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

fn grad_dot(h: u32, d: vec3<f32>) -> f32 {
    switch h {
        case 0u: { return d.x + d.y; }
        case 1u: { return -d.x + d.y; }
        case 2u: { return d.x - d.y; }
        case 3u: { return -d.x - d.y; }
        case 4u: { return d.x + d.z; }
        case 5u: { return -d.x + d.z; }
        case 6u: { return d.x - d.z; }
        case 7u: { return -d.x - d.z; }
        case 8u: { return d.y + d.z; }
        case 9u: { return -d.y + d.z; }
        case 10u: { return d.y - d.z; }
        default: { return -d.y - d.z; }
    }
}

// 64-bit unsigned arithmetic on (hi, lo) pairs, for the CPU's splitmix64 lattice hash.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let lo = (mid << 16u) | (p00 & 0xffffu);
    let hi = p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return vec2<u32>(hi, lo);
}

fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let w = mul_wide(a.y, b.y);
    return vec2<u32>(w.x + a.y * b.x + a.x * b.y, w.y);
}

fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.y + b.y;
    var carry = 0u;
    if lo < a.y {
        carry = 1u;
    }
    return vec2<u32>(a.x + b.x + carry, lo);
}

fn shr64(a: vec2<u32>, n: u32) -> vec2<u32> {
    // 0 < n < 32.
    return vec2<u32>(a.x >> n, (a.y >> n) | (a.x << (32u - n)));
}

fn splitmix64(z0: vec2<u32>) -> vec2<u32> {
    var z = add64(z0, vec2<u32>(0x9e3779b9u, 0x7f4a7c15u));
    z = mul64(z ^ shr64(z, 30u), vec2<u32>(0xbf58476du, 0x1ce4e5b9u));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x94d049bbu, 0x133111ebu));
    return z ^ shr64(z, 31u);
}

// An i32 sign-extended to 64 bits.
fn widen(x: i32) -> vec2<u32> {
    var hi = 0u;
    if x < 0 {
        hi = 0xffffffffu;
    }
    return vec2<u32>(hi, bitcast<u32>(x));
}

// `render::shading::material::lattice_hash(x, y, z, seed) % 12`.
fn lattice_gradient(x: i32, y: i32, z: i32, seed: u32) -> u32 {
    let hx = mul64(widen(x), vec2<u32>(0u, 0x8da6b343u));
    let hy = mul64(widen(y), vec2<u32>(0u, 0xd8163841u));
    let hz = mul64(widen(z), vec2<u32>(0u, 0xcb1ab31fu));
    let h = splitmix64(hx ^ hy ^ hz ^ vec2<u32>(seed, 0u));
    // 2^32 = 4 (mod 12).
    return ((h.x % 12u) * 4u + h.y % 12u) % 12u;
}

fn gradient_noise(q: vec3<f32>, seed: u32) -> f32 {
    let cell = floor(q);
    let f = q - cell;
    let ix = i32(cell.x);
    let iy = i32(cell.y);
    let iz = i32(cell.z);
    let u = fade(f.x);
    let v = fade(f.y);
    let w = fade(f.z);
    var c: array<f32, 8>;
    for (var k = 0; k < 8; k++) {
        let dx = k & 1;
        let dy = (k >> 1u) & 1;
        let dz = (k >> 2u) & 1;
        let h = lattice_gradient(ix + dx, iy + dy, iz + dz, seed);
        c[k] = grad_dot(h, f - vec3<f32>(f32(dx), f32(dy), f32(dz)));
    }
    let x00 = c[0] + (c[1] - c[0]) * u;
    let x10 = c[2] + (c[3] - c[2]) * u;
    let x01 = c[4] + (c[5] - c[4]) * u;
    let x11 = c[6] + (c[7] - c[6]) * u;
    let y0 = x00 + (x10 - x00) * v;
    let y1 = x01 + (x11 - x01) * v;
    return y0 + (y1 - y0) * w;
}

fn filtered_noise(q: vec3<f32>, footprint: f32) -> f32 {
    var sum = 0.0;
    var norm = 0.0;
    var freq = params.albedo_a.w;
    var amp = 1.0;
    for (var k = 0u; k < params.octaves; k++) {
        norm += amp;
        let w = 1.0 - smooth_step(0.25, 0.5, freq * footprint);
        if w > 0.0 {
            sum += amp * w * gradient_noise(q * freq, params.noise_seed + k * 0x9e3779b9u);
        }
        freq *= 2.0;
        amp *= 0.5;
    }
    if norm > 0.0 {
        return sum / norm;
    }
    return 0.0;
}

const NOISE_GAIN: f32 = 2.2;

fn texture(local: vec3<f32>, footprint: f32) -> vec3<f32> {
    let a = params.albedo_a.xyz;
    let b = params.albedo_b.xyz;
    if MATERIAL == 1u {
        let lon = atan2_poly(local.z, local.x);
        let y = clamp(local.y, -1.0, 1.0);
        let lat = atan2_poly(y, sqrt(max(1.0 - y * y, 0.0)));
        let u = (lon / TAU + 0.5) * params.albedo_a.w;
        let v = (lat / PI + 0.5) * params.albedo_b.w;
        if ((i32(floor(u)) + i32(floor(v))) & 1) == 0 {
            return a;
        }
        return b;
    }
    let n = filtered_noise(local, footprint);
    let s = clamp(0.5 + NOISE_GAIN * n, 0.0, 1.0);
    return a + (b - a) * s;
}

fn to_object(s: SphereAt, v: vec3<f32>) -> vec3<f32> {
    var r = v;
    if TIME_SAMPLING {
        let k = params.spin.xyz;
        let sn = s.spin_sc.x;
        let cs = s.spin_sc.y;
        r = v * cs + cross3(k, v) * sn + k * (dot3(k, v) * (1.0 - cs));
    }
    return vec3<f32>(dot3(params.w2o_row0.xyz, r), dot3(params.w2o_row1.xyz, r), dot3(params.w2o_row2.xyz, r));
}

fn surface_albedo(s: SphereAt, hit: Hit, footprint: f32, dir: vec3<f32>) -> vec3<f32> {
    if hit.surface == FLOOR {
        return params.floor_albedo.xyz;
    }
    if MATERIAL == 0u {
        return params.albedo_a.xyz;
    }
    let local = to_object(s, (hit.point - s.centre) / s.radius);
    let cos = max(abs(dot3(hit.normal, dir)), 0.05);
    return texture(local, footprint / (s.radius * sqrt(cos)));
}

struct Direction {
    dir: vec3<f32>,
    pdf: f32,
}

fn cosine_sample(n: vec3<f32>, u: vec2<f32>) -> Direction {
    let r = sqrt(u.x);
    let sc = sin_cos_turns(u.y);
    let z = sqrt(max(1.0 - u.x, 0.0));
    let sign = copysign(1.0, n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return Direction(t * (r * sc.y) + bt * (r * sc.x) + n * z, z * FRAC_1_PI);
}

fn radiance(s: SphereAt, seed: u32, index: u32, camera_dir: vec3<f32>) -> vec3<f32> {
    let first = intersect(params.cam_origin.xyz, camera_dir, NONE, s, params.wrap_jump.w);
    return radiance_from(s, seed, index, camera_dir, first);
}

// Radiance along a camera ray whose first hit is `first` (the analytic rasterizer gives its
// own; `radiance` intersects the scene).
fn radiance_from(s: SphereAt, seed: u32, index: u32, camera_dir: vec3<f32>, first: Hit) -> vec3<f32> {
    let floor_h = params.wrap_jump.w;
    var d = camera_dir;
    var hit = first;
    var l = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    var prev_bsdf_pdf = 0.0;
    var cone_width = 0.0;
    var spread = params.cam_origin.w;
    var bounce = 0u;
    loop {
        if hit.surface == NONE {
            let th = texel_of(d);
            let le = env_texel(th.index);
            if bounce == 0u {
                l += beta * le;
            } else {
                var density = 0.0;
                if th.sin_theta > 0.0 {
                    density = cell_density(th.cell_x, th.cell_y);
                }
                let jacobian = 2.0 * PI * PI * th.sin_theta;
                var w = 1.0;
                if density > 0.0 {
                    let pj = prev_bsdf_pdf * jacobian;
                    w = pj * pj / (pj * pj + density * density);
                }
                l += beta * le * w;
            }
            break;
        }
        if bounce == params.max_bounces {
            break;
        }
        let base = DIM_BOUNCE_BASE + bounce * DIM_PER_BOUNCE;
        let u_light = sampler32_2d(seed, index, base + DIM_LIGHT);
        let u_bsdf = sampler32_2d(seed, index, base + DIM_BSDF);
        var leave_skip = hit.surface;
        if dot3(hit.normal, d) > 0.0 {
            hit.normal = -hit.normal;
            if hit.surface == SPHERE {
                leave_skip = NONE;
            }
        }
        let footprint = cone_width + hit.t * spread;
        let albedo = surface_albedo(s, hit, footprint, d);
        let ls = env_sample(u_light);
        if ls.density > 0.0 {
            let cos = dot3(hit.normal, ls.direction);
            if cos > 0.0 {
                let so = offset_origin(hit.point, hit.normal);
                if !occluded(so, ls.direction, leave_skip, s, floor_h) {
                    let b = cos * FRAC_1_PI;
                    let bj = b * ls.jacobian;
                    let weight = b * ls.density * ls.jacobian / (ls.density * ls.density + bj * bj);
                    l += beta * albedo * env_texel(ls.texel) * weight;
                }
            }
        }
        let next = cosine_sample(hit.normal, u_bsdf);
        if !(next.pdf > 0.0) {
            break;
        }
        beta *= albedo;
        bounce += 1u;
        if bounce >= params.russian_roulette_from {
            let survive = clamp(max(max(beta.x, beta.y), beta.z), 0.05, 1.0);
            if survive < 1.0 {
                if sampler32_1d(seed, index, base + DIM_ROULETTE) >= survive {
                    break;
                }
                beta /= survive;
            }
        }
        if beta.x == 0.0 && beta.y == 0.0 && beta.z == 0.0 {
            break;
        }
        let o = offset_origin(hit.point, hit.normal);
        d = next.dir;
        prev_bsdf_pdf = next.pdf;
        cone_width = footprint;
        spread = max(spread, DIFFUSE_SPREAD);
        hit = intersect(o, d, leave_skip, s, floor_h);
    }
    return l;
}
