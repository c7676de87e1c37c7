// Draws a stimulus frame into a rectangle of the window (the viewport): a frame shown as it
// is (`fs_copy`), the Dubois red-cyan anaglyph of a side-by-side stereo frame (`fs_anaglyph_*`),
// or its eyes squeezed side by side or top and bottom or interleaved by screen line
// (`fs_compose`), composed here at draw time.
//
// The anaglyph is the GPU twin of `display::anaglyph_with` (crates/runner/src/display.rs):
// the same matrices (substituted from Rust by `gpu.rs`) and the same order of sums, in linear
// light. The frame's sRGB codes are decoded here by the formula (the texture unit's sRGB
// decoding is an approximation: on lavapipe it put dark output 2 codes off); the result is
// encoded here (`fs_anaglyph_encode`, for targets that store the codes given, like egui's
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

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var image_sampler: sampler;

// Rows of the matrices (output R, G, B), one vector per row.
const L0 = vec3<f32>(/*L0*/);
const L1 = vec3<f32>(/*L1*/);
const L2 = vec3<f32>(/*L2*/);
const R0 = vec3<f32>(/*R0*/);
const R1 = vec3<f32>(/*R1*/);
const R2 = vec3<f32>(/*R2*/);

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

fn mix_row(a: vec3<f32>, b: vec3<f32>, l: vec3<f32>, r: vec3<f32>) -> f32 {
    return (a.x * l.x + b.x * r.x) + (a.y * l.y + b.y * r.y) + (a.z * l.z + b.z * r.z);
}

fn linear(c: vec3<f32>) -> vec3<f32> {
    let higher = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(higher, c / 12.92, c <= vec3<f32>(0.04045));
}

// The anaglyph in linear light, clamped to [0, 1].
fn anaglyph(uv: vec2<f32>) -> vec3<f32> {
    // The left eye is the left half of the frame; a filtering sampler stays within the eye.
    let half_texel = 0.5 / f32(textureDimensions(image, 0).x);
    let left = vec2<f32>(clamp(0.5 * uv.x, half_texel, 0.5 - half_texel), uv.y);
    let l = linear(textureSampleLevel(image, image_sampler, left, 0.0).rgb);
    let r = linear(textureSampleLevel(image, image_sampler, left + vec2<f32>(0.5, 0.0), 0.0).rgb);
    let v = vec3<f32>(mix_row(L0, R0, l, r), mix_row(L1, R1, l, r), mix_row(L2, R2, l, r));
    return clamp(v, vec3<f32>(0.0), vec3<f32>(1.0));
}

@fragment
fn fs_anaglyph_linear(in: VertexOutput) -> @location(0) vec4<f32> {
    return vec4<f32>(anaglyph(in.uv), 1.0);
}

@fragment
fn fs_anaglyph_encode(in: VertexOutput) -> @location(0) vec4<f32> {
    let l = anaglyph(in.uv);
    let higher = 1.055 * pow(l, vec3<f32>(1.0 / 2.4)) - 0.055;
    let c = select(higher, l * 12.92, l <= vec3<f32>(0.0031308));
    // Rounded to a code here, so the target's conversion keeps it.
    return vec4<f32>(floor(c * 255.0 + 0.5) / 255.0, 1.0);
}

// Which composition `fs_compose` draws: 1 sbs-half, 2 top-bottom, 3 row-interleaved.
override MODE: u32 = 1u;
// Whether the frame is drawn with a filtering sampler (bilinear), or a nearest one.
override FILTERED: bool = false;
// Whether the target is sRGB (it encodes linear values) or stores the codes given.
override SRGB_TARGET: bool = false;

fn encode(l: vec3<f32>) -> vec3<f32> {
    let v = clamp(l, vec3<f32>(0.0), vec3<f32>(1.0));
    let higher = 1.055 * pow(v, vec3<f32>(1.0 / 2.4)) - 0.055;
    let c = select(higher, v * 12.92, v <= vec3<f32>(0.0031308));
    return floor(c * 255.0 + 0.5) / 255.0;
}

// Texel (x, y) of the left (eye 0) or right (eye 1) eye, as codes / 255.
fn eye_texel(eye: i32, x: i32, y: i32) -> vec4<f32> {
    let eye_w = i32(textureDimensions(image, 0).x) / 2;
    return textureLoad(image, vec2<i32>(eye * eye_w + x, y), 0);
}

// `display::average`: two pixels averaged in linear light, as codes / 255.
fn average(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    let rgb = encode((linear(a.rgb) + linear(b.rgb)) * 0.5);
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
        return vec4<f32>(linear(c.rgb), c.a);
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
