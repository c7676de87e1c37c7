//! Stimulus identifiers as the thesis writes them: `M2-S2-T3-A5` for a monoscopic sequence
//! and `M2-S2-T3-A5-stereo` for its side-by-side stereo twin.
//!
//! Levels are 1-based indices into the design file's factor lists; the id itself does not
//! know how many levels a design has (the design validates that).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// Whether a sequence is seen by one camera or by a stereo pair composed side by side.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum View {
    /// One camera, the thesis's chapter 5.
    Mono,
    /// Two cameras 6.5 cm apart, left eye on the left half of the frame (chapter 6).
    Stereo,
}

/// The four factors of the study, in the order they appear in an id.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Factor {
    /// M: surface material.
    Material,
    /// S: object speed.
    Speed,
    /// T: shutter fraction.
    Shutter,
    /// A: samples per pixel (antialiasing level).
    Samples,
}

impl Factor {
    /// All factors in id order.
    pub const ALL: [Factor; 4] = [Factor::Material, Factor::Speed, Factor::Shutter, Factor::Samples];

    /// The letter that prefixes this factor's level in an id.
    pub fn letter(self) -> char {
        match self {
            Factor::Material => 'M',
            Factor::Speed => 'S',
            Factor::Shutter => 'T',
            Factor::Samples => 'A',
        }
    }
}

/// One stimulus sequence of the study: a level of each factor and a view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StimulusId {
    /// Material level, 1-based (M1..).
    pub material: u8,
    /// Speed level, 1-based (S1..).
    pub speed: u8,
    /// Shutter level, 1-based (T1..).
    pub shutter: u8,
    /// Sampling level, 1-based (A1..).
    pub samples: u8,
    /// Mono or side-by-side stereo.
    pub view: View,
}

impl StimulusId {
    /// The 1-based level of `factor`.
    pub fn level(&self, factor: Factor) -> u8 {
        match factor {
            Factor::Material => self.material,
            Factor::Speed => self.speed,
            Factor::Shutter => self.shutter,
            Factor::Samples => self.samples,
        }
    }

    /// The level label of `factor`, e.g. `T3`.
    pub fn level_label(&self, factor: Factor) -> String {
        format!("{}{}", factor.letter(), self.level(factor))
    }

    /// The same stimulus seen in the other view.
    pub fn with_view(self, view: View) -> Self {
        Self { view, ..self }
    }
}

impl fmt::Display for StimulusId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M{}-S{}-T{}-A{}", self.material, self.speed, self.shutter, self.samples)?;
        if self.view == View::Stereo {
            f.write_str("-stereo")?;
        }
        Ok(())
    }
}

/// Why a string is not a stimulus id.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("`{text}` is not a stimulus id: {reason} (expected e.g. `M2-S2-T3-A5` or `M2-S2-T3-A5-stereo`)")]
pub struct IdError {
    /// The text that failed to parse.
    pub text: String,
    /// What was wrong with it.
    pub reason: String,
}

impl FromStr for StimulusId {
    type Err = IdError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let err = |reason: String| IdError { text: text.to_owned(), reason };
        let mut parts: Vec<&str> = text.split('-').collect();
        let view = if parts.last() == Some(&"stereo") {
            parts.pop();
            View::Stereo
        } else {
            View::Mono
        };
        if parts.len() != 4 {
            return Err(err(format!("found {} level parts, expected 4", parts.len())));
        }
        let mut levels = [0u8; 4];
        for ((part, factor), level) in parts.iter().zip(Factor::ALL).zip(levels.iter_mut()) {
            let digits = part
                .strip_prefix(factor.letter())
                .ok_or_else(|| err(format!("part `{part}` should start with `{}`", factor.letter())))?;
            *level = digits
                .parse::<u8>()
                .ok()
                .filter(|&l| l >= 1)
                .ok_or_else(|| err(format!("`{part}` needs a level number of 1 or more")))?;
        }
        Ok(StimulusId { material: levels[0], speed: levels[1], shutter: levels[2], samples: levels[3], view })
    }
}

impl Serialize for StimulusId {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for StimulusId {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let text = String::deserialize(deserializer)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_mono_and_stereo() {
        for text in ["M2-S2-T3-A5", "M1-S3-T1-A1-stereo", "M12-S1-T10-A2"] {
            let id: StimulusId = text.parse().unwrap();
            assert_eq!(id.to_string(), text);
        }
        let id: StimulusId = "M2-S2-T3-A5-stereo".parse().unwrap();
        assert_eq!((id.material, id.speed, id.shutter, id.samples, id.view), (2, 2, 3, 5, View::Stereo));
    }

    #[test]
    fn rejects_malformed_ids_with_a_reason() {
        for (text, needle) in [
            ("M2-S2-T3", "found 3 level parts"),
            ("M2-X2-T3-A5", "should start with `S`"),
            ("M0-S2-T3-A5", "level number of 1 or more"),
            ("M2-S2-T3-A5-mono", "found 5 level parts"),
        ] {
            let e = text.parse::<StimulusId>().unwrap_err();
            assert!(e.to_string().contains(needle), "{e}");
            assert!(e.to_string().contains(text), "{e}");
        }
    }
}
