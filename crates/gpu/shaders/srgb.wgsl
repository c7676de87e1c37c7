// sRGB transfer functions (IEC 61966-2-1), the WGSL twin of `study::color`
// (crates/study/src/color.rs): the same constants, the same branches (the linear toe at or
// below the knee), no clamping (callers clamp). Include with `//! include srgb`.
//
// `pow` is approximate on GPUs (the WGSL spec allows several ULP); the twin test in
// crates/gpu/tests/srgb_twin.rs states how far from the f32 CPU curve it lands.

const SRGB_ENCODE_KNEE: f32 = 0.0031308;
const SRGB_DECODE_KNEE: f32 = 0.04045;
const SRGB_TOE_SLOPE: f32 = 12.92;
const SRGB_OFFSET: f32 = 0.055;
const SRGB_ONE_PLUS_OFFSET: f32 = 1.055;
const SRGB_GAMMA: f32 = 2.4;
const SRGB_INV_GAMMA: f32 = 1.0 / 2.4;

// Linear light to the encoded value.
fn srgb_encode(linear: f32) -> f32 {
    let higher = SRGB_ONE_PLUS_OFFSET * pow(linear, SRGB_INV_GAMMA) - SRGB_OFFSET;
    return select(higher, linear * SRGB_TOE_SLOPE, linear <= SRGB_ENCODE_KNEE);
}

// An encoded value to linear light.
fn srgb_decode(encoded: f32) -> f32 {
    let higher = pow((encoded + SRGB_OFFSET) / SRGB_ONE_PLUS_OFFSET, SRGB_GAMMA);
    return select(higher, encoded / SRGB_TOE_SLOPE, encoded <= SRGB_DECODE_KNEE);
}

// `srgb_encode` per component.
fn srgb_encode3(linear: vec3<f32>) -> vec3<f32> {
    let higher = SRGB_ONE_PLUS_OFFSET * pow(linear, vec3<f32>(SRGB_INV_GAMMA)) - SRGB_OFFSET;
    return select(higher, linear * SRGB_TOE_SLOPE, linear <= vec3<f32>(SRGB_ENCODE_KNEE));
}

// `srgb_decode` per component.
fn srgb_decode3(encoded: vec3<f32>) -> vec3<f32> {
    let higher = pow((encoded + SRGB_OFFSET) / SRGB_ONE_PLUS_OFFSET, vec3<f32>(SRGB_GAMMA));
    return select(higher, encoded / SRGB_TOE_SLOPE, encoded <= vec3<f32>(SRGB_DECODE_KNEE));
}
