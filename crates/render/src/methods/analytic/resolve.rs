//! The temporal resolve (the paper's section 5.1): a sweep over normalised shutter time
//! whose events are the intervals' starts and ends and the times where two overlapping
//! intervals' depth lines cross. Between consecutive events the set of active intervals
//! and their depth order are fixed, so each sub-span takes one colour: the nearest active
//! interval's (opaque; a tie goes to the later entry, as `LESS_EQUAL` lets the later
//! fragment through), or the active intervals blended back to front over the background
//! (translucent). Sub-spans are weighted by their duration: the integral against the box
//! shutter. Time not covered by any interval shows the background.

use super::interval::Interval;

/// The sweep's event times in `[0, 1]`, ascending, distinct.
pub fn events(list: &[Interval]) -> Vec<f64> {
    let mut ev = vec![0.0, 1.0];
    for (i, a) in list.iter().enumerate() {
        ev.push(a.ts.clamp(0.0, 1.0));
        ev.push(a.te.clamp(0.0, 1.0));
        for b in &list[i + 1..] {
            let (lo, hi) = (a.ts.max(b.ts), a.te.min(b.te));
            let dk = a.k - b.k;
            if hi > lo && dk != 0.0 {
                // z_a + k_a (t - ts_a) = z_b + k_b (t - ts_b)
                let t = ((b.z - b.k * b.ts) - (a.z - a.k * a.ts)) / dk;
                if t > lo && t < hi {
                    ev.push(t);
                }
            }
        }
    }
    ev.retain(|t| t.is_finite());
    ev.sort_by(f64::total_cmp);
    ev.dedup();
    ev
}

/// Opaque resolve: the pixel's radiance and the fraction of the shutter covered.
pub fn resolve_opaque(list: &[Interval], background: [f64; 3]) -> ([f64; 3], f64) {
    let ev = events(list);
    let mut sum = [0.0; 3];
    let mut covered = 0.0;
    for w in ev.windows(2) {
        let (a, b) = (w[0], w[1]);
        let m = 0.5 * (a + b);
        let mut best: Option<&Interval> = None;
        for iv in list.iter().filter(|iv| iv.ts < m && m < iv.te) {
            if best.is_none_or(|bst| iv.depth_at(m) <= bst.depth_at(m)) {
                best = Some(iv);
            }
        }
        let c = match best {
            Some(iv) => {
                covered += b - a;
                iv.color
            }
            None => background,
        };
        for ch in 0..3 {
            sum[ch] += (b - a) * c[ch];
        }
    }
    (sum, covered)
}

/// Translucent resolve: within each sub-span the active intervals composited back to front
/// (`c = alpha c_i + (1 - alpha) c`) over the background.
pub fn resolve_translucent(list: &[Interval], background: [f64; 3]) -> [f64; 3] {
    let ev = events(list);
    let mut sum = [0.0; 3];
    let mut active: Vec<&Interval> = Vec::new();
    for w in ev.windows(2) {
        let (a, b) = (w[0], w[1]);
        let m = 0.5 * (a + b);
        active.clear();
        active.extend(list.iter().filter(|iv| iv.ts < m && m < iv.te));
        // Farthest first; equal depths keep list order, so the later entry ends on top.
        active.sort_by(|x, y| y.depth_at(m).total_cmp(&x.depth_at(m)));
        let mut c = background;
        for iv in &active {
            for (ch, value) in c.iter_mut().enumerate() {
                *value = iv.alpha * iv.color[ch] + (1.0 - iv.alpha) * *value;
            }
        }
        for ch in 0..3 {
            sum[ch] += (b - a) * c[ch];
        }
    }
    sum
}
