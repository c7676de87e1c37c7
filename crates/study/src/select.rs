//! Selecting stimuli by factor levels (`blurlab stimuli render --only "M2 S2 T3-T5 *"`).
//!
//! An expression is whitespace-separated terms. A term is `*` (no constraint), or a factor
//! letter with levels: `T3`, a range `T3-T5` (or `T3-5`), or a comma list `M1,M3,T2-4` whose
//! items all belong to the first item's factor. Factors a term does not name are
//! unconstrained; naming a factor twice is an error. `mono` or `stereo` restricts the view.
//! In a design with a method factor, a term of method tags (`guertin`, `tracer,accum2`)
//! restricts the method levels.

use std::collections::BTreeSet;
use std::fmt;
use std::str::FromStr;

use crate::ids::{Factor, MethodTag, StimulusId, View};

/// A parsed `--only` expression.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Selection {
    levels: [Option<BTreeSet<u8>>; 4],
    methods: Option<BTreeSet<MethodTag>>,
    view: Option<View>,
    text: String,
}

/// Why an expression does not parse.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("selection `{text}`: {reason} (expected terms like `M2 S2 T3-T5 *`)")]
pub struct SelectError {
    /// The expression.
    pub text: String,
    /// What is wrong with it.
    pub reason: String,
}

fn factor_of(letter: char) -> Option<Factor> {
    Factor::ALL.into_iter().find(|f| f.letter() == letter.to_ascii_uppercase())
}

fn index(factor: Factor) -> usize {
    Factor::ALL.iter().position(|f| *f == factor).unwrap_or(0)
}

impl FromStr for Selection {
    type Err = SelectError;

    fn from_str(text: &str) -> Result<Self, SelectError> {
        let err = |reason: String| SelectError { text: text.to_owned(), reason };
        let mut selection = Selection { text: text.trim().to_owned(), ..Selection::default() };
        for term in text.split_whitespace() {
            match term {
                "*" => continue,
                "mono" | "stereo" => {
                    let view = if term == "mono" { View::Mono } else { View::Stereo };
                    if selection.view.replace(view).is_some() {
                        return Err(err(format!("`{term}`: the view is named twice")));
                    }
                    continue;
                }
                _ => {}
            }
            if let Ok(tags) = term.split(',').map(str::parse::<MethodTag>).collect::<Result<BTreeSet<_>, _>>() {
                if selection.methods.replace(tags).is_some() {
                    return Err(err(format!("`{term}`: the method is named twice")));
                }
                continue;
            }
            let first = term.chars().next().and_then(factor_of).ok_or_else(|| {
                err(format!(
                    "`{term}` should start with a factor letter (M, S, T, A), or be method tags, `*`, `mono` or `stereo`"
                ))
            })?;
            let mut set = BTreeSet::new();
            for item in term.split(',') {
                let bad = || err(format!("`{item}` in `{term}` is not a level or range of {}", first.letter()));
                let rest = item
                    .strip_prefix(first.letter())
                    .or_else(|| item.strip_prefix(first.letter().to_ascii_lowercase()))
                    .ok_or_else(bad)?;
                let (lo, hi) = match rest.split_once('-') {
                    Some((lo, hi)) => {
                        let hi = hi
                            .strip_prefix(first.letter())
                            .or_else(|| hi.strip_prefix(first.letter().to_ascii_lowercase()))
                            .unwrap_or(hi);
                        (lo, hi)
                    }
                    None => (rest, rest),
                };
                let parse = |s: &str| s.parse::<u8>().ok().filter(|&l| l >= 1).ok_or_else(bad);
                let (lo, hi) = (parse(lo)?, parse(hi)?);
                if lo > hi {
                    return Err(err(format!("`{item}`: the range runs backwards")));
                }
                set.extend(lo..=hi);
            }
            let slot = &mut selection.levels[index(first)];
            if slot.is_some() {
                return Err(err(format!("factor {} is named twice", first.letter())));
            }
            *slot = Some(set);
        }
        Ok(selection)
    }
}

impl Selection {
    /// The selection that keeps everything.
    pub fn all() -> Self {
        Selection::default()
    }

    /// Whether `id` is selected.
    pub fn matches(&self, id: &StimulusId) -> bool {
        self.view.is_none_or(|v| v == id.view)
            && self.methods.as_ref().is_none_or(|set| id.method.is_some_and(|m| set.contains(&m)))
            && Factor::ALL.iter().all(|&f| self.levels[index(f)].as_ref().is_none_or(|set| set.contains(&id.level(f))))
    }

    /// Levels named for `factor` that exceed `count` (the design's number of levels).
    pub fn missing_levels(&self, factor: Factor, count: u8) -> Vec<u8> {
        self.levels[index(factor)]
            .as_ref()
            .map_or(Vec::new(), |set| set.iter().copied().filter(|&l| l > count).collect())
    }
}

impl fmt::Display for Selection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.text.is_empty() { "*" } else { &self.text })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(s: &str) -> StimulusId {
        s.parse().unwrap()
    }

    #[test]
    fn selects_by_levels_ranges_lists_and_view() {
        let sel: Selection = "M2 S2 T3-T5 *".parse().unwrap();
        assert!(sel.matches(&id("M2-S2-T3-A1")));
        assert!(sel.matches(&id("M2-S2-T5-A5-stereo")));
        assert!(!sel.matches(&id("M2-S2-T2-A1")));
        assert!(!sel.matches(&id("M1-S2-T3-A1")));
        let sel: Selection = "M1,M3 T2-4 A5 stereo".parse().unwrap();
        assert!(sel.matches(&id("M3-S1-T4-A5-stereo")));
        assert!(!sel.matches(&id("M3-S1-T4-A5")));
        assert!(!sel.matches(&id("M2-S1-T4-A5-stereo")));
        assert!(Selection::all().matches(&id("M9-S9-T9-A9")));
        assert_eq!("T3-6".parse::<Selection>().unwrap().missing_levels(Factor::Shutter, 5), vec![6]);
        let sel: Selection = "M3 guertin,tracer2 A1".parse().unwrap();
        assert!(sel.matches(&id("M3-S1-T4-A1-guertin")));
        assert!(sel.matches(&id("M3-S1-T4-A1-tracer2-stereo")));
        assert!(!sel.matches(&id("M3-S1-T4-A1-tracer")));
        assert!(!sel.matches(&id("M3-S1-T4-A1")));
        assert!("accum mcguire".parse::<Selection>().unwrap_err().to_string().contains("method is named twice"));
    }

    #[test]
    fn rejects_bad_terms_with_a_reason() {
        for (text, needle) in [
            ("X2", "factor letter"),
            ("M2 M3", "named twice"),
            ("T5-T3", "backwards"),
            ("T0", "not a level"),
            ("M1,S2", "not a level"),
            ("mono stereo", "view is named twice"),
        ] {
            let e = text.parse::<Selection>().unwrap_err();
            assert!(e.to_string().contains(needle), "{text}: {e}");
        }
    }
}
