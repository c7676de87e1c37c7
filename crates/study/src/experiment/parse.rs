//! Reading and checking an experiment file: every key against the format, the stimuli
//! against the design's factor levels, pairs, randomisation, briefing, practice,
//! presentation and keys; every error names the file, the line and the key.

use std::collections::BTreeSet;
use std::path::Path;

use super::spec::RawDefinition;
use super::{
    Attribute, Briefing, DEFAULT_PARTICIPANT_TITLE, DisplayMode, EXPERIMENT_FORMAT, Example, ExperimentDefinition,
    ExperimentError, Keys, MAX_BUDGET, MAX_LOOPS, MAX_REPEATS, MAX_TRIALS, PairSelection, PracticeTrial, Presentation,
};
use crate::fsio::sha256_hex;
use crate::ids::MethodTag;
use crate::ids::{StimulusId, View};
use crate::response::Task;
use crate::toml_locate::{TomlError, backticked, key_line};

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
        let (selection_key, selection_text) = match (&pairs.mode, &pairs.selection) {
            (Some(_), Some(_)) => {
                return Err(bad("pairs", None, "mode", "give `selection` only (`mode` is its older name)".into()));
            }
            (Some(m), None) => ("mode", m.clone()),
            (None, Some(s)) => ("selection", s.clone()),
            (None, None) => ("selection", "all".to_owned()),
        };
        let n = stimuli.len() as u64;
        let selection = match selection_text.as_str() {
            "all" => {
                if pairs.budget.is_some() {
                    return Err(bad(
                        "pairs",
                        None,
                        "budget",
                        "a budget applies to `selection = \"asap\"` or `\"random\"`; `all` shows every pair (set `repeats`)"
                            .into(),
                    ));
                }
                let repeats = pairs.repeats.unwrap_or(1);
                if repeats == 0 {
                    return Err(bad("pairs", None, "repeats", "must be 1 or more".into()));
                }
                if repeats > MAX_REPEATS {
                    return Err(bad(
                        "pairs",
                        None,
                        "repeats",
                        format!("{repeats} is above the limit of {MAX_REPEATS}"),
                    ));
                }
                let trials = n * (n - 1) / 2 * u64::from(repeats);
                if trials > MAX_TRIALS {
                    return Err(bad(
                        "pairs",
                        None,
                        "repeats",
                        format!(
                            "{n} stimuli in {} pairs x {repeats} repeats make {trials} trials, above the limit of {MAX_TRIALS}; use `selection = \"asap\"` with a budget",
                            n * (n - 1) / 2,
                        ),
                    ));
                }
                PairSelection::All { repeats }
            }
            "asap" | "random" => {
                let asap = selection_text == "asap";
                if task != Task::TwoAfc {
                    return Err(bad(
                        "pairs",
                        None,
                        selection_key,
                        format!(
                            "`{selection_text}` selects pairs for 2AFC preference trials; this experiment's task is matching (use `all`)"
                        ),
                    ));
                }
                if asap && n < 3 {
                    return Err(bad(
                        "pairs",
                        None,
                        selection_key,
                        format!("`asap` needs at least 3 stimuli; these levels give {n} (use `all`)"),
                    ));
                }
                if pairs.repeats.is_some() {
                    return Err(bad(
                        "pairs",
                        None,
                        "repeats",
                        format!("`{selection_text}` chooses its own pairs, which may recur; give `budget` only"),
                    ));
                }
                let Some(budget) = pairs.budget else {
                    return Err(bad(
                        "pairs",
                        None,
                        "budget",
                        format!(
                            "`{selection_text}` needs a budget: the counted trials each participant judges, 1 to {MAX_BUDGET}"
                        ),
                    ));
                };
                if budget == 0 || budget > MAX_BUDGET {
                    return Err(bad(
                        "pairs",
                        None,
                        "budget",
                        format!("{budget} trials: expected 1 to {MAX_BUDGET} counted trials per participant"),
                    ));
                }
                if asap { PairSelection::Asap { budget } } else { PairSelection::Random { budget } }
            }
            other => {
                return Err(bad(
                    "pairs",
                    None,
                    selection_key,
                    format!("`{other}` is not a pair selection; expected `all`, `asap` or `random`"),
                ));
            }
        };
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
        if p.ready_ms > 10_000 {
            return Err(bad("presentation", None, "ready_ms", format!("{} ms is longer than 10 s", p.ready_ms)));
        }
        let presentation = Presentation {
            gap_ms: p.gap_ms,
            replay: p.replay,
            loops: p.loops,
            visual_angle_deg: p.visual_angle_deg,
            break_every: p.break_every,
            ready_ms: p.ready_ms,
            ready_press: p.ready_press,
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
            participant_title: raw.participant_title.unwrap_or_else(|| DEFAULT_PARTICIPANT_TITLE.to_owned()),
            title: raw.title.unwrap_or_default(),
            task,
            question: raw.question,
            view,
            stimuli,
            repeats: selection.repeats(),
            selection,
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
