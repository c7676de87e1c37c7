// The tracer's kernel: one invocation per pixel adds one batch of that pixel's samples to
// its accumulator. Everything it shades with (geometry, environment, materials, the
// integrator `radiance`) is the shading layer's `radiance.wgsl`, which the analytic kernel
// shares. The CPU twin is `render::methods::tracer::trace_batch` (same function names, same
// operations in the same order).
//! include radiance

fn sphere_at(u: f32) -> SphereAt {
    var s = SphereAt(params.centre_open.xyz, params.centre_open.w, vec2<f32>(0.0, 1.0));
    if TIME_SAMPLING {
        s.centre += params.travel.xyz * u;
        if u >= params.travel.w {
            s.centre += params.wrap_jump.xyz;
        }
        if MATERIAL != 0u {
            s.spin_sc = sin_cos_turns(-params.spin.w * u / TAU);
        }
    }
    return s;
}

@compute @workgroup_size(8, 8, 1)
fn trace_batch(@builtin(global_invocation_id) gid: vec3<u32>) {
    let x = gid.x;
    let y = gid.y;
    if x >= params.width || y >= params.height {
        return;
    }
    let pixel = y * params.width + x;
    let seed = sampler32_pixel_seed(params.eye_seed, pixel);
    let inv_spp = params.floor_albedo.w;
    let corner = params.cam_corner.xyz;
    let sx = params.cam_step_x.xyz;
    let sy = params.cam_step_y.xyz;
    var acc = accum[pixel];
    var sum = vec3<f32>(acc.r, acc.g, acc.b);
    for (var i = 0u; i < batch.count; i++) {
        let index = batch.first_sample + i;
        var u = vec2<f32>(0.5, 0.5);
        if PIXEL_JITTER {
            u = sampler32_2d(seed, index, DIM_PIXEL);
        }
        let dir = normalize3(corner + sx * (f32(x) + u.x) + sy * (f32(y) + u.y));
        var t = 0.0;
        if TIME_SAMPLING {
            t = sampler32_1d(seed, index, DIM_TIME);
        }
        let s = sphere_at(t);
        let l = radiance(s, seed, index, dir);
        if is_finite3(l) {
            sum += l * inv_spp;
        } else {
            acc.nonfinite += 1u;
        }
    }
    accum[pixel] = Accum(sum.x, sum.y, sum.z, acc.nonfinite);
}
