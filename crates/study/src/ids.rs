//! Stimulus identifiers as the thesis writes them: `M2-S2-T3-A5` for a monoscopic sequence
//! and `M2-S2-T3-A5-stereo` for its side-by-side stereo twin.
//!
//! Levels are 1-based indices into the design file's factor lists; the id itself does not
//! know how many levels a design has (the design validates that). A design with a rendering
//! method factor (`[[factors.method]]`) adds the method level's tag before the view:
//! `M3-S3-T5-A1-guertin`, `M3-S3-T5-A5-tracer-stereo` ([`MethodTag`]).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::method::Method;

/// Whether a sequence is seen by one camera or by a stereo pair composed side by side.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum View {
    /// One camera, the thesis's chapter 5.
    Mono,
    /// Two cameras 6.5 cm apart, left eye on the left half of the frame (chapter 6).
    Stereo,
}

/// The factors of the study, in the order they appear in an id.
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
    /// The rendering method (optional: only designs with `[[factors.method]]` have it).
    Method,
}

impl Factor {
    /// The four numbered factors every design has, in id order.
    pub const ALL: [Factor; 4] = [Factor::Material, Factor::Speed, Factor::Shutter, Factor::Samples];

    /// Every factor, the rendering method last.
    pub const WITH_METHOD: [Factor; 5] =
        [Factor::Material, Factor::Speed, Factor::Shutter, Factor::Samples, Factor::Method];

    /// The letter that prefixes this factor's level in an id.
    pub fn letter(self) -> char {
        match self {
            Factor::Material => 'M',
            Factor::Speed => 'S',
            Factor::Shutter => 'T',
            Factor::Samples => 'A',
            Factor::Method => 'R',
        }
    }

    /// The label of a level as [`StimulusId::level`] gives it: `T3`, or a method's tag.
    pub fn label(self, level: u8) -> String {
        match self {
            Factor::Method => MethodTag::from_code(level).map_or_else(|| "-".to_owned(), |t| t.to_string()),
            _ => format!("{}{level}", self.letter()),
        }
    }
}

/// A level of the rendering-method factor as an id writes it: the method's name, followed by
/// a number from 2 on when a design has several levels of one method (`guertin`, `guertin2`:
/// the first and second `guertin` levels in the file).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MethodTag {
    /// The method.
    pub kind: Method,
    /// 1 for the design's first level of this method, 2 for its second, ...
    pub variant: u8,
}

impl MethodTag {
    /// Most levels of one method in a design: the codes of every method's levels fit one
    /// byte (42 x 6 methods = 252, with room for none more: a seventh method lowers it).
    pub const MAX_VARIANTS: u8 = 42;

    /// The tag as one small number, ordered as the tags are ([`StimulusId::level`]).
    pub fn code(self) -> u8 {
        let kind = Method::ALL.iter().position(|&m| m == self.kind).unwrap_or(0) as u8;
        kind * Self::MAX_VARIANTS + self.variant
    }

    /// The tag of [`MethodTag::code`]; `None` for 0 (no method factor) or an invalid code.
    pub fn from_code(code: u8) -> Option<MethodTag> {
        let (kind, variant) = (code.checked_sub(1)? / Self::MAX_VARIANTS, (code - 1) % Self::MAX_VARIANTS + 1);
        Some(MethodTag { kind: *Method::ALL.get(usize::from(kind))?, variant })
    }
}

impl fmt::Display for MethodTag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.kind.name())?;
        if self.variant > 1 {
            write!(f, "{}", self.variant)?;
        }
        Ok(())
    }
}

impl FromStr for MethodTag {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let digits = text.len() - text.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let (name, number) = text.split_at(text.len() - digits);
        let kind: Method = name.parse()?;
        let variant = match number {
            "" => 1,
            n => n
                .parse::<u8>()
                .ok()
                .filter(|v| (2..=Self::MAX_VARIANTS).contains(v) && !n.starts_with('0'))
                .ok_or_else(|| format!("`{text}`: a method's level number runs from 2 to {}", Self::MAX_VARIANTS))?,
        };
        Ok(MethodTag { kind, variant })
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
    /// The rendering method's level, in designs with a method factor.
    pub method: Option<MethodTag>,
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
            Factor::Method => self.method.map_or(0, MethodTag::code),
        }
    }

    /// The level label of `factor`, e.g. `T3` or `guertin`.
    pub fn level_label(&self, factor: Factor) -> String {
        factor.label(self.level(factor))
    }

    /// The same stimulus without its method level (whose seeds it shares).
    pub fn without_method(self) -> Self {
        Self { method: None, ..self }
    }

    /// The same stimulus seen in the other view.
    pub fn with_view(self, view: View) -> Self {
        Self { view, ..self }
    }

    /// Its material, speed and shutter levels.
    pub fn cell(&self) -> Cell {
        Cell { material: self.material, speed: self.speed, shutter: self.shutter }
    }
}

/// A cell of the design: the material, speed and shutter levels within which render
/// settings (samples, methods) are compared; `M3-S3-T5` as text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cell {
    /// M level, 1-based.
    pub material: u8,
    /// S level, 1-based.
    pub speed: u8,
    /// T level, 1-based.
    pub shutter: u8,
}

impl Cell {
    /// `M3-S3-T5`, with `-stereo` for the stereo view (as ids end).
    pub fn label(self, view: View) -> String {
        if view == View::Stereo { format!("{self}-stereo") } else { self.to_string() }
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "M{}-S{}-T{}", self.material, self.speed, self.shutter)
    }
}

impl fmt::Display for StimulusId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}-A{}", self.cell(), self.samples)?;
        if let Some(method) = self.method {
            write!(f, "-{method}")?;
        }
        if self.view == View::Stereo {
            f.write_str("-stereo")?;
        }
        Ok(())
    }
}

/// Why a string is not a stimulus id.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error(
    "`{text}` is not a stimulus id: {reason} (expected e.g. `M2-S2-T3-A5`, `M2-S2-T3-A5-stereo` or, with a method factor, `M2-S2-T3-A5-guertin`)"
)]
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
        let (mut parts, view) = split_view(text);
        let method = match parts.len() {
            5 => Some(parts.pop().unwrap_or_default().parse::<MethodTag>().map_err(err)?),
            _ => None,
        };
        let levels: [u8; 4] = parse_levels(&parts).map_err(err)?;
        Ok(StimulusId { material: levels[0], speed: levels[1], shutter: levels[2], samples: levels[3], method, view })
    }
}

/// The `-`-separated parts of an id or cell label, without its `-stereo` suffix, and the view
/// that suffix names.
fn split_view(text: &str) -> (Vec<&str>, View) {
    let mut parts: Vec<&str> = text.split('-').collect();
    if parts.last() == Some(&"stereo") {
        parts.pop();
        (parts, View::Stereo)
    } else {
        (parts, View::Mono)
    }
}

/// The level numbers of `parts`, one per factor in [`Factor::ALL`]'s order (`M3`, `S2`, ...).
fn parse_levels<const N: usize>(parts: &[&str]) -> Result<[u8; N], String> {
    if parts.len() != N {
        return Err(format!("found {} level parts, expected {N}", parts.len()));
    }
    let mut levels = [0u8; N];
    for ((part, factor), level) in parts.iter().zip(Factor::ALL).zip(levels.iter_mut()) {
        let digits = part
            .strip_prefix(factor.letter())
            .ok_or_else(|| format!("part `{part}` should start with `{}`", factor.letter()))?;
        *level = digits
            .parse::<u8>()
            .ok()
            .filter(|&l| l >= 1)
            .ok_or_else(|| format!("`{part}` needs a level number of 1 or more"))?;
    }
    Ok(levels)
}

impl Cell {
    /// A cell and its view from `M3-S3-T5` or `M3-S3-T5-stereo`, or from the id of a
    /// stimulus in that cell (`M3-S3-T5-A2`, `M3-S3-T5-A2-guertin-stereo`: its samples level
    /// and method are not part of the cell). Levels are not checked against a design.
    pub fn parse_label(text: &str) -> Result<(Cell, View), IdError> {
        if let Ok(id) = text.parse::<StimulusId>() {
            return Ok((id.cell(), id.view));
        }
        let err = |reason: String| IdError { text: text.to_owned(), reason };
        let (parts, view) = split_view(text);
        let [material, speed, shutter] = parse_levels(&parts).map_err(err)?;
        Ok((Cell { material, speed, shutter }, view))
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
    fn cells_parse_from_their_label_or_a_stimulus_id() {
        let cell = Cell { material: 3, speed: 2, shutter: 5 };
        for (text, view) in [
            ("M3-S2-T5", View::Mono),
            ("M3-S2-T5-stereo", View::Stereo),
            ("M3-S2-T5-A4", View::Mono),
            ("M3-S2-T5-A1-guertin-stereo", View::Stereo),
        ] {
            assert_eq!(Cell::parse_label(text).unwrap(), (cell, view), "{text}");
        }
        assert_eq!(Cell::parse_label(&cell.label(View::Stereo)).unwrap(), (cell, View::Stereo));
        for bad in ["M3-S2", "M3-X2-T5", "M0-S2-T5", "M3-S2-T5-A1-B2-C3", ""] {
            assert!(Cell::parse_label(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn an_ids_cell_is_its_material_speed_and_shutter() {
        let id: StimulusId = "M3-S2-T5-A4-stereo".parse().unwrap();
        let cell = id.cell();
        assert_eq!(cell, Cell { material: 3, speed: 2, shutter: 5 });
        assert_eq!(
            (cell.to_string(), cell.label(View::Mono), cell.label(View::Stereo)),
            ("M3-S2-T5".to_owned(), "M3-S2-T5".to_owned(), "M3-S2-T5-stereo".to_owned())
        );
        assert!(id.to_string().starts_with(&cell.to_string()));
    }

    #[test]
    fn round_trips_mono_and_stereo() {
        for text in
            ["M2-S2-T3-A5", "M1-S3-T1-A1-stereo", "M12-S1-T10-A2", "M3-S3-T5-A1-guertin", "M1-S1-T1-A5-accum3-stereo"]
        {
            let id: StimulusId = text.parse().unwrap();
            assert_eq!(id.to_string(), text);
        }
        let id: StimulusId = "M2-S2-T3-A5-stereo".parse().unwrap();
        assert_eq!((id.material, id.speed, id.shutter, id.samples, id.view), (2, 2, 3, 5, View::Stereo));
        let id: StimulusId = "M1-S1-T1-A5-accum3-stereo".parse().unwrap();
        assert_eq!(id.method, Some(MethodTag { kind: Method::Accum, variant: 3 }));
        assert_eq!(id.level_label(Factor::Method), "accum3");
        assert_eq!(id.without_method().to_string(), "M1-S1-T1-A5-stereo");
    }

    #[test]
    fn method_codes_round_trip_and_keep_the_tags_order() {
        let mut tags = Vec::new();
        for kind in Method::ALL {
            for variant in 1..=MethodTag::MAX_VARIANTS {
                tags.push(MethodTag { kind, variant });
            }
        }
        assert!(tags.len() <= usize::from(u8::MAX), "{} method codes do not fit a byte", tags.len());
        for w in tags.windows(2) {
            assert!(w[0] < w[1] && w[0].code() < w[1].code());
        }
        for t in tags {
            assert_eq!(MethodTag::from_code(t.code()), Some(t));
            assert_eq!(t.to_string().parse::<MethodTag>(), Ok(t));
        }
        assert_eq!(MethodTag::from_code(0), None);
        assert_eq!(Factor::Method.label(0), "-");
    }

    #[test]
    fn rejects_malformed_ids_with_a_reason() {
        for (text, needle) in [
            ("M2-S2-T3", "found 3 level parts"),
            ("M2-X2-T3-A5", "should start with `S`"),
            ("M0-S2-T3-A5", "level number of 1 or more"),
            ("M2-S2-T3-A5-mono", "unknown rendering method `mono`"),
            ("M2-S2-T3-A5-guertin1", "from 2 to 42"),
            ("M2-S2-T3-A5-guertin02", "from 2 to 42"),
            ("M2-S2-T3-A5-tracer-x-stereo", "found 6 level parts"),
        ] {
            let e = text.parse::<StimulusId>().unwrap_err();
            assert!(e.to_string().contains(needle), "{e}");
            assert!(e.to_string().contains(text), "{e}");
        }
    }
}
