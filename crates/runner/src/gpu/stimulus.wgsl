// Draws a stimulus frame into a rectangle of the window (the viewport): a frame shown as it
// is (`fs_copy`), the Dubois red-cyan anaglyph of a side-by-side stereo frame (`fs_anaglyph_*`),
// or its eyes squeezed side by side or top and bottom or interleaved by screen line
// (`fs_compose`), composed here at draw time.
//
// The anaglyph is the GPU twin of `display::anaglyph_with` (crates/runner/src/display.rs):
// the same matrices (`DUBOIS_LEFT` and `DUBOIS_RIGHT`, typed constants the assembler declares
// from `display::DUBOIS_*` in `gpu.rs`) and the same order of sums, in linear light. The
// frame's sRGB codes are decoded here by the formula of the shared include `srgb.wgsl` (the
// texture unit's sRGB decoding is an approximation: on lavapipe it put dark output 2 codes
// off); the result is encoded here (`fs_anaglyph_encode`, for targets that store the codes given, like egui's
// gamma-space framebuffers) or by the target (`fs_anaglyph_linear`, for sRGB targets). At an
// integer scale with a nearest sampler each output pixel comes from one texel pair, as on
// the CPU; with a filtering sampler (a scale that is not an integer) each eye's codes are
// filtered before the composition, where the CPU path's image was filtered after it.
//
// `fs_compose` is the GPU twin of `display::transform` for `sbs-half` and `top-bottom`, and
// of `display::row_interleave_on_screen` for `row-interleaved` (MODE below). For the squeezes
// it computes the pixel of the CPU's display image (the size of one eye) at a given position
// exactly as the CPU does, rounded to a code: two source pixels averaged in linear light
// (alpha: the mean rounded up), and opaque black in a column or row an odd size leaves over.
// Row-interleaving chooses the eye by the screen line, not the image row: the fragment's
// framebuffer row (`@builtin(position)`, physical pixels counted from 0 at the top of the
// framebuffer, whatever the viewport and egui's pixels_per_point) is even for the left eye,
// odd for the right (`display::line_eye`); the pixel is then that eye's image at the position,
// so each eye is scaled on its own and every screen line shows one eye whatever the scale
// and wherever the stimulus's top falls. A screen pixel's position maps to the image as in
// the copy of the CPU's image: with a nearest sampler (FILTERED false) the image pixel under
// the pixel's centre; with a filtering one (FILTERED true) the bilinear mix (clamped at the
// edges) of the four image pixels around it, of their codes for targets that store the codes
// given, of their linear values for sRGB targets (SRGB_TARGET), as a filtering sampler mixes
// the copy's texels through the view `gpu.rs` binds for each target. So the composition is
// exact at every scale; only the weights' precision differs from the texture unit's.

//! include srgb

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var image_sampler: sampler;

struct VertexOutput {
    @builtin(position) position: vec4<f32>,
    // 0..1 across the viewport, left to right and top to bottom.
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VertexOutput {
    // (-1, -1), (3, -1), (-1, 3): one triangle covering the viewport.
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    var out: VertexOutput;
    out.position = vec4<f32>(x, y, 0.0, 1.0);
    out.uv = vec2<f32>(0.5 * x + 0.5, 0.5 - 0.5 * y);
    return out;
}

@fragment
fn fs_copy(in: VertexOutput) -> @location(0) vec4<f32> {
    return textureSampleLevel(image, image_sampler, in.uv, 0.0);
}

// Output channel `c` of the anaglyph: row `c` of each matrix (element `[k][c]`: the
// matrices are column-major) times the eye's linear values, summed in the CPU's order.
fn mix_row(c: u32, l: vec3<f32>, r: vec3<f32>) -> f32 {
    let a = DUBOIS_LEFT;
    let b = DUBOIS_RIGHT;
    return (a[0][c] * l.x + b[0][c] * r.x) + (a[1][c] * l.y + b[1][c] * r.y) + (a[2][c] * l.z + b[2][c] * r.z);
}

// The anaglyph in linear light, clamped to [0, 1].
fn anaglyph(uv: vec2<f32>) -> vec3<f32> {
    // The left eye is the left half of the frame; a filtering sampler stays within the eye.
    let half_texel = 0.5 / f32(textureDimensions(image, 0).x);
    let left = vec2<f32>(clamp(0.5 * uv.x, half_texel, 0.5 - half_texel), uv.y);
    let l = srgb_decode3(textureSampleLevel(image, image_sampler, left, 0.0).rgb);
    let r = srgb_decode3(textureSampleLevel(image, image_sampler, left + vec2<f32>(0.5, 0.0), 0.0).rgb);
    let v = vec3<f32>(mix_row(0u, l, r), mix_row(1u, l, r), mix_row(2u, l, r));
    return clamp(v, vec3<f32>(0.0), vec3<f32>(1.0));
}

@fragment
fn fs_anaglyph_linear(in: VertexOutput) -> @location(0) vec4<f32> {
    return vec4<f32>(anaglyph(in.uv), 1.0);
}

@fragment
fn fs_anaglyph_encode(in: VertexOutput) -> @location(0) vec4<f32> {
    // Rounded to a code here, so the target's conversion keeps it.
    return vec4<f32>(encode(anaglyph(in.uv)), 1.0);
}

// Which composition `fs_compose` draws: 1 sbs-half, 2 top-bottom, 3 row-interleaved.
override MODE: u32 = 1u;
// Whether the frame is drawn with a filtering sampler (bilinear), or a nearest one.
override FILTERED: bool = false;
// Whether the target is sRGB (it encodes linear values) or stores the codes given.
override SRGB_TARGET: bool = false;

// Linear light, clamped to [0, 1], to the nearest code (as codes / 255).
fn encode(l: vec3<f32>) -> vec3<f32> {
    let c = srgb_encode3(clamp(l, vec3<f32>(0.0), vec3<f32>(1.0)));
    return floor(c * 255.0 + 0.5) / 255.0;
}

// Texel (x, y) of the left (eye 0) or right (eye 1) eye, as codes / 255.
fn eye_texel(eye: i32, x: i32, y: i32) -> vec4<f32> {
    let eye_w = i32(textureDimensions(image, 0).x) / 2;
    return textureLoad(image, vec2<i32>(eye * eye_w + x, y), 0);
}

// `display::average`: two pixels averaged in linear light, as codes / 255.
fn average(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    let rgb = encode((srgb_decode3(a.rgb) + srgb_decode3(b.rgb)) * 0.5);
    let alpha = floor((round(a.a * 255.0) + round(b.a * 255.0) + 1.0) / 2.0) / 255.0;
    return vec4<f32>(rgb, alpha);
}

// The size of the display image: one eye's width, the frame's height.
fn out_size() -> vec2<i32> {
    let d = vec2<i32>(textureDimensions(image, 0));
    return vec2<i32>(d.x / 2, d.y);
}

// Pixel `o` of the CPU's display image (as codes / 255); for row-interleaving, pixel `o` of
// eye `eye` (0 left, 1 right), the eye of the screen line drawn.
fn composed(o: vec2<i32>, eye: i32) -> vec4<f32> {
    let size = out_size();
    let black = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    if MODE == 3u {
        return eye_texel(eye, o.x, o.y);
    }
    if MODE == 1u {
        let half = size.x / 2;
        if o.x >= 2 * half {
            return black;
        }
        let e = select(0, 1, o.x >= half);
        let x = 2 * (o.x - e * half);
        return average(eye_texel(e, x, o.y), eye_texel(e, x + 1, o.y));
    }
    let half = size.y / 2;
    if o.y >= 2 * half {
        return black;
    }
    let e = select(0, 1, o.y >= half);
    let y = 2 * (o.y - e * half);
    return average(eye_texel(e, o.x, y), eye_texel(e, o.x, y + 1));
}

// A composed pixel in the space the target is given: codes, or linear light for sRGB targets.
fn target_value(o: vec2<i32>, eye: i32) -> vec4<f32> {
    let c = composed(clamp(o, vec2<i32>(0), out_size() - 1), eye);
    if SRGB_TARGET {
        return vec4<f32>(srgb_decode3(c.rgb), c.a);
    }
    return c;
}

@fragment
fn fs_compose(in: VertexOutput) -> @location(0) vec4<f32> {
    // The screen line's eye (row-interleaving): framebuffer rows are counted from 0 at the top
    // and the position is the pixel's centre (row + 0.5); even lines show the left eye.
    let eye = i32(floor(in.position.y)) & 1;
    let size = vec2<f32>(out_size());
    if !FILTERED {
        return target_value(vec2<i32>(floor(in.uv * size)), eye);
    }
    let p = in.uv * size - 0.5;
    let i = vec2<i32>(floor(p));
    let f = p - floor(p);
    let top = mix(target_value(i, eye), target_value(i + vec2<i32>(1, 0), eye), f.x);
    let bottom = mix(target_value(i + vec2<i32>(0, 1), eye), target_value(i + vec2<i32>(1, 1), eye), f.x);
    return mix(top, bottom, f.y);
}
