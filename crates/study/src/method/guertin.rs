//! Guertin et al. 2014's filtering approach: its settings with the paper's defaults
//! {N, r, tau, kappa, eta, gamma, phi} = {35, 40, 1, 40, 0.95, 1.5, 27}, ranges and cost; its
//! cost knob is the taps at each A level.

use super::mcguire::{filter_samples_cost, filter_sweep};
use super::{
    CurveInput, FILTER_COUNT_RANGE, KeyError, MethodSettings, MethodTable, SweepSetting, check_count, check_real,
};
use crate::design::Preset;

/// `[method] kind = "guertin"`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GuertinSettings {
    /// Taps N gathered per pixel, split between the dominant and the centre direction.
    pub taps: Option<u32>,
    /// Tile size r in pixels, the largest blur radius.
    pub tile: Option<u32>,
    /// tau, the slope of the stochastic tile offset's fall-off.
    pub tau: Option<f64>,
    /// kappa, the centre weight's scale.
    pub kappa: Option<f64>,
    /// eta, the largest sample jitter.
    pub eta: Option<f64>,
    /// gamma, the speed over which the centre direction turns to the pixel's velocity.
    pub gamma: Option<f64>,
    /// phi, the baseline jitter level (the jitter is phi / N).
    pub phi: Option<f64>,
    /// Split the samples by the tile's velocity variance (section 4.2; off in the paper's
    /// results but one).
    pub tile_variance: Option<bool>,
    /// The floor in the sphere's shadow moves with the sphere in the G-buffer (off: the
    /// floor is static, as a velocity buffer holds it).
    pub shadow_motion: Option<bool>,
}

defaults!(GuertinSettings {
    /// Taps N, 35 by default.
    taps: u32 = 35,
    /// Tile size r, 40 by default.
    tile: u32 = 40,
    /// tau, 1 by default.
    tau: f64 = 1.0,
    /// kappa, 40 by default.
    kappa: f64 = 40.0,
    /// eta, 0.95 by default.
    eta: f64 = 0.95,
    /// gamma, 1.5 by default.
    gamma: f64 = 1.5,
    /// phi, 27 by default.
    phi: f64 = 27.0,
    /// The tile-variance split, off by default.
    tile_variance: bool = false,
    /// The shadow's motion on the floor, off by default.
    shadow_motion: bool = false,
});

impl MethodSettings for GuertinSettings {
    const KEYS: &'static [&'static str] =
        &["taps", "tile", "tau", "kappa", "eta", "gamma", "phi", "tile_variance", "shadow_motion"];
    const CURVE_INPUT: CurveInput = CurveInput::Highest;

    fn from_table(t: &MethodTable) -> Self {
        GuertinSettings {
            taps: t.taps,
            tile: t.tile,
            tau: t.tau,
            kappa: t.kappa,
            eta: t.eta,
            gamma: t.gamma,
            phi: t.phi,
            tile_variance: t.tile_variance,
            shadow_motion: t.shadow_motion,
        }
    }

    fn write_table(&self, t: &mut MethodTable) {
        (t.taps, t.tile, t.tau, t.kappa) = (self.taps, self.tile, self.tau, self.kappa);
        (t.eta, t.gamma, t.phi, t.tile_variance) = (self.eta, self.gamma, self.phi, self.tile_variance);
        t.shadow_motion = self.shadow_motion;
    }

    fn check(&self) -> Result<(), KeyError> {
        check_count("taps", self.taps, FILTER_COUNT_RANGE)?;
        check_count("tile", self.tile, FILTER_COUNT_RANGE)?;
        check_real("tau", self.tau, 0.0, 1e3)?;
        check_real("kappa", self.kappa, 1e-3, 1e6)?;
        check_real("eta", self.eta, 0.0, 1.0)?;
        // The filter divides by gamma in f32: zero, or a value that rounds to zero there,
        // cannot render.
        check_real("gamma", self.gamma, 1e-3, 100.0)?;
        check_real("phi", self.phi, 0.0, 1e3)
    }

    fn samples_cost(&self, spp: u32) -> u64 {
        filter_samples_cost(spp, self.taps())
    }

    fn sweep(preset: &Preset, max_spp: u32) -> Vec<SweepSetting> {
        filter_sweep(preset, max_spp, |taps| {
            super::MethodSpec::Guertin(GuertinSettings { taps: Some(taps), ..GuertinSettings::default() })
        })
    }

    fn curve_label(_: &str, input_spp: u32) -> String {
        format!("guertin (taps, {input_spp} spp in)")
    }
}
