//! Guertin et al. 2014's filtering approach as a method: its parameters
//! ([`GuertinParams`]), its gather pass (`gather.wgsl` and its CPU twin [`gather`], also the
//! CPU fallback) after the passes both filters share, over the tracer's G-buffer at the
//! shutter's centre ([`super::post_process`], whose host runs it on a GPU).

pub mod gather;

pub use gather::{guertin_cpu, try_guertin_cpu};
use study::method::GuertinSettings;

use super::post_process::filter::{check_count, check_real};
use super::post_process::gbuffer::FloorMotion;
use super::post_process::{Filter, FilterError, FilteredImage, GBuffer, GpuFilters, MAX_SAMPLES, MAX_TILE, common};

/// Settings of Guertin et al. 2014; the defaults are the paper's
/// {N, r, tau, kappa, eta, gamma, phi} = {35, 40, 1, 40, 0.95, 1.5, 27}.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GuertinParams {
    /// Samples per pixel N, split between the dominant and the centre direction.
    pub samples: u32,
    /// Tile size r in pixels, the largest blur radius (velocities are clamped to it).
    pub tile: u32,
    /// Slope of the linear fall-off of the stochastic NeighborMax offset with the distance to
    /// the tile border (1 = from probability 1/2 at the border to 0 at the tile's centre).
    pub tau: f32,
    /// Bias of the centre weight w_p = N / (kappa |v_c|).
    pub kappa: f32,
    /// Largest sample jitter eta, scaled by phi / N.
    pub eta: f32,
    /// Pixel speed (beyond 0.5 px) over which the centre direction turns from the
    /// perpendicular of the dominant velocity to the pixel's own velocity.
    pub gamma: f32,
    /// Baseline jitter level phi.
    pub phi: f32,
    /// Split the samples between the two directions by the tile variance of the paper's
    /// equation 2 (bilinearly interpolated) instead of half and half. The paper disables it
    /// for all its results but one, hence off by default.
    pub tile_variance: bool,
    /// Seed of the per-pixel Halton jitter and of the stochastic tile offsets.
    pub seed: u32,
}

impl Default for GuertinParams {
    fn default() -> Self {
        GuertinParams::from_settings(&GuertinSettings::default(), 0)
    }
}

impl GuertinParams {
    /// The settings a design wrote (the paper's defaults where unset, from the study model's
    /// [`GuertinSettings`]) with the jitter `seed`.
    pub fn from_settings(s: &GuertinSettings, seed: u32) -> Self {
        GuertinParams {
            samples: s.taps(),
            tile: s.tile(),
            tau: s.tau() as f32,
            kappa: s.kappa() as f32,
            eta: s.eta() as f32,
            gamma: s.gamma() as f32,
            phi: s.phi() as f32,
            tile_variance: s.tile_variance(),
            seed,
        }
    }
}

/// Guertin et al.'s filter.
pub struct Guertin;

impl Filter for Guertin {
    type Settings = GuertinSettings;
    type Params = GuertinParams;

    fn params(settings: &GuertinSettings, seed: u32) -> GuertinParams {
        GuertinParams::from_settings(settings, seed)
    }

    fn floor_motion(settings: &GuertinSettings) -> FloorMotion {
        if settings.shadow_motion() { FloorMotion::Shadow } else { FloorMotion::Surface }
    }

    fn gpu(gpu: &GpuFilters, g: &GBuffer, params: &GuertinParams) -> Result<FilteredImage, FilterError> {
        gpu.guertin(g, params)
    }

    fn cpu(g: &GBuffer, params: &GuertinParams) -> Result<Vec<[f32; 3]>, FilterError> {
        try_guertin_cpu(g, params)
    }
}

impl GuertinParams {
    /// Checks the settings' ranges.
    pub fn check(&self) -> Result<(), FilterError> {
        check_count("samples", self.samples, MAX_SAMPLES)?;
        check_count("tile", self.tile, MAX_TILE)?;
        check_real("tau", self.tau, false)?;
        check_real("kappa", self.kappa, true)?;
        check_real("eta", self.eta, false)?;
        check_real("gamma", self.gamma, true)?;
        check_real("phi", self.phi, false)
    }

    /// What every pass of this filter reads for `g`.
    pub fn pass_params(&self, g: &GBuffer) -> common::PassParams {
        let mut p = common::PassParams::new(g.width, g.height, self.tile, self.samples, self.seed);
        p.tau = self.tau;
        p.kappa = self.kappa;
        p.eta = self.eta;
        p.gamma = self.gamma;
        p.phi = self.phi;
        p.variance = u32::from(self.tile_variance);
        p.inv_gamma = 1.0 / self.gamma;
        p.jitter_scale = self.eta * self.phi / self.samples as f32;
        p
    }
}
