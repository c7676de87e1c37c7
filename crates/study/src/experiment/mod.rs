//! Experiment definitions (`experiments/*.toml`, format `blurlab-experiment/1`): the task,
//! the question shown, the stimuli (by factor levels), how pairs are formed, randomisation,
//! the briefing with labelled example sequences, practice trials, presentation, display
//! mode and response keys. docs/formats.md describes the format.
//!
//! Parsing checks everything that can be checked without a stimulus set; every error names
//! the file, the line and the key. Whether the stimuli exist in a rendered set is checked
//! by the runner against the set's index before the first trial.

mod parse;
mod spec;

pub use parse::is_key_name;

use std::fmt;
use std::path::PathBuf;

use serde::Deserialize;

use crate::ids::{StimulusId, View};
use crate::response::Task;

/// Format tag of an experiment definition.
pub const EXPERIMENT_FORMAT: &str = "blurlab-experiment/1";

/// The most repeats of each pair.
pub const MAX_REPEATS: u32 = 1000;

/// The most counted trials of a session (pairs x repeats).
pub const MAX_TRIALS: u64 = 100_000;

/// The most counted trials a participant can be given with `selection = "asap"` or
/// `"random"` (about seven hours at 5 s a trial: more belongs in several experiments).
pub const MAX_BUDGET: u32 = 5000;

/// How the pairs of a 2AFC experiment are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PairSelection {
    /// Every unordered pair, `repeats` times (a complete design).
    All {
        /// How many times each pair is shown in a session.
        repeats: u32,
    },
    /// Active sampling (ASAP): each next pair where it is expected to teach the most, from a
    /// posterior shared by every session of the experiment.
    Asap {
        /// Counted trials per session.
        budget: u32,
    },
    /// A uniformly random pair each trial (the baseline of active sampling).
    Random {
        /// Counted trials per session.
        budget: u32,
    },
}

impl PairSelection {
    /// The `selection` value naming it.
    pub fn name(self) -> &'static str {
        match self {
            PairSelection::All { .. } => "all",
            PairSelection::Asap { .. } => "asap",
            PairSelection::Random { .. } => "random",
        }
    }

    /// Repeats of each pair (1 for the budgeted selections, where it has no meaning).
    pub fn repeats(self) -> u32 {
        match self {
            PairSelection::All { repeats } => repeats,
            _ => 1,
        }
    }

    /// Counted trials of a session over `stimuli` stimuli.
    pub fn counted_trials(self, stimuli: usize) -> usize {
        match self {
            PairSelection::All { repeats } => stimuli * stimuli.saturating_sub(1) / 2 * repeats as usize,
            PairSelection::Asap { budget } | PairSelection::Random { budget } => budget as usize,
        }
    }

    /// Whether every pair is shown (so Kendall's statistics apply).
    pub fn is_complete(self) -> bool {
        matches!(self, PairSelection::All { .. })
    }
}

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

/// The participant-facing title of a definition that gives none.
pub const DEFAULT_PARTICIPANT_TITLE: &str = "Video quality study";

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
    /// How long the ready screen (a fixation mark on the neutral field) is shown before each
    /// trial, in milliseconds (`ready_ms`, default 800; 0: no ready screen).
    pub ready_ms: u32,
    /// Whether the ready screen waits for the participant to press Space or Enter (after
    /// `ready_ms`) instead of moving on by itself.
    pub ready_press: bool,
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
    /// Title shown to the experimenter (may name design codes).
    pub title: String,
    /// Title shown to participants (`participant_title`; [`DEFAULT_PARTICIPANT_TITLE`] when
    /// not given): never design codes.
    pub participant_title: String,
    /// `2afc` or `match`.
    pub task: Task,
    /// The question shown with every trial.
    pub question: String,
    /// Mono or stereo sequences.
    pub view: View,
    /// The stimuli: the product of the listed levels, sorted.
    pub stimuli: Vec<StimulusId>,
    /// How many times each unordered pair is presented (1 unless `selection` is `all`).
    pub repeats: u32,
    /// How pairs are chosen: all of them, or a budget of actively or randomly chosen ones.
    pub selection: PairSelection,
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

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
        // Defaults of the keys the base leaves out.
        assert_eq!((d.presentation.ready_ms, d.presentation.ready_press), (800, false));
        assert_eq!(d.participant_title, DEFAULT_PARTICIPANT_TITLE);
    }

    #[test]
    fn budgeted_selections_parse_and_bad_budgets_name_their_key() {
        let with = |pairs: &str| good().replacen("[pairs]\nrepeats = 2", &format!("[pairs]\n{pairs}"), 1);
        assert!(good().contains("[pairs]\nrepeats = 2"));
        let d = parse(&with("selection = \"asap\"\nbudget = 20")).unwrap();
        assert_eq!(d.selection, PairSelection::Asap { budget: 20 });
        assert_eq!((d.repeats, d.selection.counted_trials(9), d.selection.is_complete()), (1, 20, false));
        let d = parse(&with("selection = \"random\"\nbudget = 7")).unwrap();
        assert_eq!(d.selection, PairSelection::Random { budget: 7 });
        let d = parse(&with("mode = \"all\"\nrepeats = 3")).unwrap();
        assert_eq!((d.selection, d.selection.counted_trials(9)), (PairSelection::All { repeats: 3 }, 108));
        let cases = [
            ("selection = \"asap\"\nbudget = 0", "line 15: key `pairs.budget`: 0 trials: expected 1 to 5000"),
            ("selection = \"asap\"\nbudget = 5001", "key `pairs.budget`: 5001 trials"),
            ("selection = \"asap\"", "key `pairs.budget`: `asap` needs a budget"),
            ("selection = \"asap\"\nbudget = 5\nrepeats = 2", "key `pairs.repeats`: `asap` chooses its own pairs"),
            ("selection = \"all\"\nbudget = 5", "key `pairs.budget`: a budget applies to"),
            ("selection = \"best\"", "line 14: key `pairs.selection`: `best` is not a pair selection"),
            ("mode = \"all\"\nselection = \"asap\"", "key `pairs.mode`: give `selection` only"),
        ];
        for (pairs, expected) in cases {
            let e = parse(&with(pairs)).unwrap_err().to_string();
            assert!(e.contains("experiments/t.toml") && e.contains(expected), "{pairs}: {e}");
        }
        // Fewer than 3 stimuli, and matching trials, cannot use ASAP.
        let two = with("selection = \"asap\"\nbudget = 5")
            .replacen("shutter = [3, 4, 5]", "shutter = [3]", 1)
            .replacen("samples = [3, 4, 5]", "samples = [3, 4]", 1);
        let e = parse(&two).unwrap_err().to_string();
        assert!(e.contains("key `pairs.selection`: `asap` needs at least 3 stimuli; these levels give 2"), "{e}");
        let matching = with("selection = \"asap\"\nbudget = 5").replacen("task = \"2afc\"", "task = \"match\"", 1);
        let e = parse(&matching).unwrap_err().to_string();
        assert!(e.contains("key `pairs.selection`: `asap` selects pairs for 2AFC"), "{e}");
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
            ("loops = 2", "loops = 2\nready_ms = 20000", "key `presentation.ready_ms`: 20000 ms is longer than 10 s"),
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
