// The thesis's ray marcher on the GPU (section 2.3): pass 1, the validity mask, finds each
// pixel's first non-empty segment; pass 2 marches from there with the lighting model. The
// CPU twin is `media::march` (first_segment, march); every step below follows it in order.
// With `use_rays`, each pixel's ray comes from `rays` (a frame whose surfaces another
// renderer made): the march stops at the ray's surface, and pass 2 also writes the smoke's
// shadow on that surface (twin: `march_surface_ray`).

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
    use_rays: u32,
};

struct Light {
    direction: vec4<f32>,
    irradiance: vec4<f32>,
    // the direction in the world, for a surface's cosine
    world: vec4<f32>,
};

// origin.w: the surface's ray parameter (NO_LIMIT: none); direction.w > 0: the surface's
// shadow is wanted; point (cube's frame) and normal (world) of the surface.
struct SurfaceRay {
    origin: vec4<f32>,
    direction: vec4<f32>,
    point: vec4<f32>,
    normal: vec4<f32>,
};

struct Primary {
    origin: vec3<f32>,
    direction: vec3<f32>,
    enter: f32,
    exit: f32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> density_grid: array<f32>;
@group(0) @binding(2) var<storage, read> distance_map: array<f32>;
@group(0) @binding(3) var<storage, read> lights: array<Light>;
@group(0) @binding(4) var<storage, read_write> mask: array<i32>;
@group(0) @binding(5) var<storage, read_write> result: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> rays: array<SurfaceRay>;
@group(0) @binding(7) var<storage, read_write> surface_shadow: array<vec4<f32>>;

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

// The pixel's ray and the part of it inside the cube (before its surface); exit <= enter
// when that is empty.
fn primary(pixel: u32, x: u32, y: u32) -> Primary {
    var origin = params.eye;
    var direction = pixel_ray(x, y);
    var limit = NO_LIMIT;
    if (params.use_rays != 0u) {
        origin = rays[pixel].origin.xyz;
        direction = rays[pixel].direction.xyz;
        limit = rays[pixel].origin.w;
    }
    let span = cube_interval(origin, direction);
    return Primary(origin, direction, span.x, min(span.y, limit));
}

// The smoke's shadow on a surface: the lights' irradiance through the medium over that
// without it, per channel, 1 where no light reaches the surface's side.
fn shadow_on_surface(ray: SurfaceRay) -> vec3<f32> {
    var lit = vec3<f32>(0.0);
    var unlit = vec3<f32>(0.0);
    for (var n = 0u; n < params.light_count; n++) {
        let cosine = dot(ray.normal.xyz, lights[n].world.xyz);
        if (cosine <= 0.0) {
            continue;
        }
        let e = lights[n].irradiance.xyz * cosine;
        unlit += e;
        lit += e * shadow(ray.point.xyz, lights[n].direction.xyz);
    }
    return select(vec3<f32>(1.0), lit / unlit, unlit > vec3<f32>(0.0));
}

@compute @workgroup_size(8, 8)
fn validity_mask(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= params.width || id.y >= params.height) {
        return;
    }
    let pixel = id.x + params.width * id.y;
    let ray = primary(pixel, id.x, id.y);
    var first = -1;
    if (ray.exit > ray.enter) {
        var i = u32(floor(ray.enter / params.step));
        loop {
            let s = segment(i, ray.enter, ray.exit);
            if (!(s.y > 0.0)) {
                break;
            }
            let p = ray.origin + s.x * ray.direction;
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
    // the surface's shadow first: a surface in the smoke's shadow may be seen through no smoke
    if (params.use_rays != 0u) {
        var shadowed = vec3<f32>(1.0);
        if (params.model == MODEL_SHADOW && rays[pixel].direction.w > 0.0) {
            shadowed = shadow_on_surface(rays[pixel]);
        }
        surface_shadow[pixel] = vec4<f32>(shadowed, 1.0);
    }
    var radiance = vec3<f32>(0.0);
    var transmittance = 1.0;
    let ray = primary(pixel, id.x, id.y);
    if (!(ray.exit > ray.enter)) {
        result[pixel] = vec4<f32>(radiance, transmittance);
        return;
    }
    var i = u32(floor(ray.enter / params.step));
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
        let s = segment(i, ray.enter, ray.exit);
        if (!(s.y > 0.0)) {
            break;
        }
        let p = ray.origin + s.x * ray.direction;
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
