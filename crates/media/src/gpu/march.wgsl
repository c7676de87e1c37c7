// The thesis's ray marcher on the GPU (section 2.3): pass 1, the validity mask, finds each
// pixel's first non-empty segment; pass 2 marches from there with the lighting model. The
// CPU twin is `media::march` (first_segment, march); every step below follows it in order.

struct Params {
    dims: vec3<u32>,
    light_count: u32,
    eye: vec3<f32>,
    step: f32,
    corner: vec3<f32>,
    sigma_t: f32,
    du: vec3<f32>,
    albedo: f32,
    dv: vec3<f32>,
    threshold: f32,
    alpha_colour: vec3<f32>,
    model: u32,
    width: u32,
    height: u32,
    use_mask: u32,
    use_distance: u32,
    shade_empty: u32,
    voxel_length: f32,
};

struct Light {
    direction: vec4<f32>,
    irradiance: vec4<f32>,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> density_grid: array<f32>;
@group(0) @binding(2) var<storage, read> distance_map: array<f32>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read_write> mask: array<i32>;
@group(0) @binding(5) var<storage, read_write> result: array<vec4<f32>>;

const MODEL_ALPHA: u32 = 0u;
const MODEL_PRIMARY: u32 = 1u;
const MODEL_SHADOW: u32 = 2u;
const TENT_REACH: f32 = 1.7320508;
const NO_LIMIT: f32 = 1e9;
const PI: f32 = 3.14159265358979;

fn voxel(i: u32, j: u32, k: u32) -> f32 {
    return density_grid[i + params.dims.x * (j + params.dims.y * k)];
}

fn density(p: vec3<f32>) -> f32 {
    if (any(p < vec3<f32>(0.0)) || any(p > vec3<f32>(1.0))) {
        return 0.0;
    }
    let n = vec3<f32>(params.dims);
    let g = clamp(p * n - vec3<f32>(0.5), vec3<f32>(0.0), n - vec3<f32>(1.0));
    let f = floor(g);
    let lo = vec3<u32>(f);
    let hi = min(lo + vec3<u32>(1u), params.dims - vec3<u32>(1u));
    let t = g - f;
    let x00 = voxel(lo.x, lo.y, lo.z) + (voxel(hi.x, lo.y, lo.z) - voxel(lo.x, lo.y, lo.z)) * t.x;
    let x10 = voxel(lo.x, hi.y, lo.z) + (voxel(hi.x, hi.y, lo.z) - voxel(lo.x, hi.y, lo.z)) * t.x;
    let x01 = voxel(lo.x, lo.y, hi.z) + (voxel(hi.x, lo.y, hi.z) - voxel(lo.x, lo.y, hi.z)) * t.x;
    let x11 = voxel(lo.x, hi.y, hi.z) + (voxel(hi.x, hi.y, hi.z) - voxel(lo.x, hi.y, hi.z)) * t.x;
    let y0 = x00 + (x10 - x00) * t.y;
    let y1 = x01 + (x11 - x01) * t.y;
    return y0 + (y1 - y0) * t.z;
}

// The ray's interval inside the unit cube; x > y when it misses.
fn cube_interval(origin: vec3<f32>, direction: vec3<f32>) -> vec2<f32> {
    let inv = vec3<f32>(1.0) / direction;
    let t0 = (vec3<f32>(0.0) - origin) * inv;
    let t1 = (vec3<f32>(1.0) - origin) * inv;
    let near = min(t0, t1);
    let far = max(t0, t1);
    let enter = max(max(max(near.x, near.y), near.z), 0.0);
    let exit = min(min(far.x, far.y), far.z);
    return vec2<f32>(enter, exit);
}

// Whole segments the distance map lets a ray skip from p.
fn skippable(p: vec3<f32>) -> u32 {
    if (params.use_distance == 0u) {
        return 0u;
    }
    let n = vec3<f32>(params.dims);
    let g = p * n - vec3<f32>(0.5);
    let c = clamp(round(g), vec3<f32>(0.0), n - vec3<f32>(1.0));
    let off = g - c;
    let ci = vec3<u32>(c);
    let stored = min(distance_map[ci.x + params.dims.x * (ci.y + params.dims.y * ci.z)], NO_LIMIT);
    let free_voxels = stored - sqrt(dot(off, off)) - TENT_REACH;
    let free = free_voxels * params.voxel_length;
    return u32(clamp(floor(free / params.step) - 1.0, 0.0, NO_LIMIT));
}

// The segments to skip after a sample of density rho at p: none inside the medium.
fn skip_from(rho: f32, p: vec3<f32>) -> u32 {
    if (rho > 0.0) {
        return 0u;
    }
    return skippable(p);
}

// Segment i clipped to [enter, exit]: (midpoint, length); length <= 0 when past the end.
fn segment(i: u32, enter: f32, exit: f32) -> vec2<f32> {
    let a = max(f32(i) * params.step, enter);
    let b = min(f32(i + 1u) * params.step, exit);
    return vec2<f32>(0.5 * (a + b), b - a);
}

fn pixel_ray(x: u32, y: u32) -> vec3<f32> {
    let target_point = params.corner + (f32(x) + 0.5) * params.du + (f32(y) + 0.5) * params.dv;
    return normalize(target_point - params.eye);
}

fn shadow(p: vec3<f32>, direction: vec3<f32>) -> f32 {
    let span = cube_interval(p, direction);
    if (!(span.y > span.x)) {
        return 1.0;
    }
    var depth = 0.0;
    var i = u32(floor(span.x / params.step));
    loop {
        let s = segment(i, span.x, span.y);
        if (!(s.y > 0.0)) {
            break;
        }
        let q = p + s.x * direction;
        let rho = density(q);
        depth += params.sigma_t * rho * s.y;
        i = i + 1u + skip_from(rho, q);
    }
    return exp(-depth);
}

@compute @workgroup_size(8, 8)
fn validity_mask(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let pixel = id.x + params.width * id.y;
    let direction = pixel_ray(id.x, id.y);
    let span = cube_interval(params.eye, direction);
    var first = -1;
    if (span.y > span.x) {
        var i = u32(floor(span.x / params.step));
        loop {
            let s = segment(i, span.x, span.y);
            if (!(s.y > 0.0)) {
                break;
            }
            let p = params.eye + s.x * direction;
            let rho = density(p);
            if (rho > params.threshold) {
                first = i32(i);
                break;
            }
            i = i + 1u + skip_from(rho, p);
        }
    }
    mask[pixel] = first;
}

@compute @workgroup_size(8, 8)
fn march(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let pixel = id.x + params.width * id.y;
    var radiance = vec3<f32>(0.0);
    var transmittance = 1.0;
    let direction = pixel_ray(id.x, id.y);
    let span = cube_interval(params.eye, direction);
    if (!(span.y > span.x)) {
        result[pixel] = vec4<f32>(radiance, transmittance);
        return;
    }
    var i = u32(floor(span.x / params.step));
    if (params.use_mask != 0u) {
        let first = mask[pixel];
        if (first < 0) {
            result[pixel] = vec4<f32>(radiance, transmittance);
            return;
        }
        i = u32(first);
    }
    var unshadowed = vec3<f32>(0.0);
    for (var n = 0u; n < params.light_count; n++) {
        unshadowed += lights[n].irradiance.xyz;
    }
    unshadowed *= params.albedo / (4.0 * PI);
    loop {
        let s = segment(i, span.x, span.y);
        if (!(s.y > 0.0)) {
            break;
        }
        let p = params.eye + s.x * direction;
        let rho = density(p);
        let sigma = params.sigma_t * rho;
        if (sigma > 0.0 || params.shade_empty != 0u) {
            var source = params.alpha_colour;
            if (params.model == MODEL_PRIMARY) {
                source = unshadowed;
            } else if (params.model == MODEL_SHADOW) {
                var lit = vec3<f32>(0.0);
                for (var n = 0u; n < params.light_count; n++) {
                    lit += lights[n].irradiance.xyz * shadow(p, lights[n].direction.xyz);
                }
                source = lit * (params.albedo / (4.0 * PI));
            }
            let tau = exp(-sigma * s.y);
            radiance += transmittance * (1.0 - tau) * source;
            transmittance *= tau;
        }
        i = i + 1u + skip_from(rho, p);
    }
    result[pixel] = vec4<f32>(radiance, transmittance);
}
