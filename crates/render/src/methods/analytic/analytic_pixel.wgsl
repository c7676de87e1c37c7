// The analytic motion blur rasterizer's kernel (Gribel et al. 2010; the GPU version is the
// paper's own future work): one invocation per pixel of a band of rows walks its tile's
// moving triangles, finds each one's visibility intervals at the pixel's sample point, keeps
// them in the pixel's interval list (a fixed budget per pixel in a storage buffer) with the
// opaque LESS_EQUAL insertion and the oracle compression, shades every kept interval once at
// its temporal midpoint with the tracer's own integrator (`radiance_from`), and resolves the
// list against the box shutter. The CPU twin is `render::methods::analytic::analytic_pixel` (same function
// names, same operations in the same order); the f64 rasterizer in `render::methods::analytic` is the
// reference both are tested against. Override constant SHADE: false writes coverage instead
// of radiance (the sphere's in red, the floor's in green, no background), which the tests
// compare with the f64 rasterizer without shading noise.
//! include radiance
//! include numeric

override SHADE: bool = true;

struct AnalyticParams {
    // World axes of the camera (camera space is (right, up, forward) from the eye).
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // Sample point of pixel position (0, 0) (xy) and the step per pixel (zw).
    sample_corner_step: vec4<f32>,
    width: u32,
    height: u32,
    first_row: u32,
    band_rows: u32,
    budget: u32,
    range: u32,
    lighting: u32,
    tiles_x: u32,
    // Sample points per output pixel along each axis: the image is the supersampled one, whose
    // n x n blocks are output pixels owning the shading's sample sequences.
    supersampling: u32,
    // The pixel's work is resumable (see `analytic_pixel`): `pass` 0 starts it, a later pass
    // continues from `resume`; `steps` bounds the steps one pass takes (0: no bound) and
    // `light_chunk` the lighting samples one shading step takes (0: all of them).
    pass_index: u32,
    steps: u32,
    light_chunk: u32,
    // 2: the trip count of the loop that detects a device's loop limit (a uniform, so that
    // no compiler unrolls it).
    sentinel: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// A moving triangle, set up on the host: edge k's cross-product polynomial C0 + C1 t + C2 t^2
// (edge_k[j] is Cj), the vertices at shutter open and their motion, pixel bounds
// [x0, x1) x [y0, y1), surface (1 sphere, 2 floor), two-sidedness and stillness.
struct Triangle {
    edge0: array<vec4<f32>, 3>,
    edge1: array<vec4<f32>, 3>,
    edge2: array<vec4<f32>, 3>,
    base: array<vec4<f32>, 3>,
    motion: array<vec4<f32>, 3>,
    bounds: vec4<u32>,
    // surface, two_sided, is_static, unused
    flags: vec4<u32>,
}

// One entry of a pixel's list: time span, linear depth (z at ts, slope k), radiance.
struct Interval {
    ts: f32,
    te: f32,
    z: f32,
    k: f32,
    r: f32,
    g: f32,
    b: f32,
    pad: f32,
}

// Per pixel: intervals offered, kept (shaded), merges, lighting samples dropped.
struct PixelStats {
    offered: u32,
    kept: u32,
    merges: u32,
    nonfinite: u32,
}

@group(0) @binding(4) var<uniform> ap: AnalyticParams;
@group(0) @binding(5) var<storage, read> triangles: array<Triangle>;
// tiles + 1 offsets into the triangle indices that follow them.
@group(0) @binding(6) var<storage, read> bins: array<u32>;
@group(0) @binding(7) var<storage, read_write> lists: array<Interval>;
// Per pixel: radiance (or coverage colours) and the covered fraction, then the counts.
struct PixelOut {
    color: vec4<f32>,
    stats: PixelStats,
}

@group(0) @binding(8) var<storage, read_write> out_pixels: array<PixelOut>;
// Per pixel of the band: where its work stands between passes.
@group(0) @binding(10) var<storage, read_write> resume: array<Resume>;
// [0]: pixels of this pass not yet done; [1]: pixels whose invocation group hit the
// device's loop limit during this pass (its results are void).
@group(0) @binding(11) var<storage, read_write> progress: array<atomic<u32>, 2>;

const MAX_SPANS: u32 = 8u;
const H1: f32 = 1000.0;
const H2: f32 = 100.0;
const H3: f32 = 1.0;
const H4: f32 = 100.0;
const H5: f32 = 1.0;

// ---- Edge equations and visibility (render::methods::analytic::edge). ----

fn edge_coeff(ti: u32, k: u32, j: u32) -> vec3<f32> {
    if k == 0u {
        return triangles[ti].edge0[j].xyz;
    }
    if k == 1u {
        return triangles[ti].edge1[j].xyz;
    }
    return triangles[ti].edge2[j].xyz;
}

// c . (sx, sy, 1), in the same order for every edge so a shared, reversed edge negates exactly.
fn dot_s(c: vec3<f32>, s: vec2<f32>) -> f32 {
    return c.x * s.x + c.y * s.y + c.z;
}

// (alpha, beta, gamma) of edge k at s.
fn edge_equation(ti: u32, k: u32, s: vec2<f32>) -> vec3<f32> {
    return vec3<f32>(dot_s(edge_coeff(ti, k, 2u), s), dot_s(edge_coeff(ti, k, 1u), s), dot_s(edge_coeff(ti, k, 0u), s));
}

fn eval_q(q: vec3<f32>, t: f32) -> f32 {
    return (q.x * t + q.y) * t + q.z;
}

fn vertex_at(ti: u32, i: u32, t: f32) -> vec3<f32> {
    return triangles[ti].base[i].xyz + triangles[ti].motion[i].xyz * t;
}

fn det_at(ti: u32, t: f32) -> f32 {
    return dot3(vertex_at(ti, 0u, t), cross3(vertex_at(ti, 1u, t), vertex_at(ti, 2u, t)));
}

fn depth_at_time(ti: u32, s: vec2<f32>, t: f32) -> f32 {
    let sum = eval_q(edge_equation(ti, 0u, s), t) + eval_q(edge_equation(ti, 1u, s), t) + eval_q(edge_equation(ti, 2u, s), t);
    return det_at(ti, t) / sum;
}

fn is_finite1(x: f32) -> bool {
    return !is_bad(x);
}

// Loops are few and short: Mesa's llvmpipe (lavapipe, the CI's device) ends every loop of
// an invocation group once all its loops together have run 65535 iterations
// (LP_MAX_TGSI_LOOP_ITERATIONS), so the three edges are unrolled, not looped over, tiles are
// ANALYTIC_TILE pixels wide, and a pixel's work is cut into resumable steps (see
// `analytic_pixel`); tests/analytic_gpu.rs holds the kernel to its twin.
fn edge_inside(ti: u32, k: u32, s: vec2<f32>, t: f32, sign: f32) -> bool {
    let v = eval_q(edge_equation(ti, k, s), t) * sign;
    if v != 0.0 {
        return v > 0.0;
    }
    // On the edge: the top-left rule on the edge's normal at this instant.
    let n = (edge_coeff(ti, k, 0u) + edge_coeff(ti, k, 1u) * t + edge_coeff(ti, k, 2u) * (t * t)) * sign;
    return n.x > 0.0 || (n.x == 0.0 && n.y > 0.0);
}

fn inside(ti: u32, s: vec2<f32>, t: f32, sign: f32) -> bool {
    return det_at(ti, t) * sign > 0.0 && edge_inside(ti, 0u, s, t, sign) && edge_inside(ti, 1u, s, t, sign)
        && edge_inside(ti, 2u, s, t, sign);
}

fn inside_any(ti: u32, s: vec2<f32>, t: f32) -> bool {
    if inside(ti, s, t, 1.0) {
        return true;
    }
    return triangles[ti].flags.y != 0u && inside(ti, s, t, -1.0);
}

struct Spans {
    t: array<vec2<f32>, 8>,
    n: u32,
}

fn push_span(v: ptr<function, Spans>, a: f32, b: f32) {
    let n = (*v).n;
    if n > 0u && (*v).t[n - 1u].y == a {
        (*v).t[n - 1u].y = b;
    } else if n < MAX_SPANS {
        (*v).t[n] = vec2<f32>(a, b);
        (*v).n = n + 1u;
    }
}

// Appends the roots of q in (0, 1), ascending, a double root once.
fn add_roots(q: vec3<f32>, cuts: ptr<function, array<f32, 16>>, n: ptr<function, u32>) {
    let r = solve_quadratic(q.x, q.y, q.z);
    if r.z == 0.0 {
        return;
    }
    let first = r.x > 0.0 && r.x < 1.0;
    if first {
        (*cuts)[*n] = r.x;
        *n += 1u;
    }
    if r.y > 0.0 && r.y < 1.0 && !(first && r.y == r.x) {
        (*cuts)[*n] = r.y;
        *n += 1u;
    }
}

// Whether q is below zero on all of [0, 1] by more than its evaluation's rounding.
fn negative_throughout(q: vec3<f32>) -> bool {
    let margin = 1e-5 * (abs(q.x) + abs(q.y) + abs(q.z));
    var m = max(q.z, q.x + q.y + q.z);
    if q.x < 0.0 {
        let t = -q.y / (2.0 * q.x);
        if t > 0.0 && t < 1.0 {
            m = max(m, eval_q(q, t));
        }
    }
    return m < -margin;
}

fn visibility(ti: u32, s: vec2<f32>) -> Spans {
    var vis: Spans;
    vis.n = 0u;
    // Most triangles a pixel meets miss its sample: one edge is negative all shutter long.
    if triangles[ti].flags.y == 0u
        && (negative_throughout(edge_equation(ti, 0u, s)) || negative_throughout(edge_equation(ti, 1u, s))
            || negative_throughout(edge_equation(ti, 2u, s))) {
        return vis;
    }
    if triangles[ti].flags.z != 0u {
        if inside_any(ti, s, 0.5) {
            push_span(&vis, 0.0, 1.0);
        }
        return vis;
    }
    var cuts: array<f32, 16>;
    cuts[0] = 0.0;
    var n = 1u;
    add_roots(edge_equation(ti, 0u, s), &cuts, &n);
    add_roots(edge_equation(ti, 1u, s), &cuts, &n);
    add_roots(edge_equation(ti, 2u, s), &cuts, &n);
    cuts[n] = 1.0;
    n += 1u;
    // Insertion sort (at most 8 entries).
    for (var i = 1u; i < n; i++) {
        let v = cuts[i];
        var j = i;
        while j > 0u && cuts[j - 1u] > v {
            cuts[j] = cuts[j - 1u];
            j -= 1u;
        }
        cuts[j] = v;
    }
    // Sign changes of the determinant, by bisection.
    var all: array<f32, 16>;
    var m = 0u;
    for (var w = 0u; w < n; w++) {
        if w > 0u {
            let a = cuts[w - 1u];
            let b = cuts[w];
            let da = det_at(ti, a);
            let db = det_at(ti, b);
            if b > a && da * db < 0.0 && m < 15u {
                var lo = a;
                var hi = b;
                var split = true;
                for (var it = 0u; it < 64u && split; it++) {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        split = false;
                    } else if (det_at(ti, mid) < 0.0) == (da < 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                all[m] = hi;
                m += 1u;
            }
        }
        if m < 16u {
            all[m] = cuts[w];
            m += 1u;
        }
    }
    for (var w = 1u; w < m; w++) {
        let a = all[w - 1u];
        let b = all[w];
        if b > a && inside_any(ti, s, 0.5 * (a + b)) {
            push_span(&vis, a, b);
        }
    }
    return vis;
}

// Depth at ts and the secant slope over [ts, te] (render::methods::analytic::edge::linear_depth).
fn linear_depth(ti: u32, s: vec2<f32>, ts: f32, te: f32) -> vec2<f32> {
    let mid = depth_at_time(ti, s, 0.5 * (ts + te));
    var z0 = depth_at_time(ti, s, ts);
    var z1 = depth_at_time(ti, s, te);
    if !is_finite1(z0) {
        z0 = mid;
    }
    if !is_finite1(z1) {
        z1 = mid;
    }
    if te > ts {
        return vec2<f32>(z0, (z1 - z0) / (te - ts));
    }
    return vec2<f32>(z0, 0.0);
}

// ---- Interval lists (render::methods::analytic::interval). ----

fn iv_depth(iv: Interval, t: f32) -> f32 {
    return iv.z + iv.k * (t - iv.ts);
}

fn iv_clipped(iv: Interval, ts: f32, te: f32) -> Interval {
    var c = iv;
    c.z = iv_depth(iv, ts);
    c.ts = ts;
    c.te = te;
    return c;
}

fn nearer(front: Interval, back: Interval, t0: f32, t1: f32) -> bool {
    return iv_depth(front, t0) < iv_depth(back, t0) && iv_depth(front, t1) < iv_depth(back, t1);
}

fn oracle(a: Interval, b: Interval) -> f32 {
    let z_end = a.z + a.k * (a.te - a.ts);
    let dc = abs(a.r - b.r) + abs(a.g - b.g) + abs(a.b - b.b);
    return H1 * max(b.ts - a.te, 0.0) + H2 * abs(z_end - b.z) + H3 * abs(a.k - b.k) + H4 * ((a.te - a.ts) + (b.te - b.ts)) + H5 * dc;
}

fn merge(a: Interval, b: Interval) -> Interval {
    let total = (a.te - a.ts) + (b.te - b.ts);
    var w = 0.5;
    if total > 0.0 {
        w = (b.te - b.ts) / total;
    }
    let u = 1.0 - w;
    return Interval(
        a.ts,
        max(a.te, b.te),
        u * a.z + w * (b.z - b.k * (b.ts - a.ts)),
        u * a.k + w * b.k,
        u * a.r + w * b.r,
        u * a.g + w * b.g,
        u * a.b + w * b.b,
        0.0,
    );
}

// The pixel's list: entries lists[first .. first + n).
struct List {
    first: u32,
    n: u32,
}

// Applies the opaque LESS_EQUAL rules to `new` against the list: the clipped interval, or an
// empty one (te <= ts) when it is hidden. Removes the entries it hides.
fn insert_opaque_clip(list: ptr<function, List>, new_iv: Interval) -> Interval {
    var iv = new_iv;
    let first = (*list).first;
    var hidden = false;
    for (var i = 0u; i < (*list).n && !hidden && iv.te > iv.ts; i++) {
        let e = lists[first + i];
        if e.ts <= iv.ts && e.te >= iv.te && nearer(e, iv, iv.ts, iv.te) {
            hidden = true;
        } else if e.ts <= iv.ts && e.te > iv.ts && e.te < iv.te && nearer(e, iv, iv.ts, e.te) {
            iv = iv_clipped(iv, e.te, iv.te);
        } else if e.ts > iv.ts && e.ts < iv.te && e.te >= iv.te && nearer(e, iv, e.ts, iv.te) {
            iv = iv_clipped(iv, iv.ts, e.ts);
        }
    }
    if hidden || iv.te <= iv.ts {
        iv.te = iv.ts;
        return iv;
    }
    var kept = 0u;
    for (var i = 0u; i < (*list).n; i++) {
        let e = lists[first + i];
        let hidden = iv.ts <= e.ts && iv.te >= e.te && iv_depth(iv, e.ts) <= iv_depth(e, e.ts) && iv_depth(iv, e.te) <= iv_depth(e, e.te);
        if !hidden {
            lists[first + kept] = e;
            kept += 1u;
        }
    }
    (*list).n = kept;
    return iv;
}

// Inserts `iv` after the entries with the same or an earlier start.
fn insert_sorted(list: ptr<function, List>, iv: Interval) {
    let first = (*list).first;
    var at = (*list).n;
    while at > 0u && lists[first + at - 1u].ts > iv.ts {
        lists[first + at] = lists[first + at - 1u];
        at -= 1u;
    }
    lists[first + at] = iv;
    (*list).n += 1u;
}

fn compress(list: ptr<function, List>) -> u32 {
    let first = (*list).first;
    var merges = 0u;
    while (*list).n > ap.budget {
        let n = (*list).n;
        var best = F32_MAX;
        var bi = 0u;
        var bj = 1u;
        for (var i = 0u; i < n; i++) {
            let a = lists[first + i];
            for (var j = i + 1u; j < min(i + 1u + ap.range, n); j++) {
                let o = oracle(a, lists[first + j]);
                if o < best {
                    best = o;
                    bi = i;
                    bj = j;
                }
            }
        }
        lists[first + bi] = merge(lists[first + bi], lists[first + bj]);
        for (var j = bj; j + 1u < n; j++) {
            lists[first + j] = lists[first + j + 1u];
        }
        (*list).n = n - 1u;
        merges += 1u;
    }
    return merges;
}

// ---- Resolve: each entry's share of the shutter where it is the nearest (the sweep of
// render::methods::analytic::resolve, per entry: an entry is hidden where a later entry is as near or
// an earlier one nearer). ----

fn resolve(list: List) -> vec4<f32> {
    var sum = vec3<f32>(0.0);
    var covered = 0.0;
    var hidden: array<vec2<f32>, 65>;
    for (var i = 0u; i < list.n; i++) {
        let a = lists[list.first + i];
        var m = 0u;
        for (var j = 0u; j < list.n; j++) {
            let b = lists[list.first + j];
            let lo = max(a.ts, b.ts);
            let hi = min(a.te, b.te);
            // b - a in depth, linear over [lo, hi]; b hides a where it is negative (or zero
            // for a later entry).
            let d0 = iv_depth(b, lo) - iv_depth(a, lo);
            let d1 = iv_depth(b, hi) - iv_depth(a, hi);
            let h0 = d0 < 0.0 || (d0 == 0.0 && j > i);
            let h1 = d1 < 0.0 || (d1 == 0.0 && j > i);
            if j != i && hi > lo && (h0 || h1) {
                var span = vec2<f32>(lo, hi);
                if !(h0 && h1) {
                    let x = clamp(lo + (hi - lo) * (d0 / (d0 - d1)), lo, hi);
                    span = select(vec2<f32>(x, hi), vec2<f32>(lo, x), h0);
                }
                // Insertion by start.
                var at = m;
                while at > 0u && hidden[at - 1u].x > span.x {
                    hidden[at] = hidden[at - 1u];
                    at -= 1u;
                }
                hidden[at] = span;
                m += 1u;
            }
        }
        // The union's length.
        var gone = 0.0;
        var cur = vec2<f32>(0.0, 0.0);
        var open = false;
        for (var h = 0u; h < m; h++) {
            let sp = hidden[h];
            if open && sp.x <= cur.y {
                cur.y = max(cur.y, sp.y);
            } else {
                if open {
                    gone += cur.y - cur.x;
                }
                cur = sp;
                open = true;
            }
        }
        if open {
            gone += cur.y - cur.x;
        }
        // An empty entry (te <= ts) hides nothing of itself and is seen for no time.
        let seen = max((a.te - a.ts) - gone, 0.0);
        sum += seen * vec3<f32>(a.r, a.g, a.b);
        covered += seen;
    }
    return vec4<f32>(sum, covered);
}

// ---- Shading (render::methods::analytic::shade). ----

// The sphere at fraction u of the shutter, moving in a straight line (the triangles'
// assumption: no wrap inside one exposure).
fn sphere_straight(u: f32) -> SphereAt {
    var s = SphereAt(params.centre_open.xyz, params.centre_open.w, vec2<f32>(0.0, 1.0));
    if TIME_SAMPLING {
        s.centre += params.travel.xyz * u;
        if MATERIAL != 0u {
            s.spin_sc = sin_cos_turns(-params.spin.w * u / TAU);
        }
    }
    return s;
}

fn camera_ray(s: vec2<f32>) -> vec3<f32> {
    return ap.forward.xyz + ap.right.xyz * s.x + ap.up.xyz * s.y;
}

// Where an interval is shaded: the sphere at the interval's midpoint, the hit on the surface
// the interval belongs to, and the camera ray's direction.
struct ShadePoint {
    sphere: SphereAt,
    hit: Hit,
    dir: vec3<f32>,
}

fn shade_point(ti: u32, iv: Interval, s: vec2<f32>) -> ShadePoint {
    let t = 0.5 * (iv.ts + iv.te);
    var depth = depth_at_time(ti, s, t);
    if !(is_finite1(depth) && depth > 0.0) {
        depth = iv_depth(iv, t);
    }
    let origin = params.cam_origin.xyz;
    let p = origin + camera_ray(s) * depth;
    let sphere = sphere_straight(t);
    let dir = normalize3(camera_ray(s));
    var hit: Hit;
    if triangles[ti].flags.x == SPHERE {
        // The ray's front hit on the true sphere, else the radial projection (as `shade`).
        let along = intersect_sphere(origin, dir, sphere.centre, sphere.radius);
        var point = p;
        if along > 0.0 {
            point = origin + dir * along;
        }
        var n = point - sphere.centre;
        let len2 = dot3(n, n);
        if len2 > 0.0 && is_finite1(len2) {
            n = n / sqrt(len2);
        } else {
            n = vec3<f32>(0.0, 1.0, 0.0);
        }
        if !(along > 0.0) {
            point = sphere.centre + n * sphere.radius;
        }
        let dp = point - origin;
        hit = Hit(sqrt(dot3(dp, dp)), point, n, SPHERE);
    } else {
        var point = p;
        point.y = params.wrap_jump.w;
        let dp = point - origin;
        hit = Hit(sqrt(dot3(dp, dp)), point, vec3<f32>(0.0, 1.0, 0.0), FLOOR);
    }
    return ShadePoint(sphere, hit, dir);
}

// A sky near f32's maximum makes the running sum of finite lighting samples overflow. Once
// a sample or the sum exceeds SCALE_FROM (2^100, far above any radiance of an ordinary
// scene), the sum continues scaled by 2^-64 (exact: a power of two) and the mean is scaled
// back. The test is on magnitudes, not on an overflow having happened: llvmpipe's compiler
// may assume an addition never overflows and drop a check of its result. Sums below the
// threshold take the plain additions.
const SUM_SCALE: f32 = 5.421010862427522e-20;
const SUM_UNSCALE: f32 = 18446744073709551616.0;
const SCALE_FROM: f32 = 1.2676506002282294e30;

fn needs_scaling(sum: vec3<f32>, l: vec3<f32>) -> bool {
    let m = max(abs(sum), abs(l));
    return max(m.x, max(m.y, m.z)) > SCALE_FROM;
}

fn add_lighting(sum: vec3<f32>, l: vec3<f32>, scaled: bool) -> vec3<f32> {
    if scaled {
        return sum + l * SUM_SCALE;
    }
    return sum + l;
}

fn lighting_mean(sum: vec3<f32>, scaled: bool) -> vec3<f32> {
    let mean = sum / f32(ap.lighting);
    if scaled {
        return min(mean * SUM_UNSCALE, vec3<f32>(F32_MAX));
    }
    return mean;
}

fn from_inside(sp: ShadePoint) -> bool {
    return sp.hit.surface == SPHERE && dot3(sp.hit.normal, sp.dir) > 0.0;
}

// The colour the coverage specialisation (SHADE false) gives a surface.
fn coverage_colour(ti: u32) -> vec3<f32> {
    if triangles[ti].flags.x == SPHERE {
        return vec3<f32>(1.0, 0.0, 0.0);
    }
    return vec3<f32>(0.0, 1.0, 0.0);
}

// ---- The pixel's work as resumable steps. ----
//
// Mesa's llvmpipe (lavapipe) ends every loop of an invocation group, silently, once its loops
// together have run LP_MAX_TGSI_LOOP_ITERATIONS (65535) times; a pixel of a moving sphere at
// the study's sample counts needs more (its tile's triangles, then the lighting samples of
// each kept interval: M3-S3-T5-A5 of the shipped design painted 8x8 tiles). So the pixel's
// work is a sequence of steps (test one triangle of the tile, offer one visibility span to
// the list, or shade the pending interval with `light_chunk` lighting samples) and a pass
// takes at most `steps` of them, keeping where it stands in `resume`; the host repeats the
// pass until every pixel is done. The steps run the twin's operations in the twin's order,
// so how the work is cut does not change a bit of the result. A pass that still meets the
// limit is detected (`sentinel`) and the host repeats the band with fewer steps per pass.

const PHASE_TRIANGLE: u32 = 0u;
const PHASE_SPANS: u32 = 1u;
const PHASE_SHADE: u32 = 2u;
const PHASE_DONE: u32 = 3u;

struct Resume {
    phase: u32,
    // The next entry of the tile's bin.
    next: u32,
    // The triangle whose spans are being offered, and the next of its spans.
    ti: u32,
    span: u32,
    span_n: u32,
    // The list's length.
    n: u32,
    // The pending interval's lighting samples taken so far and those dropped.
    j: u32,
    bad: u32,
    stats: PixelStats,
    iv: Interval,
    sum: vec4<f32>,
    spans: array<vec2<f32>, 8>,
}

@compute @workgroup_size(8, 8, 1)
fn analytic_pixel(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let row = gid.y;
    let y = ap.first_row + row;
    if x >= ap.width || row >= ap.band_rows || y >= ap.height {
        return;
    }
    let slot = row * ap.width + x;
    let tile = (y / ANALYTIC_TILE) * ap.tiles_x + x / ANALYTIC_TILE;
    var st: Resume;
    if ap.pass_index == 0u {
        st.phase = PHASE_TRIANGLE;
        st.next = bins[tile];
        st.n = 0u;
        st.stats = PixelStats(0u, 0u, 0u, 0u);
    } else {
        st = resume[slot];
    }
    if st.phase == PHASE_DONE {
        return;
    }
    let pixel = y * ap.width + x;
    let s = ap.sample_corner_step.xy + ap.sample_corner_step.zw * vec2<f32>(f32(x) + 0.5, f32(y) + 0.5);
    let n = ap.supersampling;
    let seed = sampler32_pixel_seed(params.eye_seed ^ ANALYTIC_STREAM, (y / n) * (ap.width / n) + x / n);
    let sub = (y % n) * n + x % n;
    var list = List(slot * (ap.budget + 1u), st.n);
    let tri_end = bins[tile + 1u];
    var taken = 0u;
    loop {
        if st.phase == PHASE_DONE || (ap.steps != 0u && taken >= ap.steps) {
            break;
        }
        taken += 1u;
        if st.phase == PHASE_TRIANGLE {
            if st.next >= tri_end {
                st.phase = PHASE_DONE;
            } else {
                let ti = bins[st.next];
                st.next += 1u;
                let bounds = triangles[ti].bounds;
                if x >= bounds.x && x < bounds.y && y >= bounds.z && y < bounds.w {
                    let vis = visibility(ti, s);
                    if vis.n > 0u {
                        st.ti = ti;
                        st.span = 0u;
                        st.span_n = vis.n;
                        st.spans = vis.t;
                        st.phase = PHASE_SPANS;
                    }
                }
            }
        } else if st.phase == PHASE_SPANS {
            if st.span >= st.span_n {
                st.phase = PHASE_TRIANGLE;
            } else {
                let span = st.spans[st.span];
                st.span += 1u;
                st.stats.offered += 1u;
                let zk = linear_depth(st.ti, s, span.x, span.y);
                let iv = insert_opaque_clip(&list, Interval(span.x, span.y, zk.x, zk.y, 0.0, 0.0, 0.0, 0.0));
                if iv.te > iv.ts {
                    st.iv = iv;
                    st.j = 0u;
                    st.bad = 0u;
                    st.sum = vec4<f32>(0.0);
                    st.phase = PHASE_SHADE;
                }
            }
        } else {
            var colour = vec3<f32>(0.0);
            var finished = true;
            if SHADE {
                let sp = shade_point(st.ti, st.iv, s);
                let first = (st.stats.kept * ap.supersampling * ap.supersampling + sub) * ap.lighting;
                var end = ap.lighting;
                if ap.light_chunk != 0u {
                    end = min(st.j + ap.light_chunk, ap.lighting);
                }
                var sum = st.sum.xyz;
                var scaled = st.sum.w != 0.0;
                // A sphere point facing away from the ray (a midpoint off its triangle) would
                // be shaded from the sphere's inside, where no light arrives and no path
                // escapes: zero, without bouncing to max_bounces (render::methods::analytic::shade).
                if from_inside(sp) {
                    end = ap.lighting;
                }
                for (var j = st.j; j < end && !from_inside(sp); j++) {
                    let l = radiance_from(sp.sphere, seed, first + j, sp.dir, sp.hit);
                    if is_finite3(l) {
                        if !scaled && needs_scaling(sum, l) {
                            scaled = true;
                            sum = sum * SUM_SCALE;
                        }
                        sum = add_lighting(sum, l, scaled);
                    } else {
                        st.bad += 1u;
                    }
                }
                st.sum = vec4<f32>(sum, select(0.0, 1.0, scaled));
                st.j = end;
                finished = end >= ap.lighting;
                colour = lighting_mean(sum, scaled);
            } else {
                colour = coverage_colour(st.ti);
            }
            if finished {
                var iv = st.iv;
                iv.r = colour.x;
                iv.g = colour.y;
                iv.b = colour.z;
                insert_sorted(&list, iv);
                st.stats.kept += 1u;
                st.stats.nonfinite += st.bad;
                st.stats.merges += compress(&list);
                st.phase = PHASE_SPANS;
            }
        }
    }
    st.n = list.n;
    if st.phase == PHASE_DONE {
        let res = resolve(list);
        var background = vec3<f32>(0.0);
        if SHADE {
            background = env_texel(texel_of(normalize3(camera_ray(s))).index);
        }
        let rest = max(1.0 - res.w, 0.0);
        out_pixels[pixel] = PixelOut(vec4<f32>(res.xyz + background * rest, res.w), st.stats);
    } else {
        atomicAdd(&progress[0], 1u);
    }
    resume[slot] = st;
    // Runs `sentinel` times unless the device's loop limit was reached during this pass.
    var k = 0u;
    loop {
        k += 1u;
        if k >= ap.sentinel {
            break;
        }
    }
    if k != ap.sentinel {
        atomicAdd(&progress[1], 1u);
    }
}
