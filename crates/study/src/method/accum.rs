//! The accumulation buffer's settings: K instants over the open shutter, jittered or at the
//! sub-intervals' centres, and the samples per pixel of each; its cost knob is K.

use super::{CurveInput, FrameWork, KeyError, MethodSettings, MethodTable, SweepSetting, check_count};
use crate::design::{MAX_SAMPLES, Preset};

/// The accumulation buffer's instants when a design does not set `instants`.
pub const DEFAULT_INSTANTS: u32 = 8;
/// Samples per pixel of each instant in the cost sweep.
const SWEEP_SAMPLES_PER_INSTANT: u32 = 4;

/// `[method] kind = "accum"`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AccumSettings {
    /// Instants K averaged over the open shutter.
    pub instants: Option<u32>,
    /// Jittered instants (one random time in each of the K equal sub-intervals) instead of
    /// their centres.
    pub jitter: Option<bool>,
    /// Samples per pixel of each instant; by default the A level's samples are shared among
    /// the instants (rounded up).
    pub samples_per_instant: Option<u32>,
}

impl AccumSettings {
    /// Instants K (at least 1).
    pub fn instant_count(&self) -> u32 {
        self.instants.unwrap_or(DEFAULT_INSTANTS).max(1)
    }

    /// Samples per pixel of each instant when the A level has `spp`.
    pub fn samples_per_instant(&self, spp: u32) -> u32 {
        self.samples_per_instant.unwrap_or_else(|| spp.div_ceil(self.instant_count())).max(1)
    }

    /// Whether the instants are jittered.
    pub fn jittered(&self) -> bool {
        self.jitter.unwrap_or(false)
    }
}

impl MethodSettings for AccumSettings {
    const KEYS: &'static [&'static str] = &["instants", "jitter", "samples_per_instant"];
    const CURVE_INPUT: CurveInput = CurveInput::Each;

    fn from_table(t: &MethodTable) -> Self {
        AccumSettings { instants: t.instants, jitter: t.jitter, samples_per_instant: t.samples_per_instant }
    }

    fn write_table(&self, t: &mut MethodTable) {
        (t.instants, t.jitter, t.samples_per_instant) = (self.instants, self.jitter, self.samples_per_instant);
    }

    fn check(&self) -> Result<(), KeyError> {
        check_count("instants", self.instants, 1..=4096)?;
        check_count("samples_per_instant", self.samples_per_instant, 1..=MAX_SAMPLES)?;
        if let Some(spi) = self.samples_per_instant {
            let k = self.instants.unwrap_or(DEFAULT_INSTANTS);
            let per_pixel = u64::from(k) * u64::from(spi);
            if per_pixel > u64::from(MAX_SAMPLES) {
                return Err(KeyError {
                    key: "samples_per_instant",
                    message: format!(
                        "{k} instants x {spi} samples per instant is {per_pixel} samples per pixel, above the limit of {MAX_SAMPLES}"
                    ),
                });
            }
        }
        Ok(())
    }

    /// K instants of their samples each.
    fn samples_cost(&self, spp: u32) -> u64 {
        let k = self.instant_count();
        u64::from(k) * u64::from(self.samples_per_instant(spp.max(1)))
    }

    fn frame_work(&self, spp: u32) -> FrameWork {
        let k = self.instant_count();
        let spi = self.samples_per_instant(spp);
        let key = if self.samples_per_instant.is_some() {
            Some("samples_per_instant")
        } else {
            self.instants.is_some().then_some("instants")
        };
        FrameWork {
            light_paths: u64::from(k) * u64::from(spi),
            light_paths_key: key,
            light_paths_how: format!("{k} instants x {spi} samples per instant"),
            triangle_pairs: None,
        }
    }

    /// Instants 1, 2, 4, ... of a few samples each, up to `max_spp` in all.
    fn sweep(_: &Preset, max_spp: u32) -> Vec<SweepSetting> {
        let per = SWEEP_SAMPLES_PER_INSTANT.min(max_spp);
        std::iter::successors(Some(1u32), |k| k.checked_mul(2))
            .take_while(|&k| k * per <= max_spp)
            .map(|k| SweepSetting {
                spec: super::MethodSpec::Accum(AccumSettings {
                    instants: Some(k),
                    samples_per_instant: Some(per),
                    jitter: Some(false),
                }),
                knob: "instants",
                value: k,
                input_spp: per,
                antialias: None,
            })
            .collect()
    }

    fn work_units(_: &str, value: u32, input_spp: u32) -> u64 {
        u64::from(value) * u64::from(input_spp)
    }

    fn curve_label(_: &str, input_spp: u32) -> String {
        format!("accum (instants, {input_spp} spp each)")
    }
}
