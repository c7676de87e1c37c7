//! Sixteen-lane values for the wide tracer: [`F`] (f32), [`U`] (u32), [`M`] (a mask, all
//! bits set or clear per lane) and [`V3`] (a vector of three [`F`]).
//!
//! Each operation is a loop over a fixed-size array, `#[inline(always)]`, so that inside a
//! function compiled for an instruction set ([`super::dispatch`]) the compiler turns it into
//! that set's vector instructions: one AVX-512 register, two AVX2 or four SSE2 registers
//! per value. Every lane computes exactly the scalar operation of the same name (IEEE
//! add, multiply, divide and square root are correctly rounded on every path, and Rust
//! never fuses a multiply and an add), so a lane's result does not depend on the path.

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// Lanes per value: one camera sample each.
pub(crate) const LANES: usize = 16;

/// Sixteen f32 lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct F(pub(crate) [f32; LANES]);

/// Sixteen u32 lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct U(pub(crate) [u32; LANES]);

/// A mask: `!0` (true) or `0` (false) per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct M(pub(crate) [u32; LANES]);

#[inline(always)]
fn map<T: Copy, R: Copy + Default>(a: [T; LANES], f: impl Fn(T) -> R) -> [R; LANES] {
    let mut out = [R::default(); LANES];
    for i in 0..LANES {
        out[i] = f(a[i]);
    }
    out
}

#[inline(always)]
fn zip<T: Copy, S: Copy, R: Copy + Default>(a: [T; LANES], b: [S; LANES], f: impl Fn(T, S) -> R) -> [R; LANES] {
    let mut out = [R::default(); LANES];
    for i in 0..LANES {
        out[i] = f(a[i], b[i]);
    }
    out
}

#[inline(always)]
fn mask(b: bool) -> u32 {
    if b { !0 } else { 0 }
}

macro_rules! binary {
    ($t:ident, $trait:ident, $fn:ident, $op:tt) => {
        impl $trait for $t {
            type Output = $t;
            #[inline(always)]
            fn $fn(self, rhs: $t) -> $t {
                $t(zip(self.0, rhs.0, |a, b| a $op b))
            }
        }
    };
}

binary!(F, Add, add, +);
binary!(F, Sub, sub, -);
binary!(F, Mul, mul, *);
binary!(F, Div, div, /);
binary!(M, BitAnd, bitand, &);
binary!(M, BitOr, bitor, |);

impl Neg for F {
    type Output = F;
    #[inline(always)]
    fn neg(self) -> F {
        F(map(self.0, |a| -a))
    }
}

impl Not for M {
    type Output = M;
    #[inline(always)]
    fn not(self) -> M {
        M(map(self.0, |a| !a))
    }
}

impl F {
    #[inline(always)]
    pub(crate) fn splat(v: f32) -> F {
        F([v; LANES])
    }
    #[inline(always)]
    pub(crate) fn sqrt(self) -> F {
        F(map(self.0, f32::sqrt))
    }
    #[inline(always)]
    pub(crate) fn abs(self) -> F {
        F(map(self.0, f32::abs))
    }
    #[inline(always)]
    pub(crate) fn floor(self) -> F {
        F(map(self.0, f32::floor))
    }
    #[inline(always)]
    pub(crate) fn max(self, o: F) -> F {
        F(zip(self.0, o.0, f32::max))
    }
    /// `f32::clamp` per lane (a NaN stays NaN).
    #[inline(always)]
    pub(crate) fn clamp(self, lo: f32, hi: f32) -> F {
        F(map(self.0, |a| a.clamp(lo, hi)))
    }
    #[inline(always)]
    pub(crate) fn copysign(self, sign: F) -> F {
        F(zip(self.0, sign.0, f32::copysign))
    }
    #[inline(always)]
    pub(crate) fn lt(self, o: F) -> M {
        M(zip(self.0, o.0, |a, b| mask(a < b)))
    }
    #[inline(always)]
    pub(crate) fn le(self, o: F) -> M {
        M(zip(self.0, o.0, |a, b| mask(a <= b)))
    }
    #[inline(always)]
    pub(crate) fn gt(self, o: F) -> M {
        M(zip(self.0, o.0, |a, b| mask(a > b)))
    }
    #[inline(always)]
    pub(crate) fn ge(self, o: F) -> M {
        M(zip(self.0, o.0, |a, b| mask(a >= b)))
    }
    #[inline(always)]
    pub(crate) fn eq(self, o: F) -> M {
        M(zip(self.0, o.0, |a, b| mask(a == b)))
    }
    #[inline(always)]
    pub(crate) fn is_nan(self) -> M {
        M(map(self.0, |a| mask(a.is_nan())))
    }
    /// `a.max(0.0) as i32 as u32` per lane (`as u32` itself for values below 2^31: NaN and
    /// negatives to 0). Where every lane is below 2^22 the integer comes from the float's
    /// bits (truncation is `floor` for non-negative values; adding 1.5 * 2^23 puts the
    /// integer in the low mantissa bits), which vectorises; Rust's saturating conversion
    /// does not, on x86. Both give the same integers.
    #[inline(always)]
    pub(crate) fn to_u32_below_2_31(self) -> U {
        let a = self.max(F::splat(0.0));
        if a.lt(F::splat(4_194_304.0)).all() { a.floor().magic_to_int() } else { U(map(a.0, |a| a as i32 as u32)) }
    }
    /// `as i32` per lane (saturating, NaN to 0) of integral values, as u32 bits; through
    /// the float's bits, as above, where every lane lies within +-2^22.
    #[inline(always)]
    pub(crate) fn integral_to_i32_bits(self) -> U {
        if self.abs().lt(F::splat(4_194_304.0)).all() {
            self.magic_to_int()
        } else {
            U(map(self.0, |a| a as i32 as u32))
        }
    }
    /// The two's-complement integer of an integral float within +-2^22.
    #[inline(always)]
    fn magic_to_int(self) -> U {
        const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23
        let mut out = [0u32; LANES];
        for (o, a) in out.iter_mut().zip(self.0) {
            *o = (a + MAGIC).to_bits().wrapping_sub(MAGIC.to_bits());
        }
        U(out)
    }
}

impl U {
    #[inline(always)]
    pub(crate) fn splat(v: u32) -> U {
        U([v; LANES])
    }
    /// `first, first + 1, ...` (wrapping).
    #[inline(always)]
    pub(crate) fn ramp(first: u32) -> U {
        let mut out = [0; LANES];
        for (i, o) in out.iter_mut().enumerate() {
            *o = first.wrapping_add(i as u32);
        }
        U(out)
    }
    #[inline(always)]
    pub(crate) fn wrapping_add(self, o: U) -> U {
        U(zip(self.0, o.0, u32::wrapping_add))
    }
    #[inline(always)]
    pub(crate) fn wrapping_mul(self, o: U) -> U {
        U(zip(self.0, o.0, u32::wrapping_mul))
    }
    #[inline(always)]
    pub(crate) fn wrapping_sub(self, o: U) -> U {
        U(zip(self.0, o.0, u32::wrapping_sub))
    }
    #[inline(always)]
    pub(crate) fn min(self, o: U) -> U {
        U(zip(self.0, o.0, u32::min))
    }
    /// `a >> s` per lane (`s` below 32).
    #[inline(always)]
    pub(crate) fn shr_each(self, s: U) -> U {
        U(zip(self.0, s.0, |a, s| a >> (s & 31)))
    }
    #[inline(always)]
    pub(crate) fn lt(self, o: U) -> M {
        M(zip(self.0, o.0, |a, b| mask(a < b)))
    }
    #[inline(always)]
    pub(crate) fn le(self, o: U) -> M {
        M(zip(self.0, o.0, |a, b| mask(a <= b)))
    }
    #[inline(always)]
    pub(crate) fn gt(self, o: U) -> M {
        M(zip(self.0, o.0, |a, b| mask(a > b)))
    }
    /// `words[i]` per lane; an index beyond them reads the last word (lanes that are not
    /// tracing may hold any index). Clamping rather than checking lets the compiler use the
    /// instruction set's gather.
    #[inline(always)]
    pub(crate) fn gather(words: &[u32], index: U) -> U {
        let Some(last) = words.len().checked_sub(1) else { return U::splat(0) };
        U(map(index.0, |i| words[(i as usize).min(last)]))
    }
    #[inline(always)]
    pub(crate) fn xor(self, o: U) -> U {
        U(zip(self.0, o.0, |a, b| a ^ b))
    }
    #[inline(always)]
    pub(crate) fn and(self, o: U) -> U {
        U(zip(self.0, o.0, |a, b| a & b))
    }
    #[inline(always)]
    pub(crate) fn shl(self, k: u32) -> U {
        U(map(self.0, |a| a << k))
    }
    #[inline(always)]
    pub(crate) fn shr(self, k: u32) -> U {
        U(map(self.0, |a| a >> k))
    }
    #[inline(always)]
    pub(crate) fn reverse_bits(self) -> U {
        U(map(self.0, u32::reverse_bits))
    }
    #[inline(always)]
    pub(crate) fn eq(self, o: U) -> M {
        M(zip(self.0, o.0, |a, b| mask(a == b)))
    }
    /// `as f32` of values below 2^31 (exact below 2^24).
    #[inline(always)]
    pub(crate) fn to_f32(self) -> F {
        F(map(self.0, |a| a as f32))
    }
}

impl M {
    /// The first `n` lanes.
    #[inline(always)]
    pub(crate) fn first(n: u32) -> M {
        let mut out = [0; LANES];
        for (i, o) in out.iter_mut().enumerate() {
            *o = mask((i as u32) < n);
        }
        M(out)
    }
    #[inline(always)]
    pub(crate) fn all(self) -> bool {
        self.0.iter().fold(!0, |a, &b| a & b) != 0
    }
    #[inline(always)]
    pub(crate) fn any(self) -> bool {
        self.0.iter().fold(0, |a, &b| a | b) != 0
    }
    #[inline(always)]
    pub(crate) fn lane(self, i: usize) -> bool {
        self.0[i] != 0
    }
    /// `a` where set, `b` elsewhere.
    #[inline(always)]
    pub(crate) fn select(self, a: F, b: F) -> F {
        let bits = self.select_u(U(map(a.0, f32::to_bits)), U(map(b.0, f32::to_bits)));
        F(map(bits.0, f32::from_bits))
    }
    #[inline(always)]
    pub(crate) fn select_u(self, a: U, b: U) -> U {
        U(zip(zip(a.0, b.0, |a, b| (a, b)), self.0, |(a, b), m| (a & m) | (b & !m)))
    }
    #[inline(always)]
    pub(crate) fn select3(self, a: V3, b: V3) -> V3 {
        V3 { x: self.select(a.x, b.x), y: self.select(a.y, b.y), z: self.select(a.z, b.z) }
    }
}

/// A 3-vector of lanes; its operations are `glam::Vec3`'s, component by component in the
/// same order.
#[derive(Clone, Copy, Debug)]
pub(crate) struct V3 {
    pub(crate) x: F,
    pub(crate) y: F,
    pub(crate) z: F,
}

impl V3 {
    #[inline(always)]
    pub(crate) fn splat(v: glam::Vec3) -> V3 {
        V3 { x: F::splat(v.x), y: F::splat(v.y), z: F::splat(v.z) }
    }
    /// `(x y) + (y y') + (z z')`, as `glam::Vec3::dot` and the twin's `dot3`.
    #[inline(always)]
    pub(crate) fn dot(self, o: V3) -> F {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub(crate) fn scale(self, s: F) -> V3 {
        V3 { x: self.x * s, y: self.y * s, z: self.z * s }
    }
    #[inline(always)]
    pub(crate) fn div(self, s: F) -> V3 {
        V3 { x: self.x / s, y: self.y / s, z: self.z / s }
    }
    #[inline(always)]
    pub(crate) fn mul(self, o: V3) -> V3 {
        V3 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
    /// `v / sqrt(v . v)`, the twin's `normalize3`.
    #[inline(always)]
    pub(crate) fn normalize(self) -> V3 {
        self.div(self.dot(self).sqrt())
    }
    /// Lane `i` as a `glam::Vec3`.
    #[inline(always)]
    pub(crate) fn lane(self, i: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }
    /// Sets lane `i`.
    #[inline(always)]
    pub(crate) fn set_lane(&mut self, i: usize, v: glam::Vec3) {
        self.x.0[i] = v.x;
        self.y.0[i] = v.y;
        self.z.0[i] = v.z;
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        V3 { x: -self.x, y: -self.y, z: -self.z }
    }
}
