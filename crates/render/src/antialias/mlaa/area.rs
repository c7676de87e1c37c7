//! The area texture: how much of an edgel and of its opposite pixel the revectorised line
//! of its edge covers, for every pair of end patterns and distances to the line's ends.
//!
//! Generated here from the pattern geometry (Reshetov 2009's revectorisation, as the
//! thesis's section 3.5 uses it), once per process:
//!
//! - A line of edgels runs along one boundary (the north or west boundary of each pixel)
//!   from `x = 0` to `x = n`, `n = left + right + 1` pixels; the pixel whose weights are
//!   looked up spans `[left, left + 1]`. Heights are measured across the boundary, positive
//!   into the opposite pixel's row (or column).
//! - Each end has a crossing edge on the opposite side, on the current side, on both or on
//!   neither ([`Crossing`]). A crossing on one side means the original edge continues as a
//!   staircase that way, so the true edge passes through the middle of that step: height
//!   `+1/2` (opposite side) or `-1/2` (current side) at that end. No crossing, or a
//!   crossing on both sides (a T junction), gives height 0 there.
//! - The revectorised line goes straight from each end's height to height 0 at the middle
//!   of the line (`x = n / 2`): a Z pattern is one straight line through the middle, a U
//!   pattern two meeting there, an L pattern one half-line and a flat half.
//! - Where the line lies on the current side (height < 0), the part of the current pixel
//!   beyond it belongs to the opposite colour: the current pixel's weight is the integral
//!   of `max(-h, 0)` over its span. Where it lies on the opposite side, the opposite pixel's
//!   weight is the integral of `max(h, 0)`. Both are non-zero only for the pixel at the
//!   middle of a Z pattern of odd length (as the thesis notes).
//!
//! Layout: a `4 SIDE x 4 SIDE` texture of `[current, opposite]`, texel
//! `(c1 SIDE + left, c2 SIDE + right)` for crossing classes `c1`, `c2` ([`Crossing::class`]).

use std::sync::OnceLock;

/// The largest search distance, in pixels, the texture covers: the study model's range.
pub const MAX_DISTANCE: u32 = *study::method::antialias::MLAA_SEARCH_DISTANCE_RANGE.end();
/// Distances per side of a pattern's sub-texture: `0..=MAX_DISTANCE`.
pub const SIDE: usize = MAX_DISTANCE as usize + 1;
/// Texels per row (and rows) of the texture.
pub const WIDTH: usize = 4 * SIDE;

/// The crossing edge at one end of a line, as the fetch at a quarter pixel from the
/// boundary returns it: 0, 1/4 (opposite side only), 3/4 (current side only) or 1 (both).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Crossing {
    /// No crossing edge: the line just ends.
    None,
    /// A crossing edge on the opposite pixel's side.
    Opposite,
    /// A crossing edge on the current pixel's side.
    Current,
    /// Crossing edges on both sides.
    Both,
}

impl Crossing {
    /// Every kind, in [`Crossing::class`] order.
    pub const ALL: [Crossing; 4] = [Crossing::None, Crossing::Opposite, Crossing::Current, Crossing::Both];

    /// The kind a quarter-offset bilinear fetch returned (`round(4 e)` is 0, 1, 3 or 4).
    pub fn from_fetch(e: f32) -> Crossing {
        match (4.0 * e).round() as i32 {
            1 => Crossing::Opposite,
            3 => Crossing::Current,
            4 => Crossing::Both,
            _ => Crossing::None,
        }
    }

    /// The index of its sub-texture along one axis.
    pub fn class(self) -> usize {
        self as usize
    }

    /// The line's height at this end.
    fn height(self) -> f64 {
        match self {
            Crossing::Opposite => 0.5,
            Crossing::Current => -0.5,
            Crossing::None | Crossing::Both => 0.0,
        }
    }
}

/// `[current, opposite]` weights of the pixel `left` pixels from the left end of a line
/// `left + right + 1` long whose ends cross as `c1` and `c2`.
pub fn pattern_area(c1: Crossing, c2: Crossing, left: u32, right: u32) -> [f64; 2] {
    let n = f64::from(left + right + 1);
    let middle = n / 2.0;
    let (h1, h2) = (c1.height(), c2.height());
    let height = |x: f64| if x <= middle { h1 * (1.0 - x / middle) } else { h2 * (x - middle) / (n - middle) };
    // The height is linear, of one sign, on each half: split the span at the middle.
    let (a, b) = (f64::from(left), f64::from(left) + 1.0);
    let mut cuts = vec![a];
    if a < middle && middle < b {
        cuts.push(middle);
    }
    cuts.push(b);
    let (mut current, mut opposite) = (0.0, 0.0);
    for w in cuts.windows(2) {
        let area = 0.5 * (height(w[0]) + height(w[1])) * (w[1] - w[0]);
        if area < 0.0 {
            current -= area;
        } else {
            opposite += area;
        }
    }
    [current, opposite]
}

/// The texture, row-major, `WIDTH x WIDTH` (built on first use).
pub fn area_texture() -> &'static [[f32; 2]] {
    static TEXTURE: OnceLock<Vec<[f32; 2]>> = OnceLock::new();
    TEXTURE.get_or_init(|| {
        let mut t = vec![[0.0f32; 2]; WIDTH * WIDTH];
        for c1 in Crossing::ALL {
            for c2 in Crossing::ALL {
                for left in 0..SIDE as u32 {
                    for right in 0..SIDE as u32 {
                        let [cur, opp] = pattern_area(c1, c2, left, right);
                        let (u, v) = (c1.class() * SIDE + left as usize, c2.class() * SIDE + right as usize);
                        t[v * WIDTH + u] = [cur as f32, opp as f32];
                    }
                }
            }
        }
        t
    })
}

/// The texel of the pattern `(c1, c2)` at distances `(left, right)` (each at most
/// [`MAX_DISTANCE`]).
pub fn area(c1: Crossing, c2: Crossing, left: u32, right: u32) -> [f32; 2] {
    let (u, v) = (c1.class() * SIDE + left as usize, c2.class() * SIDE + right as usize);
    area_texture()[v * WIDTH + u]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_z_pattern_covers_half_a_pixel_on_each_side_in_all() {
        // The line from +1/2 to -1/2 over n pixels cuts a triangle of area n/8 from each side.
        for (left, right) in [(0, 0), (0, 3), (2, 2), (5, 1), (7, 8)] {
            let n = left + right + 1;
            let (mut cur, mut opp) = (0.0, 0.0);
            for i in 0..n {
                let [c, o] = pattern_area(Crossing::Opposite, Crossing::Current, i, n - 1 - i);
                cur += c;
                opp += o;
            }
            assert!((cur - f64::from(n) / 8.0).abs() < 1e-12 && (opp - f64::from(n) / 8.0).abs() < 1e-12);
        }
    }

    #[test]
    fn an_l_pattern_smooths_only_its_crossing_half() {
        // A line of 4 with a step up at its left end: the first two pixels' opposites get
        // the triangle's area (1/2 * 2 * 1/2 = 1/2 in all), the last two nothing.
        let a: Vec<[f64; 2]> = (0..4).map(|i| pattern_area(Crossing::Opposite, Crossing::None, i, 3 - i)).collect();
        assert!((a[0][1] - 0.375).abs() < 1e-12 && (a[1][1] - 0.125).abs() < 1e-12, "{a:?}");
        assert!(a[2] == [0.0, 0.0] && a[3] == [0.0, 0.0] && a[0][0] == 0.0);
    }

    #[test]
    fn only_the_middle_of_an_odd_z_has_both_weights() {
        for n in [1u32, 3, 5, 9] {
            for i in 0..n {
                let [c, o] = pattern_area(Crossing::Current, Crossing::Opposite, i, n - 1 - i);
                assert_eq!(c > 0.0 && o > 0.0, i == n / 2, "n {n} i {i}: {c} {o}");
            }
        }
        assert_eq!(pattern_area(Crossing::None, Crossing::Both, 3, 4), [0.0, 0.0]);
    }

    #[test]
    fn fetched_values_name_their_crossing() {
        for (e, c) in
            [(0.0, Crossing::None), (0.25, Crossing::Opposite), (0.75, Crossing::Current), (1.0, Crossing::Both)]
        {
            assert_eq!(Crossing::from_fetch(e), c);
        }
        assert_eq!(area(Crossing::Opposite, Crossing::Current, 2, 2), {
            let [c, o] = pattern_area(Crossing::Opposite, Crossing::Current, 2, 2);
            [c as f32, o as f32]
        });
    }
}
