//! The medium placed in the world at one instant: its grids' box (the unit cube scaled and
//! moved to the design's `centre` and `size`) and the density interpolated between the two
//! grids around that instant. Distances along rays are world metres, so the extinction is the
//! design's, per metre.

use glam::DVec3;
use media::shutter::BlendedGridMedium;
use media::tracking::Medium;
use study::medium::SceneMedium;

use super::MediumGrids;

/// The medium at one instant, in world coordinates.
#[derive(Debug, Clone, Copy)]
pub struct WorldMedium<'a> {
    lo: DVec3,
    hi: DVec3,
    inv_size: DVec3,
    grids: BlendedGridMedium<'a>,
}

impl<'a> WorldMedium<'a> {
    /// `medium` at time `t` (seconds), from its `grids`.
    pub fn at(medium: &SceneMedium, grids: &'a MediumGrids, t: f64) -> Self {
        let (lo, hi) = medium.bounds();
        let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
        WorldMedium {
            lo,
            hi,
            inv_size: (hi - lo).recip(),
            grids: grids.sequence.at(grids.position(medium, t), medium.extinction, medium.albedo),
        }
    }
}

impl Medium for WorldMedium<'_> {
    fn interval(&self, origin: DVec3, direction: DVec3) -> Option<(f64, f64)> {
        let inv = direction.recip();
        let t0 = (self.lo - origin) * inv;
        let t1 = (self.hi - origin) * inv;
        let near = t0.min(t1);
        let far = t0.max(t1);
        let enter = near.x.max(near.y).max(near.z).max(0.0);
        let exit = far.x.min(far.y).min(far.z);
        (exit > enter).then_some((enter, exit))
    }

    fn extinction(&self, p: DVec3) -> f64 {
        self.grids.extinction((p - self.lo) * self.inv_size)
    }

    fn majorant(&self) -> f64 {
        self.grids.majorant()
    }

    fn albedo(&self) -> f64 {
        self.grids.albedo
    }
}
