// Robust numerics for WGSL kernels, the twin of `render::numeric` (crates/render/src/numeric/):
// Kahan's difference of products, the robust quadratic, next floats and pbrt-v4's ray-origin
// offset. Same steps as the Rust f32 functions. Include with `//! include numeric`.
//
// Vulkan does not promise that `fma` is fused (unfused, the difference of products is the
// naive one); the twin test (crates/render/tests/numeric_wgsl.rs) reports what the adapter
// does. There is deliberately no TwoSum or compensated sum here: drivers may reassociate float
// additions that SPIR-V does not mark exact, and Mesa's lavapipe does fold TwoSum's error term
// to zero (measured by an earlier version of the twin test: 0 instead of 2.4e-4). GPU
// accumulations are therefore plain f32 with a stated error bound, or integers.

// `a b - c d` with the rounding error of `c d` recovered by a fused multiply-add.
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let err = fma(-c, d, cd);
    let dop = fma(a, b, -cd);
    return dop + err;
}

// Real roots of `a x^2 + b x + c`: `vec3(smaller, larger, 1)`, or `vec3(0, 0, 0)` without real
// roots (as `solve_quadratic_f32`: a zero `a` gives the linear root twice).
fn solve_quadratic(a: f32, b: f32, c: f32) -> vec3<f32> {
    if a == 0.0 {
        if b == 0.0 {
            return vec3<f32>(0.0);
        }
        let x = -c / b;
        return vec3<f32>(x, x, 1.0);
    }
    let disc = difference_of_products(b, b, 4.0 * a, c);
    // `!(disc >= 0)` also rejects NaN.
    if !(disc >= 0.0) {
        return vec3<f32>(0.0);
    }
    let s = sqrt(disc);
    let q = -0.5 * (b + select(s, -s, b < 0.0));
    if q == 0.0 {
        return vec3<f32>(0.0, 0.0, 1.0);
    }
    let r0 = q / a;
    let r1 = c / q;
    return vec3<f32>(min(r0, r1), max(r0, r1), 1.0);
}

// The next f32 above `v` (+inf stays; -0 becomes the smallest positive).
fn next_float_up(v: f32) -> f32 {
    if bitcast<u32>(v) == 0x7f800000u {
        return v;
    }
    let w = select(v, 0.0, v == 0.0);
    let bits = bitcast<u32>(w);
    return bitcast<f32>(select(bits - 1u, bits + 1u, w >= 0.0));
}

// The next f32 below `v` (-inf stays; +0 becomes the smallest negative).
fn next_float_down(v: f32) -> f32 {
    if bitcast<u32>(v) == 0xff800000u {
        return v;
    }
    if v == 0.0 {
        return bitcast<f32>(0x80000001u);
    }
    let bits = bitcast<u32>(v);
    return bitcast<f32>(select(bits + 1u, bits - 1u, v > 0.0));
}

// Origin of a ray leaving `p` (error at most `p_error` per component) of a surface with
// normal `n` in direction `w` (offset_ray_origin_f32).
fn offset_ray_origin(p: vec3<f32>, p_error: vec3<f32>, n: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    let d = dot(abs(n), p_error);
    let offset = select(d, -d, dot(w, n) < 0.0) * n;
    let po = p + offset;
    var out = po;
    for (var i = 0; i < 3; i++) {
        if offset[i] > 0.0 {
            out[i] = next_float_up(po[i]);
        } else if offset[i] < 0.0 {
            out[i] = next_float_down(po[i]);
        }
    }
    return out;
}
