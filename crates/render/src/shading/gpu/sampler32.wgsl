// The u32 Owen-scrambled Sobol sampler: the WGSL twin of `render::shading::gpu::sampler32`
// (read its docs for the scheme), which `tests/sampler32_wgsl.rs` holds it to bit for bit.
// Needs the constant DIM_PIXEL (declared by `render::shading::gpu::assembler::assembler()`). The eye's
// 32-bit seed is computed once on the CPU (`eye_seed32`) and passed in.

// The "lowbias32" integer hash (a bijection).
fn sampler32_hash(x0: u32) -> u32 {
    var x = x0;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    return x ^ (x >> 16u);
}

// The seed of pixel number `pixel` (y * width + x) of the eye seeded `eye_seed`.
fn sampler32_pixel_seed(eye_seed: u32, pixel: u32) -> u32 {
    return sampler32_hash(eye_seed ^ sampler32_hash(pixel));
}

// The seeds of a dimension: (index shuffle, first coordinate, second coordinate).
fn sampler32_dim_seeds(pixel_seed: u32, dim: u32) -> vec3<u32> {
    let h = sampler32_hash(pixel_seed ^ sampler32_hash(dim ^ 0x5bd1e995u));
    return vec3<u32>(h, sampler32_hash(h ^ 0x68e31da4u), sampler32_hash(h ^ 0xb5297a4du));
}

// Laine-Karras style hash permutation (Burley 2020): an Owen scramble of the bit-reversed value.
fn sampler32_laine_karras(x0: u32, seed: u32) -> u32 {
    var x = x0 + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// The second Sobol dimension (primitive polynomial x + 1), bit-reversed: the xor of each
// bit's supersets among the index bits (its generator is Pascal's triangle mod 2), in five
// shift-and-xor steps (`sampler32::sobol1_reversed` explains it).
fn sampler32_sobol1_reversed(i: u32) -> u32 {
    var x = i;
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    x ^= (x >> 16u) & 0x0000ffffu;
    return x;
}

fn sampler32_shuffled_index(index: u32, dim: u32, shuffle: u32) -> u32 {
    if dim == DIM_PIXEL {
        return index;
    }
    return reverseBits(sampler32_laine_karras(reverseBits(index), shuffle));
}

// The 1D value of dimension `dim` for sample `index` of a pixel, as a 32-bit fraction.
fn sampler32_1d_bits(pixel_seed: u32, index: u32, dim: u32) -> u32 {
    let s = sampler32_dim_seeds(pixel_seed, dim);
    return reverseBits(sampler32_laine_karras(sampler32_shuffled_index(index, dim, s.x), s.y));
}

// The 2D value of dimension `dim` for sample `index` of a pixel, as 32-bit fractions.
fn sampler32_2d_bits(pixel_seed: u32, index: u32, dim: u32) -> vec2<u32> {
    let s = sampler32_dim_seeds(pixel_seed, dim);
    let i = sampler32_shuffled_index(index, dim, s.x);
    return vec2<u32>(
        reverseBits(sampler32_laine_karras(i, s.y)),
        reverseBits(sampler32_laine_karras(sampler32_sobol1_reversed(i), s.z)),
    );
}

// A 32-bit fraction as an f32 in [0, 1): its top 24 bits, exactly (times 2^-24).
fn sampler32_to_unit(v: u32) -> f32 {
    return f32(v >> 8u) * 5.9604644775390625e-8f;
}

fn sampler32_1d(pixel_seed: u32, index: u32, dim: u32) -> f32 {
    return sampler32_to_unit(sampler32_1d_bits(pixel_seed, index, dim));
}

fn sampler32_2d(pixel_seed: u32, index: u32, dim: u32) -> vec2<f32> {
    let v = sampler32_2d_bits(pixel_seed, index, dim);
    return vec2<f32>(sampler32_to_unit(v.x), sampler32_to_unit(v.y));
}
