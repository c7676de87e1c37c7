//! Experiment definitions (`experiments/*.toml`, format `blurlab-experiment/1`): the task,
//! the question shown, the stimuli (by factor levels), how pairs are formed, randomisation,
//! the briefing with labelled example sequences, practice trials, presentation, display
//! mode and response keys. docs/formats.md describes the format.
//!
//! Parsing checks everything that can be checked without a stimulus set; every error names
//! the file, the line and the key. Whether the stimuli exist in a rendered set is checked
//! by the runner against the set's index before the first trial.

use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::fsio::sha256_hex;
use crate::ids::MethodTag;
use crate::ids::{StimulusId, View};
use crate::response::Task;
use crate::toml_locate::{TomlError, backticked, key_line};

/// Format tag of an experiment definition.
pub const EXPERIMENT_FORMAT: &str = "blurlab-experiment/1";
/// The most repeats of each pair.
pub const MAX_REPEATS: u32 = 1000;
/// The most counted trials of a session (pairs x repeats).
pub const MAX_TRIALS: u64 = 100_000;
/// The most loops of a sequence per presentation.
pub const MAX_LOOPS: u32 = 100;

/// How the two eyes of a stereo sequence (or the one image of a mono sequence) reach the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum DisplayMode {
    /// One image; for a stereo sequence the left eye only.
    Mono,
    /// Side by side at full width (free fusion, mirror stereoscopes): the frame as rendered.
    SbsFull,
    /// Side by side squeezed to half width per eye (3D displays in side-by-side mode).
    SbsHalf,
    /// Left eye on top, right eye below, each squeezed to half height (3D displays).
    TopBottom,
    /// Red-cyan anaglyph with Dubois's least-squares matrices.
    Anaglyph,
    /// Even screen lines (physical pixel rows from the top of the window) show the left eye,
    /// odd ones the right (passive polarised monitors), whatever the stimulus's scale.
    RowInterleaved,
}

impl DisplayMode {
    /// All modes, in documentation order.
    pub const ALL: [DisplayMode; 6] = [
        DisplayMode::Mono,
        DisplayMode::SbsFull,
        DisplayMode::SbsHalf,
        DisplayMode::TopBottom,
        DisplayMode::Anaglyph,
        DisplayMode::RowInterleaved,
    ];

    /// The name used in definitions and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            DisplayMode::Mono => "mono",
            DisplayMode::SbsFull => "sbs-full",
            DisplayMode::SbsHalf => "sbs-half",
            DisplayMode::TopBottom => "top-bottom",
            DisplayMode::Anaglyph => "anaglyph",
            DisplayMode::RowInterleaved => "row-interleaved",
        }
    }
}

impl fmt::Display for DisplayMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for DisplayMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        DisplayMode::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<&str> = DisplayMode::ALL.iter().map(|m| m.name()).collect();
            format!("display mode `{s}` is not one of {}", names.join(", "))
        })
    }
}

/// A labelled example sequence of the briefing.
#[derive(Clone, Debug, PartialEq)]
pub struct Example {
    /// Short label shown above the sequence, e.g. `Noise`.
    pub label: String,
    /// One sentence explaining what to look for.
    pub description: String,
    /// The sequence shown.
    pub stimulus: StimulusId,
}

/// The briefing shown before the first trial.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Briefing {
    /// Text shown first.
    pub text: String,
    /// Example sequences (noise, flicker/strobing, excessive blur).
    pub examples: Vec<Example>,
}

/// A practice trial: an extreme pair, flagged in the log and never analysed.
#[derive(Clone, Debug, PartialEq)]
pub struct PracticeTrial {
    /// The two stimuli (2AFC) or the two candidates (matching).
    pub pair: [StimulusId; 2],
    /// For matching: which of the pair is the reference (the first when not given).
    pub reference: Option<StimulusId>,
}

/// How a trial is played.
#[derive(Clone, Debug, PartialEq)]
pub struct Presentation {
    /// Blank gap between sequences in milliseconds.
    pub gap_ms: u32,
    /// Whether the participant may replay a trial.
    pub replay: bool,
    /// How many times each sequence loops per presentation.
    pub loops: u32,
    /// Visual angle the stimulus (one eye's width) subtends, in degrees.
    pub visual_angle_deg: f64,
    /// A break after every this many counted trials (0: no breaks).
    pub break_every: u32,
}

/// Response keys (egui key names: `A`-`Z`, `0`-`9`, `ArrowLeft`, `ArrowRight`, `Space`, ...).
#[derive(Clone, Debug, PartialEq)]
pub struct Keys {
    /// Chooses the first sequence (2AFC) or the left candidate (matching).
    pub first: String,
    /// Chooses the second sequence or the right candidate.
    pub second: String,
    /// Replays the trial.
    pub replay: String,
}

/// An optional participant attribute asked on the start screen.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// Key in the log header's `attributes` JSON.
    pub key: String,
    /// Question shown.
    pub question: String,
    /// Allowed answers.
    pub options: Vec<String>,
}

/// A parsed, checked experiment definition.
#[derive(Clone, Debug, PartialEq)]
pub struct ExperimentDefinition {
    /// The file it was read from.
    pub path: PathBuf,
    /// SHA-256 of the file (recorded in every log).
    pub sha256: String,
    /// Name, e.g. `mono-3-interactions` (results go under `results/NAME/`).
    pub name: String,
    /// Title shown to the experimenter.
    pub title: String,
    /// `2afc` or `match`.
    pub task: Task,
    /// The question shown with every trial.
    pub question: String,
    /// Mono or stereo sequences.
    pub view: View,
    /// The stimuli: the product of the listed levels, sorted.
    pub stimuli: Vec<StimulusId>,
    /// How many times each unordered pair is presented.
    pub repeats: u32,
    /// Shuffle the order of the pairs.
    pub shuffle_pairs: bool,
    /// Shuffle the order within a pair (2AFC) or the candidate slots (matching).
    pub shuffle_within_pair: bool,
    /// The briefing.
    pub briefing: Briefing,
    /// Practice trials, shown after the briefing in the order given.
    pub practice: Vec<PracticeTrial>,
    /// Playback settings.
    pub presentation: Presentation,
    /// Default display mode (the command line may override it).
    pub display: DisplayMode,
    /// Response keys.
    pub keys: Keys,
    /// Participant attributes asked on the start screen.
    pub attributes: Vec<Attribute>,
}

impl ExperimentDefinition {
    /// Every stimulus the experiment can show: trials, practice and briefing examples.
    pub fn all_stimuli(&self) -> BTreeSet<StimulusId> {
        let mut all: BTreeSet<StimulusId> = self.stimuli.iter().copied().collect();
        for p in &self.practice {
            all.extend(p.pair);
        }
        all.extend(self.briefing.examples.iter().map(|e| e.stimulus));
        all
    }

    /// Reads and checks a definition file.
    pub fn read(path: &Path) -> Result<Self, ExperimentError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| ExperimentError::Io { path: path.to_owned(), source })?;
        Self::parse(path, &text)
    }

    /// Parses definition text read from `path`.
    pub fn parse(path: &Path, text: &str) -> Result<Self, ExperimentError> {
        let raw: RawDefinition = toml::from_str(text).map_err(|e| {
            let at = TomlError::new(text, &e);
            let key = backticked(&at.message).or_else(|| at.written_key(text).map(str::to_owned)).unwrap_or_default();
            ExperimentError::Invalid { path: path.to_owned(), line: at.line, key, message: at.message }
        })?;
        let bad = |table: &str, index: Option<usize>, key: &str, message: String| ExperimentError::Invalid {
            path: path.to_owned(),
            line: key_line(text, table, index, key).unwrap_or(1),
            key: if table.is_empty() { key.to_owned() } else { format!("{table}.{key}") },
            message,
        };

        if raw.format != EXPERIMENT_FORMAT {
            return Err(bad("", None, "format", format!("is `{}`, expected `{EXPERIMENT_FORMAT}`", raw.format)));
        }
        let name_ok =
            !raw.name.is_empty() && raw.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !name_ok {
            return Err(bad("", None, "name", format!("`{}` must be letters, digits, `-` or `_`", raw.name)));
        }
        let task: Task = raw.task.parse().map_err(|m| bad("", None, "task", m))?;
        if raw.question.trim().is_empty() {
            return Err(bad("", None, "question", "must not be empty".into()));
        }
        let view = match raw.view.as_str() {
            "mono" => View::Mono,
            "stereo" => View::Stereo,
            other => return Err(bad("", None, "view", format!("`{other}` is neither `mono` nor `stereo`"))),
        };

        // Stimuli: the product of the listed levels.
        let s = &raw.stimuli;
        for (key, levels) in
            [("material", &s.material), ("speed", &s.speed), ("shutter", &s.shutter), ("samples", &s.samples)]
        {
            if levels.is_empty() {
                return Err(bad("stimuli", None, key, "lists no levels".into()));
            }
            if let Some(l) = levels.iter().find(|&&l| l == 0) {
                return Err(bad("stimuli", None, key, format!("level {l} is not a 1-based level")));
            }
            let unique: BTreeSet<_> = levels.iter().collect();
            if unique.len() != levels.len() {
                return Err(bad("stimuli", None, key, "lists a level twice".into()));
            }
        }
        let mut methods: Vec<Option<MethodTag>> = Vec::new();
        for text in &s.method {
            let tag = text.parse::<MethodTag>().map_err(|m| bad("stimuli", None, "method", m))?;
            if methods.contains(&Some(tag)) {
                return Err(bad("stimuli", None, "method", format!("lists `{tag}` twice")));
            }
            methods.push(Some(tag));
        }
        if methods.is_empty() {
            methods.push(None);
        }
        let mut stimuli = Vec::new();
        for &material in &s.material {
            for &speed in &s.speed {
                for &shutter in &s.shutter {
                    for &samples in &s.samples {
                        for &method in &methods {
                            stimuli.push(StimulusId { material, speed, shutter, samples, method, view });
                        }
                    }
                }
            }
        }
        stimuli.sort();
        if stimuli.len() < 2 {
            return Err(bad(
                "stimuli",
                None,
                "samples",
                "the levels give fewer than 2 stimuli: nothing to pair".into(),
            ));
        }

        let pairs = raw.pairs.unwrap_or_default();
        if pairs.mode != "all" {
            return Err(bad("pairs", None, "mode", format!("`{}` is not supported (only `all`)", pairs.mode)));
        }
        if pairs.repeats == 0 {
            return Err(bad("pairs", None, "repeats", "must be 1 or more".into()));
        }
        if pairs.repeats > MAX_REPEATS {
            return Err(bad(
                "pairs",
                None,
                "repeats",
                format!("{} is above the limit of {MAX_REPEATS}", pairs.repeats),
            ));
        }
        let n = stimuli.len() as u64;
        let trials = n * (n - 1) / 2 * u64::from(pairs.repeats);
        if trials > MAX_TRIALS {
            return Err(bad(
                "pairs",
                None,
                "repeats",
                format!(
                    "{n} stimuli in {} pairs x {} repeats make {trials} trials, above the limit of {MAX_TRIALS}",
                    n * (n - 1) / 2,
                    pairs.repeats
                ),
            ));
        }
        let rnd = raw.randomisation.unwrap_or_default();

        let id_of = |table: &str, index: Option<usize>, key: &str, text: &str| -> Result<StimulusId, ExperimentError> {
            let id: StimulusId =
                text.parse().map_err(|e: crate::ids::IdError| bad(table, index, key, e.to_string()))?;
            if id.view != view {
                return Err(bad(
                    table,
                    index,
                    key,
                    format!("{id} is not a {} sequence like the experiment's `view`", view_name(view)),
                ));
            }
            Ok(id)
        };

        let raw_briefing = raw.briefing.unwrap_or_default();
        let mut examples = Vec::new();
        for (i, e) in raw_briefing.examples.iter().enumerate() {
            if e.label.trim().is_empty() {
                return Err(bad("briefing.examples", Some(i), "label", "must not be empty".into()));
            }
            examples.push(Example {
                label: e.label.clone(),
                description: e.description.clone(),
                stimulus: id_of("briefing.examples", Some(i), "stimulus", &e.stimulus)?,
            });
        }
        let briefing = Briefing { text: raw_briefing.text, examples };

        let mut practice = Vec::new();
        for (i, p) in raw.practice.iter().enumerate() {
            let pair =
                [id_of("practice", Some(i), "pair", &p.pair[0])?, id_of("practice", Some(i), "pair", &p.pair[1])?];
            let reference = match &p.reference {
                None => None,
                Some(r) => {
                    let r = id_of("practice", Some(i), "reference", r)?;
                    if !pair.contains(&r) {
                        return Err(bad("practice", Some(i), "reference", format!("{r} is not one of the pair")));
                    }
                    Some(r)
                }
            };
            if task == Task::TwoAfc && reference.is_some() {
                return Err(bad("practice", Some(i), "reference", "only matching trials have a reference".into()));
            }
            if pair[0] == pair[1] {
                return Err(bad("practice", Some(i), "pair", "the two stimuli must differ".into()));
            }
            practice.push(PracticeTrial { pair, reference });
        }

        let p = raw.presentation.unwrap_or_default();
        if p.loops == 0 || p.loops > MAX_LOOPS {
            return Err(bad("presentation", None, "loops", format!("must be 1 to {MAX_LOOPS}, found {}", p.loops)));
        }
        if !(p.visual_angle_deg > 0.0 && p.visual_angle_deg < 120.0) {
            return Err(bad(
                "presentation",
                None,
                "visual_angle_deg",
                format!("{} is not between 0 and 120 degrees", p.visual_angle_deg),
            ));
        }
        if p.gap_ms > 10_000 {
            return Err(bad("presentation", None, "gap_ms", format!("{} ms is longer than 10 s", p.gap_ms)));
        }
        let presentation = Presentation {
            gap_ms: p.gap_ms,
            replay: p.replay,
            loops: p.loops,
            visual_angle_deg: p.visual_angle_deg,
            break_every: p.break_every,
        };

        let display_text = raw.display.unwrap_or_default().mode.unwrap_or_else(|| match view {
            View::Mono => "mono".into(),
            View::Stereo => "sbs-full".into(),
        });
        let display: DisplayMode = display_text.parse().map_err(|m| bad("display", None, "mode", m))?;
        if view == View::Mono && display != DisplayMode::Mono {
            return Err(bad(
                "display",
                None,
                "mode",
                format!("`{display}` needs stereo sequences; this experiment is mono"),
            ));
        }

        let k = raw.keys.unwrap_or_default();
        for (key, value) in [("first", &k.first), ("second", &k.second), ("replay", &k.replay)] {
            if !is_key_name(value) {
                return Err(bad(
                    "keys",
                    None,
                    key,
                    format!(
                        "`{value}` is not a key name (A-Z, 0-9, ArrowLeft, ArrowRight, ArrowUp, ArrowDown, Space, Enter)"
                    ),
                ));
            }
        }
        if k.first == k.second || k.first == k.replay || k.second == k.replay {
            return Err(bad("keys", None, "second", "the first, second and replay keys must differ".into()));
        }
        let keys = Keys { first: k.first, second: k.second, replay: k.replay };

        let mut attributes = Vec::new();
        for (i, a) in raw.attributes.iter().enumerate() {
            if a.key.is_empty() || !a.key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(bad("attributes", Some(i), "key", format!("`{}` must be letters, digits or `_`", a.key)));
            }
            if a.options.len() < 2 {
                return Err(bad("attributes", Some(i), "options", "needs at least 2 options".into()));
            }
            attributes.push(Attribute { key: a.key.clone(), question: a.question.clone(), options: a.options.clone() });
        }

        Ok(ExperimentDefinition {
            path: path.to_owned(),
            sha256: sha256_hex(text.as_bytes()),
            name: raw.name,
            title: raw.title.unwrap_or_default(),
            task,
            question: raw.question,
            view,
            stimuli,
            repeats: pairs.repeats,
            shuffle_pairs: rnd.pair_order,
            shuffle_within_pair: rnd.within_pair,
            briefing,
            practice,
            presentation,
            display,
            keys,
            attributes,
        })
    }
}

fn view_name(view: View) -> &'static str {
    match view {
        View::Mono => "mono",
        View::Stereo => "stereo",
    }
}

/// Whether `name` is a response key name the runner accepts.
pub fn is_key_name(name: &str) -> bool {
    let single = name.len() == 1 && name.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit());
    single || ["ArrowLeft", "ArrowRight", "ArrowUp", "ArrowDown", "Space", "Enter"].contains(&name)
}

/// Why a definition cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// A key is missing, malformed or inconsistent.
    #[error("{path}: line {line}: key `{key}`: {message}")]
    Invalid {
        /// File.
        path: PathBuf,
        /// 1-based line (of the key, or of its table when the key is missing).
        line: usize,
        /// Dotted key, e.g. `presentation.loops`.
        key: String,
        /// What is wrong.
        message: String,
    },
}

fn default_true() -> bool {
    true
}
fn default_one() -> u32 {
    1
}
fn default_all() -> String {
    "all".into()
}
fn default_angle() -> f64 {
    14.4
}
fn default_gap() -> u32 {
    500
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDefinition {
    format: String,
    name: String,
    title: Option<String>,
    task: String,
    question: String,
    view: String,
    stimuli: RawStimuli,
    pairs: Option<RawPairs>,
    randomisation: Option<RawRandomisation>,
    briefing: Option<RawBriefing>,
    #[serde(default)]
    practice: Vec<RawPractice>,
    presentation: Option<RawPresentation>,
    display: Option<RawDisplay>,
    keys: Option<RawKeys>,
    #[serde(default)]
    attributes: Vec<RawAttribute>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStimuli {
    material: Vec<u8>,
    speed: Vec<u8>,
    shutter: Vec<u8>,
    samples: Vec<u8>,
    /// Method levels by tag (`tracer`, `guertin2`), for sets of a design with a method factor.
    #[serde(default)]
    method: Vec<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPairs {
    #[serde(default = "default_all")]
    mode: String,
    #[serde(default = "default_one")]
    repeats: u32,
}
impl Default for RawPairs {
    fn default() -> Self {
        RawPairs { mode: default_all(), repeats: 1 }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRandomisation {
    #[serde(default = "default_true")]
    pair_order: bool,
    #[serde(default = "default_true")]
    within_pair: bool,
}
impl Default for RawRandomisation {
    fn default() -> Self {
        RawRandomisation { pair_order: true, within_pair: true }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawBriefing {
    #[serde(default)]
    text: String,
    #[serde(default)]
    examples: Vec<RawExample>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawExample {
    label: String,
    #[serde(default)]
    description: String,
    stimulus: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPractice {
    pair: [String; 2],
    reference: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPresentation {
    #[serde(default = "default_gap")]
    gap_ms: u32,
    #[serde(default = "default_true")]
    replay: bool,
    #[serde(default = "default_one")]
    loops: u32,
    #[serde(default = "default_angle")]
    visual_angle_deg: f64,
    #[serde(default)]
    break_every: u32,
}
impl Default for RawPresentation {
    fn default() -> Self {
        RawPresentation {
            gap_ms: default_gap(),
            replay: true,
            loops: 1,
            visual_angle_deg: default_angle(),
            break_every: 0,
        }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawDisplay {
    mode: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeys {
    #[serde(default = "key_first")]
    first: String,
    #[serde(default = "key_second")]
    second: String,
    #[serde(default = "key_replay")]
    replay: String,
}
fn key_first() -> String {
    "1".into()
}
fn key_second() -> String {
    "2".into()
}
fn key_replay() -> String {
    "R".into()
}
impl Default for RawKeys {
    fn default() -> Self {
        RawKeys { first: key_first(), second: key_second(), replay: key_replay() }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAttribute {
    key: String,
    question: String,
    options: Vec<String>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::ExperimentToml;

    /// The base fixture: a complete definition using every table.
    fn good() -> String {
        ExperimentToml::base().to_string()
    }

    fn parse(text: &str) -> Result<ExperimentDefinition, ExperimentError> {
        ExperimentDefinition::parse(Path::new("experiments/t.toml"), text)
    }

    #[test]
    fn parses_a_complete_definition() {
        let d = parse(&good()).unwrap();
        assert_eq!(d.task, Task::TwoAfc);
        assert_eq!(d.stimuli.len(), 9);
        assert_eq!(d.stimuli[0].to_string(), "M2-S2-T3-A3");
        assert_eq!(d.repeats, 2);
        assert!(d.shuffle_pairs && d.shuffle_within_pair && d.presentation.replay);
        assert_eq!(d.presentation.loops, 2);
        assert_eq!(d.presentation.visual_angle_deg, 14.4);
        assert_eq!(d.display, DisplayMode::Mono);
        assert_eq!(d.keys.replay, "R");
        assert_eq!(d.all_stimuli().len(), 11);
        assert_eq!(d.attributes[0].options, ["yes", "no"]);
    }

    fn error_of(from: &str, to: &str) -> String {
        let good = good();
        assert!(good.contains(from), "{from}");
        parse(&good.replacen(from, to, 1)).unwrap_err().to_string()
    }

    #[test]
    fn each_bad_key_is_named_with_its_line() {
        let cases = [
            ("task = \"2afc\"", "task = \"rank\"", "line 3: key `task`: task `rank` is neither"),
            ("view = \"mono\"", "view = \"both\"", "line 5: key `view`"),
            ("shutter = [3, 4, 5]", "shutter = []", "line 10: key `stimuli.shutter`: lists no levels"),
            ("shutter = [3, 4, 5]", "shutter = [3, 3]", "line 10: key `stimuli.shutter`: lists a level twice"),
            ("samples = [3, 4, 5]", "samples = [0]", "line 11: key `stimuli.samples`: level 0"),
            ("repeats = 2", "repeats = 0", "line 14: key `pairs.repeats`: must be 1 or more"),
            ("stimulus = \"M2-S2-T3-A1\"", "stimulus = \"M2-S2-T3\"", "line 20: key `briefing.examples.stimulus`"),
            ("stimulus = \"M2-S2-T3-A1\"", "stimulus = \"M2-S2-T3-A1-stereo\"", "is not a mono sequence"),
            (
                "\"M2-S2-T1-A1\", \"M2-S2-T3-A5\"",
                "\"M2-S2-T1-A1\", \"M2-S2-T1-A1\"",
                "line 23: key `practice.pair`: the two",
            ),
            ("loops = 2", "loops = 0", "line 27: key `presentation.loops`"),
            ("first = \"ArrowLeft\"", "first = \"Ctrl\"", "line 30: key `keys.first`: `Ctrl` is not a key name"),
            ("second = \"ArrowRight\"", "second = \"ArrowLeft\"", "key `keys.second`: the first, second and replay"),
            ("options = [\"yes\", \"no\"]", "options = [\"yes\"]", "line 36: key `attributes.options`"),
            ("format = \"blurlab-experiment/1\"", "format = \"x/2\"", "line 1: key `format`"),
            ("[pairs]", "[pairs]\nmode = \"some\"", "line 14: key `pairs.mode`"),
            ("loops = 2", "loops = 2\nspeed = 3", "line 28: key `speed`: unknown field `speed`"),
            ("[keys]", "[display]\nmode = \"anaglyph\"\n[keys]", "key `display.mode`: `anaglyph` needs stereo"),
            ("[keys]", "[display]\nmode = \"3d\"\n[keys]", "display mode `3d` is not one of"),
        ];
        for (from, to, needle) in cases {
            let e = error_of(from, to);
            assert!(e.starts_with("experiments/t.toml: line "), "{e}");
            assert!(e.contains(needle), "replacing {from:?}: expected {needle:?} in {e}");
        }
        let e = parse(&good().replace("question = \"Which sequence has higher quality?\"\n", "")).unwrap_err();
        assert!(e.to_string().contains("key `question`: missing field `question`"), "{e}");
    }

    #[test]
    fn shipped_definitions_parse() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
        let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let mut parsed = 0;
        for entry in entries {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let d = ExperimentDefinition::read(&path).unwrap_or_else(|e| panic!("{e}"));
                assert_eq!(Some(d.name.as_str()), path.file_stem().and_then(|s| s.to_str()), "{}", path.display());
                parsed += 1;
            }
        }
        // Tests #1-#3, mono and stereo, with the sampling and shutter variants of #2.
        assert!(parsed >= 9, "only {parsed} definitions in {}", dir.display());
    }
}
