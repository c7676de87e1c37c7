//! Antialiasing of a method level's display frame, after the method has rendered it:
//! `antialias = "mlaa"` (morphological antialiasing, the thesis's Part II) with its
//! `mlaa_threshold` and `mlaa_search_distance`. Any method's level may ask for it (every
//! method gives a display frame); the keys are the same for all.

use serde::{Deserialize, Serialize};

use super::{KeyError, MethodTable};
use crate::scene::Antialias;

/// The keys every method level may write.
pub const KEYS: [&str; 3] = ["antialias", "mlaa_threshold", "mlaa_search_distance"];
/// The luminance step that makes an edge, in display units, unless written.
pub const DEFAULT_MLAA_THRESHOLD: f64 = 0.1;
/// The search distance in pixels unless written (the thesis's "between 8 and 12").
pub const DEFAULT_MLAA_SEARCH_DISTANCE: u32 = 12;
/// The search distances the area texture covers.
pub const MLAA_SEARCH_DISTANCE_RANGE: std::ops::RangeInclusive<u32> = 1..=64;

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
        for (key, written) in
            [("mlaa_threshold", t.mlaa_threshold.is_some()), ("mlaa_search_distance", t.mlaa_search_distance.is_some())]
        {
            if written {
                return Err(KeyError { key, message: "applies only with antialias = \"mlaa\"".into() });
            }
        }
        return Ok(None);
    }
    let threshold = t.mlaa_threshold.unwrap_or(DEFAULT_MLAA_THRESHOLD);
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
    Ok(Some(Antialias::Mlaa { threshold, search_distance }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_checked_and_defaulted() {
        let mut t = MethodTable { antialias: Some(AntialiasKind::Mlaa), ..MethodTable::default() };
        assert_eq!(antialias_of(&t), Ok(Some(Antialias::Mlaa { threshold: 0.1, search_distance: 12 })));
        t.mlaa_threshold = Some(0.0);
        assert_eq!(antialias_of(&t).unwrap_err().key, "mlaa_threshold");
        t.mlaa_threshold = Some(1.0);
        t.mlaa_search_distance = Some(65);
        assert_eq!(antialias_of(&t).unwrap_err().message, "must lie in 1..=64, found 65");
        t.mlaa_search_distance = Some(8);
        assert_eq!(antialias_of(&t), Ok(Some(Antialias::Mlaa { threshold: 1.0, search_distance: 8 })));
        let orphan = MethodTable { mlaa_search_distance: Some(8), ..MethodTable::default() };
        assert_eq!(antialias_of(&orphan).unwrap_err().key, "mlaa_search_distance");
        assert_eq!(antialias_of(&MethodTable::default()), Ok(None));
    }
}
