// Draws a stimulus frame into a rectangle of the window (the viewport): a frame shown as it
// is (`fs_copy`), or the Dubois red-cyan anaglyph of a side-by-side stereo frame, composed
// here at draw time (`fs_anaglyph_*`).
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
