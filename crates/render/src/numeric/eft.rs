//! Error-free transforms: a sum or product as the rounded result plus its exact rounding
//! error, and Kahan's difference of products `a b - c d` with one rounding's accuracy even
//! when the two products nearly cancel (the discriminant of a quadratic, 2D cross products).

/// `(s, e)` with `s = fl(a + b)` and `s + e = a + b` exactly (Knuth's TwoSum).
#[inline]
pub fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `(s, e)` with `s = fl(a + b)` and `s + e = a + b` exactly (Knuth's TwoSum in f32).
#[inline]
pub fn two_sum_f32(a: f32, b: f32) -> (f32, f32) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `(p, e)` with `p = fl(a b)` and `p + e = a b` exactly (barring overflow/underflow).
#[inline]
pub fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

macro_rules! difference_of_products_impl {
    ($(#[$doc:meta])* $name:ident, $t:ty) => {
        $(#[$doc])*
        #[inline]
        pub fn $name(a: $t, b: $t, c: $t, d: $t) -> $t {
            let cd = c * d;
            let err = (-c).mul_add(d, cd);
            let dop = a.mul_add(b, -cd);
            dop + err
        }
    };
}

difference_of_products_impl!(
    /// `a b - c d` to within 1.5 ulps (Kahan's algorithm with fused multiply-adds): the error
    /// of the rounded product `c d` is recovered exactly and added back.
    difference_of_products,
    f64
);
difference_of_products_impl!(
    /// [`difference_of_products`] in f32 (the GPU kernels' twin).
    difference_of_products_f32,
    f32
);

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// An exact reference for sums and products of f64 values: two's-complement fixed point
    /// with 2^-200 resolution in six 64-bit limbs. The tests' values and their products lie
    /// between 2^-150 and 2^180 in magnitude, so it holds them, and their sums and products,
    /// exactly.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    struct Exact([u64; 6]);

    impl Exact {
        fn neg(self) -> Exact {
            let mut r = [0u64; 6];
            let mut carry = 1u128;
            for (i, limb) in self.0.iter().enumerate() {
                let v = u128::from(!limb) + carry;
                r[i] = v as u64;
                carry = v >> 64;
            }
            Exact(r)
        }
    }

    impl std::ops::Add for Exact {
        type Output = Exact;
        fn add(self, o: Exact) -> Exact {
            let mut r = [0u64; 6];
            let mut carry = 0u128;
            for (limb, (a, b)) in r.iter_mut().zip(self.0.iter().zip(o.0)) {
                let v = u128::from(*a) + u128::from(b) + carry;
                *limb = v as u64;
                carry = v >> 64;
            }
            Exact(r)
        }
    }

    impl std::ops::Mul for Exact {
        type Output = Exact;
        /// The product of two fixed-point values, rescaled by 2^-200 (exact for the values
        /// used: the low 200 bits of the product are zero).
        fn mul(self, o: Exact) -> Exact {
            let (sa, a) = self.sign_magnitude();
            let (sb, b) = o.sign_magnitude();
            let mut wide = [0u64; 12];
            for i in 0..6 {
                let mut carry = 0u128;
                for j in 0..6 {
                    if i + j >= 12 {
                        continue;
                    }
                    let v = u128::from(a.0[i]) * u128::from(b.0[j]) + u128::from(wide[i + j]) + carry;
                    wide[i + j] = v as u64;
                    carry = v >> 64;
                }
                if i + 6 < 12 {
                    wide[i + 6] = carry as u64;
                }
            }
            // Shift right by 200 bits = 3 limbs and 8 bits.
            let mut r = [0u64; 6];
            for (k, limb) in r.iter_mut().enumerate() {
                let lo = wide[k + 3] >> 8;
                let hi = if k + 4 < 12 { wide[k + 4] << 56 } else { 0 };
                *limb = lo | hi;
            }
            let m = Exact(r);
            if sa != sb { m.neg() } else { m }
        }
    }

    impl Exact {
        fn sign_magnitude(self) -> (bool, Exact) {
            if self.0[5] >> 63 == 1 { (true, self.neg()) } else { (false, self) }
        }
    }

    /// `x` in the 2^-200 fixed point (x must be a multiple of 2^-200 below 2^150).
    fn exact(x: f64) -> Exact {
        if x == 0.0 {
            return Exact([0; 6]);
        }
        let bits = x.to_bits();
        let exponent = ((bits >> 52) & 0x7ff) as i32;
        let mantissa = (bits & ((1 << 52) - 1)) | if exponent == 0 { 0 } else { 1 << 52 };
        // x = mantissa * 2^(exponent - 1075); in the fixed point, shift left by exponent - 1075 + 200.
        let shift = exponent.max(1) - 1075 + 200;
        assert!((0..330).contains(&shift), "{x} outside the fixed point");
        let mut r = [0u64; 6];
        let (limb, bit) = ((shift / 64) as usize, shift % 64);
        r[limb] = mantissa << bit;
        if bit > 0 && limb + 1 < 6 {
            r[limb + 1] = mantissa >> (64 - bit);
        }
        let m = Exact(r);
        if x < 0.0 { m.neg() } else { m }
    }

    #[test]
    fn the_exact_reference_adds_and_multiplies_exactly() {
        assert_eq!(exact(1.5) + exact(-0.25), exact(1.25));
        assert_eq!(exact(3.0) * exact(-0.5), exact(-1.5));
        assert_eq!(exact(2f64.powi(60)) * exact(2f64.powi(-70)), exact(2f64.powi(-10)));
    }

    #[test]
    fn kahan_recovers_what_the_naive_difference_loses() {
        // b^2 - 4ac of a double root's neighbour: the naive form cancels to 0.
        let (a, b, c, d) = (1.0 + f64::EPSILON, 1.0 + f64::EPSILON, 1.0, 1.0 + 2.0 * f64::EPSILON);
        let exact = f64::EPSILON * f64::EPSILON; // (1+e)^2 - (1+2e) = e^2
        assert_eq!(a * b - c * d, 0.0);
        assert_eq!(difference_of_products(a, b, c, d), exact);
        let e = f32::EPSILON;
        assert_eq!(difference_of_products_f32(1.0 + e, 1.0 + e, 1.0, 1.0 + 2.0 * e), e * e);
    }

    proptest! {
        #[test]
        fn error_free_transforms_are_exact(a in -1e12f64..1e12, b in -1e12f64..1e12) {
            let (s, e) = two_sum(a, b);
            prop_assert_eq!(exact(s) + exact(e), exact(a) + exact(b));
            let (p, e) = two_product(a, b);
            prop_assert_eq!(exact(p) + exact(e), exact(a) * exact(b));
        }

        #[test]
        fn f32_difference_of_products_is_within_two_ulps_of_the_f64_value(
            a in -1e3f32..1e3, b in -1e3f32..1e3, c in -1e3f32..1e3, t in -1e-3f32..1e-3
        ) {
            // d chosen so that c d nearly equals a b: the cancellation case.
            let d = if c == 0.0 { 1.0 } else { a * b / c * (1.0 + t) };
            // Both products of f32 values are exact in f64; their difference rounds once there.
            let reference = f64::from(a) * f64::from(b) - f64::from(c) * f64::from(d);
            let got = f64::from(difference_of_products_f32(a, b, c, d));
            let ulp = f64::from(f32::EPSILON) * reference.abs().max(f64::from(f32::MIN_POSITIVE));
            prop_assert!((got - reference).abs() <= 2.0 * ulp, "{got} vs {reference}");
        }
    }
}
