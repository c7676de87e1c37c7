//! Per-pixel interval lists (the paper's section 5): each entry is the time span in which
//! one triangle covers the pixel's sample point, with a linear depth (`z` at the start,
//! slope `k` per unit of normalised shutter time), a colour and an opacity. Lists are kept
//! sorted by start time (insertion sort). Opaque insertion applies the `LESS_EQUAL`
//! optimisations of the paper's Figure 7: a new interval hidden for its whole span by one
//! entry is dropped before it is shaded, an entry the new one hides for the entry's whole
//! span is removed, and a new interval hidden over a part at one of its ends is clipped to
//! the rest (clipping that would split it in two is not done). The list is then compressed
//! to its budget ([`compress`]) as triangles arrive.
//!
//! Compression merges the pair with the lowest oracle value (Eq. 19) among each entry and
//! its next `range` successors (+3 opaque, +10 translucent), with Eq. 20's blend. Eq. 20
//! weights the later interval by its share of the two durations; two intervals of zero
//! length (their denominator 0) are blended half and half.

/// One interval of a pixel's list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Start (normalised shutter time).
    pub ts: f64,
    /// End.
    pub te: f64,
    /// View depth at `ts`.
    pub z: f64,
    /// Depth slope per unit of normalised time.
    pub k: f64,
    /// Linear radiance.
    pub color: [f64; 3],
    /// Opacity (1 for the opaque study scene).
    pub alpha: f64,
}

impl Interval {
    /// The linear depth at `t`.
    #[inline]
    pub fn depth_at(&self, t: f64) -> f64 {
        self.z + self.k * (t - self.ts)
    }

    /// Duration.
    pub fn len(&self) -> f64 {
        self.te - self.ts
    }

    /// Whether the interval has no duration.
    pub fn is_empty(&self) -> bool {
        self.te <= self.ts
    }

    /// The interval restricted to `[ts, te]` (same depth line).
    pub fn clipped(&self, ts: f64, te: f64) -> Interval {
        Interval { ts, te, z: self.depth_at(ts), ..*self }
    }
}

/// The oracle constants h1..h5 of Eq. 19 (the paper's values).
pub const ORACLE_H: [f64; 5] = [1000.0, 100.0, 1.0, 100.0, 1.0];
/// Search range of the compression for opaque scenes.
pub const SEARCH_RANGE_OPAQUE: usize = 3;
/// Search range of the compression for translucent scenes.
pub const SEARCH_RANGE_TRANSLUCENT: usize = 10;

/// Eq. 19: how unsuitable merging `a` with the later `b` is (lower merges first).
pub fn oracle(a: &Interval, b: &Interval) -> f64 {
    let [h1, h2, h3, h4, h5] = ORACLE_H;
    let z_end = a.z + a.k * (a.te - a.ts);
    let dc: f64 = (0..3).map(|c| (a.color[c] - b.color[c]).abs()).sum();
    h1 * (b.ts - a.te).max(0.0) + h2 * (z_end - b.z).abs() + h3 * (a.k - b.k).abs() + h4 * (a.len() + b.len()) + h5 * dc
}

/// Eq. 20: `a` and the later `b` (`a.ts <= b.ts`) as one interval starting at `a.ts`.
pub fn merge(a: &Interval, b: &Interval) -> Interval {
    let total = a.len() + b.len();
    // The later interval's share of the two durations; half each when both are empty.
    let w = if total > 0.0 { b.len() / total } else { 0.5 };
    let mix = |x: f64, y: f64| (1.0 - w) * x + w * y;
    Interval {
        ts: a.ts,
        te: a.te.max(b.te),
        z: mix(a.z, b.z - b.k * (b.ts - a.ts)),
        k: mix(a.k, b.k),
        color: [0, 1, 2].map(|c| mix(a.color[c], b.color[c])),
        alpha: mix(a.alpha, b.alpha),
    }
}

/// Inserts `iv` keeping `list` sorted by start time (after entries with the same start).
pub fn insert_sorted(list: &mut Vec<Interval>, iv: Interval) {
    let at = list.partition_point(|e| e.ts <= iv.ts);
    list.insert(at, iv);
}

/// What opaque insertion did with a new interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Insertion {
    /// Hidden for its whole span by an existing entry: dropped (and never shaded).
    Hidden,
    /// Inserted (possibly clipped), with this many hidden entries removed.
    Inserted {
        /// Entries removed because the new interval hides them.
        removed: usize,
    },
}

/// Whether `front` is nearer than `back` at both `t0` and `t1` (linear depths: throughout).
fn nearer(front: &Interval, back: &Interval, t0: f64, t1: f64) -> bool {
    front.depth_at(t0) < back.depth_at(t0) && front.depth_at(t1) < back.depth_at(t1)
}

/// Opaque insertion with the `LESS_EQUAL` optimisations of Figure 7. `new` has no colour
/// yet: `shade` gives it one for its final (possibly clipped) span, only when it is kept.
pub fn insert_opaque(list: &mut Vec<Interval>, new: Interval, shade: impl FnOnce(&Interval) -> [f64; 3]) -> Insertion {
    let mut new = new;
    for e in list.iter() {
        if new.is_empty() {
            break;
        }
        // Hidden throughout: the entry spans the new interval and is strictly in front (a
        // tie passes LESS_EQUAL, so the new interval stays).
        if e.ts <= new.ts && e.te >= new.te && nearer(e, &new, new.ts, new.te) {
            return Insertion::Hidden;
        }
        // Hidden at its start or its end only: clip (one interval stays one).
        if e.ts <= new.ts && e.te > new.ts && e.te < new.te && nearer(e, &new, new.ts, e.te) {
            new = new.clipped(e.te, new.te);
        } else if e.ts > new.ts && e.ts < new.te && e.te >= new.te && nearer(e, &new, e.ts, new.te) {
            new = new.clipped(new.ts, e.ts);
        }
    }
    if new.is_empty() {
        return Insertion::Hidden;
    }
    let before = list.len();
    // LESS_EQUAL: the new interval wins ties, so an entry it spans and is nowhere behind goes.
    list.retain(|e| {
        let hidden = new.ts <= e.ts
            && new.te >= e.te
            && new.depth_at(e.ts) <= e.depth_at(e.ts)
            && new.depth_at(e.te) <= e.depth_at(e.te);
        !hidden
    });
    let removed = before - list.len();
    new.color = shade(&new);
    insert_sorted(list, new);
    Insertion::Inserted { removed }
}

/// Merges the lowest-oracle pair (each entry with its next `range` successors; ties: the
/// first pair found) until `list` holds at most `budget` entries. Returns the merges done.
pub fn compress(list: &mut Vec<Interval>, budget: usize, range: usize) -> usize {
    let budget = budget.max(1);
    let mut merges = 0;
    while list.len() > budget {
        let mut best = (f64::INFINITY, 0, 1);
        for i in 0..list.len() {
            for j in i + 1..(i + 1 + range).min(list.len()) {
                let o = oracle(&list[i], &list[j]);
                if o < best.0 {
                    best = (o, i, j);
                }
            }
        }
        let (_, i, j) = best;
        let merged = merge(&list[i], &list[j]);
        list.remove(j);
        list[i] = merged;
        merges += 1;
    }
    merges
}
