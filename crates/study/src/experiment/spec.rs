//! An experiment file as written: the TOML tables and their defaults, before checking.

use serde::Deserialize;

fn default_true() -> bool {
    true
}

fn default_one() -> u32 {
    1
}

fn default_angle() -> f64 {
    14.4
}

fn default_gap() -> u32 {
    500
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDefinition {
    pub(super) format: String,
    pub(super) name: String,
    pub(super) title: Option<String>,
    pub(super) participant_title: Option<String>,
    pub(super) task: String,
    pub(super) question: String,
    pub(super) view: String,
    pub(super) stimuli: RawStimuli,
    pub(super) pairs: Option<RawPairs>,
    pub(super) randomisation: Option<RawRandomisation>,
    pub(super) briefing: Option<RawBriefing>,
    #[serde(default)]
    pub(super) practice: Vec<RawPractice>,
    pub(super) presentation: Option<RawPresentation>,
    pub(super) display: Option<RawDisplay>,
    pub(super) keys: Option<RawKeys>,
    #[serde(default)]
    pub(super) attributes: Vec<RawAttribute>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawStimuli {
    pub(super) material: Vec<u8>,
    pub(super) speed: Vec<u8>,
    pub(super) shutter: Vec<u8>,
    pub(super) samples: Vec<u8>,
    /// Method levels by tag (`tracer`, `guertin2`), for sets of a design with a method factor.
    #[serde(default)]
    pub(super) method: Vec<String>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPairs {
    /// The older spelling of `selection` (only `all`).
    pub(super) mode: Option<String>,
    pub(super) selection: Option<String>,
    pub(super) repeats: Option<u32>,
    pub(super) budget: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRandomisation {
    #[serde(default = "default_true")]
    pub(super) pair_order: bool,
    #[serde(default = "default_true")]
    pub(super) within_pair: bool,
}

impl Default for RawRandomisation {
    fn default() -> Self {
        RawRandomisation { pair_order: true, within_pair: true }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBriefing {
    #[serde(default)]
    pub(super) text: String,
    #[serde(default)]
    pub(super) examples: Vec<RawExample>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawExample {
    pub(super) label: String,
    #[serde(default)]
    pub(super) description: String,
    pub(super) stimulus: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPractice {
    pub(super) pair: [String; 2],
    pub(super) reference: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPresentation {
    #[serde(default = "default_gap")]
    pub(super) gap_ms: u32,
    #[serde(default = "default_true")]
    pub(super) replay: bool,
    #[serde(default = "default_one")]
    pub(super) loops: u32,
    #[serde(default = "default_angle")]
    pub(super) visual_angle_deg: f64,
    #[serde(default)]
    pub(super) break_every: u32,
    #[serde(default = "default_ready")]
    pub(super) ready_ms: u32,
    #[serde(default)]
    pub(super) ready_press: bool,
}

fn default_ready() -> u32 {
    800
}

impl Default for RawPresentation {
    fn default() -> Self {
        RawPresentation {
            gap_ms: default_gap(),
            replay: true,
            loops: 1,
            visual_angle_deg: default_angle(),
            break_every: 0,
            ready_ms: default_ready(),
            ready_press: false,
        }
    }
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDisplay {
    pub(super) mode: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawKeys {
    #[serde(default = "key_first")]
    pub(super) first: String,
    #[serde(default = "key_second")]
    pub(super) second: String,
    #[serde(default = "key_replay")]
    pub(super) replay: String,
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
pub(super) struct RawAttribute {
    pub(super) key: String,
    pub(super) question: String,
    pub(super) options: Vec<String>,
}
