//! Time-dependent edge equations (the paper's section 4): for a fixed sample point
//! `s = (sx, sy, 1)` each edge of a moving triangle gives `e(t) = s . (p_i(t) x p_j(t))`,
//! a quadratic `alpha t^2 + beta t + gamma` since the vertices move linearly. The sample
//! is inside the triangle at `t` when the three edge functions have the sign of the
//! triangle's determinant `p0 . (p1 x p2)` (homogeneous rasterization: that sign also
//! keeps the part of the triangle behind the eye out). The visibility function is found
//! from the edge functions' roots in (0, 1) (the cancellation-free quadratic of
//! `crate::numeric`), the determinant's sign changes (a cubic: a triangle sweeping through
//! the eye) by bisection between them, and the sign of each piece at its midpoint, so a
//! tangent (double root), a discriminant rounded below zero, roots exactly at 0 or 1 and a
//! vanishing `alpha` need no special case: each only moves an interval end by the root's
//! own error. A sample exactly on an edge for a whole piece (`e = 0` identically) belongs to
//! the triangle on one side only (a top-left rule on the edge's normal), so triangles
//! sharing an edge never both cover, nor both miss, a sample.
//!
//! Depth is the view depth of the point hit, `d(t) = det(t) / (e0 + e1 + e2)(t)`, a cubic
//! over a quadratic (the paper's Eq. 15); each interval stores its linear approximation
//! (the depth at the start and the secant slope), whose largest relative error
//! [`TriangleSetup::depth_error`] measures.

use glam::{DVec2, DVec3};

use super::geometry::MovingTriangle;
use crate::numeric::solve_quadratic;

/// Disjoint visibility intervals at most: four from the edges (two positive parts of each
/// of three quadratics), and a determinant (cubic) sign change can split up to three more.
pub const MAX_SPANS: usize = 8;

/// `alpha t^2 + beta t + gamma`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadratic {
    /// `t^2` coefficient.
    pub alpha: f64,
    /// `t` coefficient.
    pub beta: f64,
    /// Constant.
    pub gamma: f64,
}

impl Quadratic {
    /// The value at `t`.
    #[inline]
    pub fn eval(&self, t: f64) -> f64 {
        (self.alpha * t + self.beta) * t + self.gamma
    }

    /// Whether all coefficients are zero.
    pub fn is_zero(&self) -> bool {
        self.alpha == 0.0 && self.beta == 0.0 && self.gamma == 0.0
    }

    /// Whether the quadratic is below zero on all of [0, 1] by more than any rounding of its
    /// evaluation (a margin of 1e-9 of its coefficients' size): its largest value there, at
    /// an end or at its vertex, is.
    pub fn negative_throughout(&self) -> bool {
        let margin = 1e-9 * (self.alpha.abs() + self.beta.abs() + self.gamma.abs());
        let mut max = self.gamma.max(self.alpha + self.beta + self.gamma);
        if self.alpha < 0.0 {
            let t = -self.beta / (2.0 * self.alpha);
            if t > 0.0 && t < 1.0 {
                max = max.max(self.eval(t));
            }
        }
        max < -margin
    }

    /// Roots strictly inside (0, 1), ascending (0, 1 or 2 of them).
    pub fn roots_in_unit(&self) -> ([f64; 2], usize) {
        let mut out = [0.0; 2];
        let mut n = 0;
        if let Some((r0, r1)) = solve_quadratic(self.alpha, self.beta, self.gamma) {
            for r in [r0, r1] {
                if r > 0.0 && r < 1.0 && (n == 0 || out[n - 1] != r) {
                    out[n] = r;
                    n += 1;
                }
            }
        }
        (out, n)
    }
}

/// The visibility of one triangle at one sample point: disjoint, ascending intervals of
/// normalised shutter time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Visibility {
    spans: [(f64, f64); MAX_SPANS],
    len: usize,
}

impl Visibility {
    /// No visibility.
    pub const EMPTY: Visibility = Visibility { spans: [(0.0, 0.0); MAX_SPANS], len: 0 };

    /// The intervals `(start, end)`, ascending and disjoint.
    pub fn spans(&self) -> &[(f64, f64)] {
        &self.spans[..self.len]
    }

    /// Total time covered.
    pub fn coverage(&self) -> f64 {
        self.spans().iter().map(|(a, b)| b - a).sum()
    }

    fn push(&mut self, a: f64, b: f64) {
        if self.len > 0 && self.spans[self.len - 1].1 == a {
            self.spans[self.len - 1].1 = b;
        } else if self.len < MAX_SPANS {
            self.spans[self.len] = (a, b);
            self.len += 1;
        }
    }
}

/// Per-triangle constants: each edge's cross-product polynomial `C2 t^2 + C1 t + C0` (so
/// `e(t) = s . C(t)`) and the vertex paths.
#[derive(Clone, Copy, Debug)]
pub struct TriangleSetup {
    /// `[C0, C1, C2]` of edge k (the edge opposite vertex k).
    pub edges: [[DVec3; 3]; 3],
    /// Vertices at t = 0.
    pub base: [DVec3; 3],
    /// Vertex motion over the shutter.
    pub motion: [DVec3; 3],
    /// Whether back-facing instants count.
    pub two_sided: bool,
}

/// `e . s` for `s = (x, y, 1)`, written the same way for every edge so that an edge shared
/// with reversed vertices gives exactly the negated value.
#[inline]
fn dot_s(c: DVec3, s: DVec2) -> f64 {
    c.x * s.x + c.y * s.y + c.z
}

impl TriangleSetup {
    /// Prepares `tri`.
    pub fn new(tri: &MovingTriangle) -> Self {
        let base = tri.open;
        let motion = [0, 1, 2].map(|i| tri.close[i] - tri.open[i]);
        let edge = |i: usize, j: usize| {
            let (a, b, da, db) = (base[i], base[j], motion[i], motion[j]);
            [a.cross(b), a.cross(db) + da.cross(b), da.cross(db)]
        };
        TriangleSetup { edges: [edge(1, 2), edge(2, 0), edge(0, 1)], base, motion, two_sided: tri.two_sided }
    }

    /// Whether the triangle is back-facing (or edge-on) at every instant of the shutter, so a
    /// one-sided triangle covers nothing: the determinant's cubic in the Bernstein basis has
    /// no coefficient above zero (its values on [0, 1] lie in their hull), with a margin of
    /// rounding so a triangle turning edge-on is never culled on a rounding error.
    pub fn back_facing_throughout(&self) -> bool {
        if self.two_sided {
            return false;
        }
        let [c0, c1, c2] = self.edges[0];
        let (a, d) = (self.base[0], self.motion[0]);
        let m = [a.dot(c0), a.dot(c1) + d.dot(c0), a.dot(c2) + d.dot(c1), d.dot(c2)];
        let scale: f64 = a.abs().dot(c0.abs() + c1.abs() + c2.abs()) + d.abs().dot(c0.abs() + c1.abs() + c2.abs());
        let margin = 1e-12 * scale;
        let b = [m[0], m[0] + m[1] / 3.0, m[0] + (2.0 * m[1] + m[2]) / 3.0, m[0] + m[1] + m[2] + m[3]];
        b.iter().all(|&v| v < -margin)
    }

    /// The edge equations at sample point `s`.
    pub fn edge_equations(&self, s: DVec2) -> [Quadratic; 3] {
        self.edges.map(|[c0, c1, c2]| Quadratic { alpha: dot_s(c2, s), beta: dot_s(c1, s), gamma: dot_s(c0, s) })
    }

    /// The determinant `p0 . (p1 x p2)` at `t` (a cubic in `t`).
    pub fn det(&self, t: f64) -> f64 {
        let p = |i: usize| self.base[i] + self.motion[i] * t;
        p(0).dot(p(1).cross(p(2)))
    }

    /// The cubic-rational depth of Eq. 15 at `s`: numerator `m0 + m1 t + m2 t^2 + m3 t^3`
    /// (the determinant) and denominator `n0 + n1 t + n2 t^2` (the edge functions' sum).
    pub fn depth_function(&self, s: DVec2) -> ([f64; 4], [f64; 3]) {
        let [c0, c1, c2] = self.edges[0];
        let (a, d) = (self.base[0], self.motion[0]);
        let m = [a.dot(c0), a.dot(c1) + d.dot(c0), a.dot(c2) + d.dot(c1), d.dot(c2)];
        let e = self.edge_equations(s);
        let n = [
            e[0].gamma + e[1].gamma + e[2].gamma,
            e[0].beta + e[1].beta + e[2].beta,
            e[0].alpha + e[1].alpha + e[2].alpha,
        ];
        (m, n)
    }

    /// The exact view depth at `s` and `t`: `det(t) / sum e_k(t)`.
    pub fn depth(&self, s: DVec2, t: f64) -> f64 {
        let sum: f64 = self.edge_equations(s).iter().map(|e| e.eval(t)).sum();
        self.det(t) / sum
    }

    /// The linear depth of an interval `[ts, te]` at `s`: depth at `ts` and slope (the
    /// secant; 0 for an empty interval). An end where the depth is not finite (all edge
    /// functions vanishing together) takes the midpoint's.
    pub fn linear_depth(&self, s: DVec2, ts: f64, te: f64) -> (f64, f64) {
        let mid = self.depth(s, 0.5 * (ts + te));
        let finite = |v: f64| if v.is_finite() { v } else { mid };
        let (z0, z1) = (finite(self.depth(s, ts)), finite(self.depth(s, te)));
        if te > ts { (z0, (z1 - z0) / (te - ts)) } else { (z0, 0.0) }
    }

    /// The largest relative error `|d_lin - d| / d` of the linear depth over `[ts, te]`
    /// (at 33 evenly spaced times).
    pub fn depth_error(&self, s: DVec2, ts: f64, te: f64) -> f64 {
        let (z, k) = self.linear_depth(s, ts, te);
        (0..=32)
            .map(|i| {
                let t = ts + (te - ts) * f64::from(i) / 32.0;
                let d = self.depth(s, t);
                if d.is_finite() && d != 0.0 { ((z + k * (t - ts)) - d).abs() / d.abs() } else { 0.0 }
            })
            .fold(0.0, f64::max)
    }

    /// Whether the sample is inside at `t` with orientation `sign` (+1 front, -1 back).
    fn inside(&self, e: &[Quadratic; 3], t: f64, sign: f64) -> bool {
        if self.det(t) * sign <= 0.0 {
            return false;
        }
        (0..3).all(|k| {
            let v = e[k].eval(t) * sign;
            if v != 0.0 {
                return v > 0.0;
            }
            // On the edge: the top-left rule on the edge's normal at this instant; the
            // reversed edge of a neighbour has the negated normal and so the other answer.
            let [c0, c1, c2] = self.edges[k];
            let n = (c0 + c1 * t + c2 * t * t) * sign;
            n.x > 0.0 || (n.x == 0.0 && n.y > 0.0)
        })
    }

    /// The visibility function at `s` over the shutter `[0, 1]`.
    pub fn visibility(&self, s: DVec2) -> Visibility {
        let e = self.edge_equations(s);
        // Most triangles a pixel meets miss its sample: one edge function is negative for the
        // whole shutter. Rejecting them here gives what the general path gives, cheaper.
        if !self.two_sided && e.iter().any(Quadratic::negative_throughout) {
            return Visibility::EMPTY;
        }
        let signs: &[f64] = if self.two_sided { &[1.0, -1.0] } else { &[1.0] };
        if self.motion == [DVec3::ZERO; 3] {
            // Static: no roots and no sign change, one piece (what the general path gives).
            let mut vis = Visibility::EMPTY;
            if signs.iter().any(|&sign| self.inside(&e, 0.5, sign)) {
                vis.push(0.0, 1.0);
            }
            return vis;
        }
        let mut cuts = [0.0f64; 16];
        cuts[0] = 0.0;
        let mut n = 1;
        for q in &e {
            let (r, k) = q.roots_in_unit();
            cuts[n..n + k].copy_from_slice(&r[..k]);
            n += k;
        }
        cuts[n] = 1.0;
        n += 1;
        cuts[..n].sort_by(f64::total_cmp);
        // Sign changes of the determinant (the triangle's plane sweeping through the eye).
        let mut all = [0.0f64; 16];
        let mut m = 0;
        for w in 0..n {
            if w > 0 {
                let (a, b) = (cuts[w - 1], cuts[w]);
                let (da, db) = (self.det(a), self.det(b));
                if b > a && da * db < 0.0 && m < 15 {
                    let (mut lo, mut hi) = (a, b);
                    for _ in 0..64 {
                        let mid = 0.5 * (lo + hi);
                        if mid <= lo || mid >= hi {
                            break;
                        }
                        if (self.det(mid) < 0.0) == (da < 0.0) { lo = mid } else { hi = mid }
                    }
                    all[m] = hi;
                    m += 1;
                }
            }
            if m < 16 {
                all[m] = cuts[w];
                m += 1;
            }
        }
        let mut vis = Visibility::EMPTY;
        for w in 1..m {
            let (a, b) = (all[w - 1], all[w]);
            if b <= a {
                continue;
            }
            let mid = 0.5 * (a + b);
            if signs.iter().any(|&sign| self.inside(&e, mid, sign)) {
                vis.push(a, b);
            }
        }
        vis
    }
}
