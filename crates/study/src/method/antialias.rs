//! Antialiasing of a method level's display frame, after the method has rendered it:
//! `antialias = "mlaa"` (morphological antialiasing, the thesis's Part II) with its
//! `mlaa_threshold` and `mlaa_search_distance`. Any method's level may ask for it (every
//! method gives a display frame); the keys are the same for all.

use serde::{Deserialize, Serialize};

use super::{KeyError, MethodSpec, MethodTable, SweepSetting, TracerSettings, sweep_levels};
use crate::design::Preset;
use crate::scene::{Antialias, MlaaEdges};

/// The keys every method level may write.
pub const KEYS: [&str; 4] = ["antialias", "mlaa_threshold", "mlaa_edges", "mlaa_search_distance"];
/// The luminance step that makes an edge, in display units, unless written.
pub const DEFAULT_MLAA_THRESHOLD: f64 = 0.1;
/// The step of inverse view depth (1/m) that makes an edge with `mlaa_edges = "depth"`,
/// unless written. In the study scene the sphere's silhouette steps by 0.08 1/m or more
/// (the sphere at 3 m against the floor or the sky), while the floor's inverse depth, an
/// affine function of the image position on a plane, changes by under 0.01 1/m from one
/// pixel to the next at 160 pixels across (0.0022 at 640): 0.02 finds the one, not the other.
pub const DEFAULT_MLAA_DEPTH_THRESHOLD: f64 = 0.02;
/// The search distance in pixels unless written (the thesis's "between 8 and 12").
pub const DEFAULT_MLAA_SEARCH_DISTANCE: u32 = 12;
/// The search distances the area texture covers.
pub const MLAA_SEARCH_DISTANCE_RANGE: std::ops::RangeInclusive<u32> = 1..=64;

/// The cost sweep's knob along MLAA's search distance (value 0: the frame without MLAA).
pub const SWEEP_KNOB_SEARCH_DISTANCE: &str = "mlaa_search_distance";
/// The cost sweep's knob along MLAA's threshold, in hundredths of display luminance.
pub const SWEEP_KNOB_THRESHOLD: &str = "mlaa_threshold_percent";
/// Search distances MLAA's cost sweep measures at the default threshold; 0 is the input
/// frame itself, unfiltered.
pub const SWEEP_MLAA_SEARCH_DISTANCES: [u32; 8] = [0, 1, 2, 4, 8, 12, 16, 32];
/// Thresholds (hundredths) MLAA's cost sweep measures at the default search distance.
pub const SWEEP_MLAA_THRESHOLDS_PERCENT: [u32; 4] = [5, 10, 20, 40];

/// MLAA's cost sweep (`blurlab cost --mlaa`): the tracer with every camera sample through
/// its pixel's centre (one visibility sample per pixel, so edges alias as MLAA expects),
/// filtered by MLAA along its search distance and then its threshold. The tracer traces the
/// preset's highest sampling level (within `max_spp`) so that what the curve shows is
/// aliasing, not noise, as the analytic rasterizer's sweep shades with that level's
/// lighting samples; its time and error sit beside the jittered (supersampled) tracer's.
pub fn mlaa_sweep(preset: &Preset, max_spp: u32) -> Vec<SweepSetting> {
    let input_spp = sweep_levels(preset, max_spp).last().copied().unwrap_or(1).max(1);
    let spec = MethodSpec::Tracer(TracerSettings { pixel_jitter: Some(false) });
    let setting = |knob, value, antialias| SweepSetting { spec: spec.clone(), knob, value, input_spp, antialias };
    let distances = SWEEP_MLAA_SEARCH_DISTANCES.iter().map(|&d| {
        let mlaa = (d > 0).then_some(Antialias::Mlaa {
            threshold: DEFAULT_MLAA_THRESHOLD,
            search_distance: d,
            edges: MlaaEdges::Luminance,
        });
        setting(SWEEP_KNOB_SEARCH_DISTANCE, d, mlaa)
    });
    let thresholds = SWEEP_MLAA_THRESHOLDS_PERCENT.iter().map(|&t| {
        let mlaa = Antialias::Mlaa {
            threshold: f64::from(t) / 100.0,
            search_distance: DEFAULT_MLAA_SEARCH_DISTANCE,
            edges: MlaaEdges::Luminance,
        };
        setting(SWEEP_KNOB_THRESHOLD, t, Some(mlaa))
    });
    distances.chain(thresholds).collect()
}

/// `antialias` as a design writes it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AntialiasKind {
    /// The frame as the method rendered it.
    #[default]
    None,
    /// Morphological antialiasing.
    Mlaa,
}

/// The antialiasing a method table asks for, its settings checked.
pub fn antialias_of(t: &MethodTable) -> Result<Option<Antialias>, KeyError> {
    let kind = t.antialias.unwrap_or_default();
    if kind != AntialiasKind::Mlaa {
        for (key, written) in [
            ("mlaa_threshold", t.mlaa_threshold.is_some()),
            ("mlaa_edges", t.mlaa_edges.is_some()),
            ("mlaa_search_distance", t.mlaa_search_distance.is_some()),
        ] {
            if written {
                return Err(KeyError { key, message: "applies only with antialias = \"mlaa\"".into() });
            }
        }
        return Ok(None);
    }
    let edges = t.mlaa_edges.unwrap_or_default();
    let default_threshold = match edges {
        MlaaEdges::Luminance => DEFAULT_MLAA_THRESHOLD,
        MlaaEdges::Depth => DEFAULT_MLAA_DEPTH_THRESHOLD,
    };
    let threshold = t.mlaa_threshold.unwrap_or(default_threshold);
    if !(threshold > 0.0 && threshold <= 1.0) {
        return Err(KeyError { key: "mlaa_threshold", message: format!("must lie in (0, 1], found {threshold}") });
    }
    let search_distance = t.mlaa_search_distance.unwrap_or(DEFAULT_MLAA_SEARCH_DISTANCE);
    if !MLAA_SEARCH_DISTANCE_RANGE.contains(&search_distance) {
        return Err(KeyError {
            key: "mlaa_search_distance",
            message: format!(
                "must lie in {}..={}, found {search_distance}",
                MLAA_SEARCH_DISTANCE_RANGE.start(),
                MLAA_SEARCH_DISTANCE_RANGE.end()
            ),
        });
    }
    Ok(Some(Antialias::Mlaa { threshold, search_distance, edges }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_checked_and_defaulted() {
        let mut t = MethodTable { antialias: Some(AntialiasKind::Mlaa), ..MethodTable::default() };
        let luminance = MlaaEdges::Luminance;
        assert_eq!(
            antialias_of(&t),
            Ok(Some(Antialias::Mlaa { threshold: 0.1, search_distance: 12, edges: luminance }))
        );
        t.mlaa_threshold = Some(0.0);
        assert_eq!(antialias_of(&t).unwrap_err().key, "mlaa_threshold");
        t.mlaa_threshold = Some(1.0);
        t.mlaa_search_distance = Some(65);
        assert_eq!(antialias_of(&t).unwrap_err().message, "must lie in 1..=64, found 65");
        t.mlaa_search_distance = Some(8);
        assert_eq!(
            antialias_of(&t),
            Ok(Some(Antialias::Mlaa { threshold: 1.0, search_distance: 8, edges: luminance }))
        );
        let orphan = MethodTable { mlaa_search_distance: Some(8), ..MethodTable::default() };
        assert_eq!(antialias_of(&orphan).unwrap_err().key, "mlaa_search_distance");
        let orphan = MethodTable { mlaa_edges: Some(MlaaEdges::Depth), ..MethodTable::default() };
        assert_eq!(antialias_of(&orphan).unwrap_err().key, "mlaa_edges");
        // Depth edges have their own default threshold, in 1/m.
        let depth = MethodTable {
            antialias: Some(AntialiasKind::Mlaa),
            mlaa_edges: Some(MlaaEdges::Depth),
            ..MethodTable::default()
        };
        let edges = MlaaEdges::Depth;
        assert_eq!(antialias_of(&depth), Ok(Some(Antialias::Mlaa { threshold: 0.02, search_distance: 12, edges })));
        assert_eq!(antialias_of(&MethodTable::default()), Ok(None));
    }

    #[test]
    fn the_cost_sweep_filters_centre_sampled_tracer_frames_at_the_top_level() {
        let preset = Preset {
            name: "p".into(),
            width: 8,
            height: 4,
            frames: 1,
            first_frame: 0,
            samples_per_pixel: vec![1, 4, 8, 12, 16],
        };
        let sweep = mlaa_sweep(&preset, 12);
        assert_eq!(sweep.len(), SWEEP_MLAA_SEARCH_DISTANCES.len() + SWEEP_MLAA_THRESHOLDS_PERCENT.len());
        assert!(
            sweep.iter().all(
                |s| s.input_spp == 12 && s.spec == MethodSpec::Tracer(TracerSettings { pixel_jitter: Some(false) })
            )
        );
        assert_eq!((sweep[0].knob, sweep[0].value, sweep[0].antialias), (SWEEP_KNOB_SEARCH_DISTANCE, 0, None));
        let mlaa =
            |threshold, search_distance| Antialias::Mlaa { threshold, search_distance, edges: MlaaEdges::Luminance };
        assert_eq!(sweep[5].antialias, Some(mlaa(0.1, 12)));
        let last = sweep.last().unwrap();
        assert_eq!((last.knob, last.antialias), (SWEEP_KNOB_THRESHOLD, Some(mlaa(0.4, 12))));
        // Every filtered setting is one a design may write.
        for s in &sweep {
            if let Some(Antialias::Mlaa { threshold, search_distance, .. }) = s.antialias {
                let t = MethodTable {
                    antialias: Some(AntialiasKind::Mlaa),
                    mlaa_threshold: Some(threshold),
                    mlaa_search_distance: Some(search_distance),
                    ..MethodTable::default()
                };
                assert_eq!(antialias_of(&t), Ok(s.antialias));
            }
        }
    }
}
