//! Test fixtures shared by the crates' tests: the text of an experiment definition, written
//! from one base so that every test states only what it changes. The module is always
//! compiled (it is small): behind a cargo feature, `cargo test --workspace` and the e2e
//! tests' `cargo build -p blurlab` resolved different features for this crate and so
//! compiled the renderer and everything above it twice.
//!
//! [`ExperimentToml::base`] is a complete definition using every table;
//! [`ExperimentToml::minimal`] is the same with the optional tables left out. A test
//! changes fields with struct update syntax and writes the text with `to_string()`:
//!
//! ```
//! use study::testing::ExperimentToml;
//! let text = ExperimentToml { task: "match".into(), repeats: Some(3), ..ExperimentToml::minimal() }.to_string();
//! assert!(text.contains("task = \"match\"") && text.contains("repeats = 3"));
//! ```

use std::fmt;

use crate::experiment::EXPERIMENT_FORMAT;

/// An experiment definition's text, table by table (`None` or empty: the table is left
/// out). The text lists the tables in a fixed order with a blank line before each.
#[derive(Clone, Debug, PartialEq)]
pub struct ExperimentToml {
    /// `name`.
    pub name: String,
    /// `task` (`2afc` or `match`).
    pub task: String,
    /// `question`.
    pub question: String,
    /// `view` (`mono` or `stereo`).
    pub view: String,
    /// `stimuli.material` levels.
    pub material: Vec<u8>,
    /// `stimuli.speed` levels.
    pub speed: Vec<u8>,
    /// `stimuli.shutter` levels.
    pub shutter: Vec<u8>,
    /// `stimuli.samples` levels.
    pub samples: Vec<u8>,
    /// `pairs.repeats` (`None`: no `[pairs]` table).
    pub repeats: Option<u32>,
    /// `[briefing]` and its examples.
    pub briefing: Option<BriefingToml>,
    /// One `[[practice]]` table per pair.
    pub practice: Vec<[String; 2]>,
    /// `[presentation]`.
    pub presentation: Option<PresentationToml>,
    /// `keys.first` and `keys.second` (`None`: no `[keys]` table).
    pub keys: Option<[String; 2]>,
    /// One `[[attributes]]` table each.
    pub attributes: Vec<AttributeToml>,
}

/// `[briefing]` with its `[[briefing.examples]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct BriefingToml {
    /// `briefing.text`.
    pub text: String,
    /// The examples.
    pub examples: Vec<ExampleToml>,
}

/// One `[[briefing.examples]]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct ExampleToml {
    /// `label`.
    pub label: String,
    /// `description` (`None`: left out).
    pub description: Option<String>,
    /// `stimulus` id.
    pub stimulus: String,
}

/// `[presentation]`; each `None` key is left out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PresentationToml {
    /// `gap_ms`.
    pub gap_ms: Option<u32>,
    /// `replay`.
    pub replay: Option<bool>,
    /// `loops`.
    pub loops: Option<u32>,
    /// `ready_ms`.
    pub ready_ms: Option<u32>,
    /// `break_every`.
    pub break_every: Option<u32>,
}

/// One `[[attributes]]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct AttributeToml {
    /// `key`.
    pub key: String,
    /// `question`.
    pub question: String,
    /// `options`.
    pub options: Vec<String>,
}

/// A practice pair of two stimulus ids.
pub fn pair(first: &str, second: &str) -> [String; 2] {
    [first.to_owned(), second.to_owned()]
}

impl ExperimentToml {
    /// A complete mono 2AFC definition: 9 stimuli (M2 S2 T3-5 A3-5) in pairs repeated
    /// twice, a briefing with one example, one practice pair, presentation settings, arrow
    /// keys and one participant attribute.
    pub fn base() -> ExperimentToml {
        ExperimentToml {
            name: "t".into(),
            task: "2afc".into(),
            question: "Which sequence has higher quality?".into(),
            view: "mono".into(),
            material: vec![2],
            speed: vec![2],
            shutter: vec![3, 4, 5],
            samples: vec![3, 4, 5],
            repeats: Some(2),
            briefing: Some(BriefingToml {
                text: "Look for noise.".into(),
                examples: vec![ExampleToml {
                    label: "Noise".into(),
                    description: None,
                    stimulus: "M2-S2-T3-A1".into(),
                }],
            }),
            practice: vec![pair("M2-S2-T1-A1", "M2-S2-T3-A5")],
            presentation: Some(PresentationToml {
                gap_ms: Some(300),
                replay: None,
                loops: Some(2),
                ready_ms: None,
                break_every: None,
            }),
            keys: Some(["ArrowLeft".into(), "ArrowRight".into()]),
            attributes: vec![AttributeToml {
                key: "cg_experience".into(),
                question: "Do you work in computer graphics?".into(),
                options: vec!["yes".into(), "no".into()],
            }],
        }
    }

    /// [`ExperimentToml::base`] with only the required keys: no pairs, briefing, practice,
    /// presentation, keys or attributes tables (the format's defaults apply).
    pub fn minimal() -> ExperimentToml {
        ExperimentToml {
            repeats: None,
            briefing: None,
            practice: Vec::new(),
            presentation: None,
            keys: None,
            attributes: Vec::new(),
            ..ExperimentToml::base()
        }
    }
}

/// A TOML basic string.
fn quoted(s: &str) -> String {
    toml::Value::String(s.to_owned()).to_string()
}

fn list<T: fmt::Display>(items: &[T]) -> String {
    let items: Vec<String> = items.iter().map(ToString::to_string).collect();
    format!("[{}]", items.join(", "))
}

fn strings(items: &[String]) -> String {
    let items: Vec<String> = items.iter().map(|s| quoted(s)).collect();
    list(&items)
}

impl fmt::Display for ExperimentToml {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "format = {}", quoted(EXPERIMENT_FORMAT))?;
        writeln!(f, "name = {}", quoted(&self.name))?;
        writeln!(f, "task = {}", quoted(&self.task))?;
        writeln!(f, "question = {}", quoted(&self.question))?;
        writeln!(f, "view = {}", quoted(&self.view))?;
        writeln!(f, "\n[stimuli]")?;
        writeln!(f, "material = {}", list(&self.material))?;
        writeln!(f, "speed = {}", list(&self.speed))?;
        writeln!(f, "shutter = {}", list(&self.shutter))?;
        writeln!(f, "samples = {}", list(&self.samples))?;
        if let Some(repeats) = self.repeats {
            writeln!(f, "\n[pairs]\nrepeats = {repeats}")?;
        }
        if let Some(b) = &self.briefing {
            writeln!(f, "\n[briefing]\ntext = {}", quoted(&b.text))?;
            for e in &b.examples {
                writeln!(f, "[[briefing.examples]]\nlabel = {}", quoted(&e.label))?;
                if let Some(d) = &e.description {
                    writeln!(f, "description = {}", quoted(d))?;
                }
                writeln!(f, "stimulus = {}", quoted(&e.stimulus))?;
            }
        }
        for p in &self.practice {
            writeln!(f, "\n[[practice]]\npair = {}", strings(p))?;
        }
        if let Some(p) = &self.presentation {
            writeln!(f, "\n[presentation]")?;
            if let Some(gap) = p.gap_ms {
                writeln!(f, "gap_ms = {gap}")?;
            }
            if let Some(replay) = p.replay {
                writeln!(f, "replay = {replay}")?;
            }
            if let Some(loops) = p.loops {
                writeln!(f, "loops = {loops}")?;
            }
            if let Some(ready) = p.ready_ms {
                writeln!(f, "ready_ms = {ready}")?;
            }
            if let Some(every) = p.break_every {
                writeln!(f, "break_every = {every}")?;
            }
        }
        if let Some([first, second]) = &self.keys {
            writeln!(f, "\n[keys]\nfirst = {}\nsecond = {}", quoted(first), quoted(second))?;
        }
        for a in &self.attributes {
            writeln!(f, "\n[[attributes]]\nkey = {}\nquestion = {}", quoted(&a.key), quoted(&a.question))?;
            writeln!(f, "options = {}", strings(&a.options))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::experiment::ExperimentDefinition;

    #[test]
    fn both_fixtures_parse() {
        for text in [ExperimentToml::base().to_string(), ExperimentToml::minimal().to_string()] {
            ExperimentDefinition::parse(Path::new("t.toml"), &text).unwrap_or_else(|e| panic!("{e}\n{text}"));
        }
        let minimal = ExperimentToml::minimal().to_string();
        assert!(!minimal.contains("[pairs]") && !minimal.contains("[[practice]]"), "{minimal}");
    }
}
