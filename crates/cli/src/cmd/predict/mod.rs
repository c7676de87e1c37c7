//! `blurlab predict`: what people will choose in a 2AFC experiment, forecast from the
//! rendered sequences by an image-computable observer, without sampling noise.
//!
//! - `--observer cvvdp` (default): each sequence's quality in JOD from ColorVideoVDP against
//!   its reference ([`observer`]); `P(i over j) = Phi(z75 (Q_i - Q_j))`
//!   (`analysis::forecast`).
//!   `--eye-movement pursuit` judges the frames as an eye that follows the sphere sees them;
//!   `both` forecasts a population of which half fixate and half pursue: each choice
//!   probability is the mean of the two observers' (an exploration, BENCHMARKS.md).
//!   `--judging pair` judges each pair against itself: the better of the two by the shared
//!   reference is the other's reference, and the worse one's quality against it gives the
//!   probability (`analysis::forecast::preference_from_pair`; also an exploration).
//! - `--observer flip`: the FLIP observer of `--simulate flip` (distances to the gold
//!   standard, its default decision noise), as the baseline.
//!
//! The report (`predict.md`, `predict.json`, `votes.csv`, `matrix.csv`, figures) holds the
//! expected vote matrix, the expected votes, David's groups on the expected counts with a
//! stated number of judges, and with `--votes TABLE` the rank correlations and group
//! agreement with a published table.

pub mod observer;
pub mod reference;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use analysis::forecast::{
    Agreement, ExpectedVotes, agreement, preference_from_distances, preference_from_jod, preference_from_pair,
};
use analysis::plots::{ForecastScatter, SideBySideVotes, VotesFigure, save_figure};
use analysis::votes::VoteTable;
use anyhow::Context as _;
use clap::ValueEnum as _;
use runner::stimuli::StimulusSet;
use serde::Serialize;
use study::StimulusId;
use study::experiment::ExperimentDefinition;
use study::response::Task;

use self::observer::{EyeMovement, ObserverSettings, ReferenceKind};
use super::BadInput;
use super::stimuli::DeviceArg;

/// Which observer forecasts the choices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ObserverArg {
    /// ColorVideoVDP qualities in JOD.
    Cvvdp,
    /// FLIP distances to the gold standard (the baseline).
    Flip,
}

impl ObserverArg {
    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ObserverArg::Cvvdp => "cvvdp",
            ObserverArg::Flip => "flip",
        }
    }
}

/// How the forecast's observers move their eyes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EyeMovementArg {
    /// Every observer fixates.
    #[default]
    Fixation,
    /// Every observer follows the sphere.
    Pursuit,
    /// Half fixate, half follow the sphere: each choice probability is the mean of the two.
    Both,
}

impl EyeMovementArg {
    /// The eye movements of the population, in equal shares.
    fn movements(self) -> &'static [EyeMovement] {
        match self {
            EyeMovementArg::Fixation => &[EyeMovement::Fixation],
            EyeMovementArg::Pursuit => &[EyeMovement::Pursuit],
            EyeMovementArg::Both => &[EyeMovement::Fixation, EyeMovement::Pursuit],
        }
    }

    fn is_fixation(&self) -> bool {
        *self == EyeMovementArg::Fixation
    }
}

/// What sets the size of a choice probability.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum JudgingArg {
    /// The two sequences' qualities against the shared reference.
    #[default]
    Reference,
    /// The pair against itself: the worse one judged with the better one as its reference
    /// (the better one by the shared reference).
    Pair,
}

impl JudgingArg {
    fn is_reference(&self) -> bool {
        *self == JudgingArg::Reference
    }
}

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    /// The experiment definition (a 2AFC experiment, e.g. experiments/mono-2-sampling-2afc.toml).
    pub experiment: PathBuf,
    /// The rendered stimulus set holding the experiment's sequences.
    #[arg(long)]
    pub stimuli: PathBuf,
    /// The observer.
    #[arg(long, value_enum, default_value_t = ObserverArg::Cvvdp)]
    pub observer: ObserverArg,
    /// What ColorVideoVDP compares each sequence with. The default, `shutter`, is the reference
    /// the protocol chose on the mono tables and froze for the held-out stereo ones (BENCHMARKS.md,
    /// "The ColorVideoVDP observer"); `eye` and `sharp` are the references it did not choose.
    #[arg(long, value_enum, default_value_t = ReferenceKind::Shutter)]
    pub reference: ReferenceKind,
    /// Samples per pixel of each reference frame (default: twice the set's highest level).
    #[arg(long)]
    pub reference_spp: Option<u32>,
    /// Sub-frames per displayed frame of the `eye` and `sharp` references.
    #[arg(long, default_value_t = observer::DEFAULT_SUB_FRAMES)]
    pub sub_frames: u32,
    /// How the observers' eyes move: `fixation` (the metric as it is), `pursuit` (following
    /// the sphere) or `both` (half and half).
    #[arg(long, value_enum, default_value_t = EyeMovementArg::Fixation)]
    pub eye_movement: EyeMovementArg,
    /// What sets each choice probability: `reference` (the two qualities against the shared
    /// reference) or `pair` (the worse of the two judged against the better one, which the
    /// shared reference names).
    #[arg(long, value_enum, default_value_t = JudgingArg::Reference)]
    pub judging: JudgingArg,
    /// The clip judged: frames FIRST..END of the set's sequences (0-based, END excluded;
    /// default: every frame of the set's preset).
    #[arg(long, value_parser = parse_clip)]
    pub clip: Option<(u32, u32)>,
    /// A published table of vote totals (`blurlab-votes/1`) to compare with.
    #[arg(long)]
    pub votes: Option<PathBuf>,
    /// Judgements per pair of the forecast (default: the table's `judges`, else 20).
    #[arg(long)]
    pub judges: Option<u32>,
    /// Significance level of the grouping (default: the table's `alpha`, else 0.01).
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Device that renders the references.
    #[arg(long, value_enum, default_value_t = DeviceArg::Auto)]
    pub device: DeviceArg,
    /// Report folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// Parses `FIRST..END`.
fn parse_clip(text: &str) -> Result<(u32, u32), String> {
    let (a, b) = text.split_once("..").ok_or_else(|| format!("`{text}` is not FIRST..END (e.g. 0..30)"))?;
    let num = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("`{s}` in `{text}` is not a frame number"));
    let (a, b) = (num(a)?, num(b)?);
    if a >= b {
        return Err(format!("`{text}`: END must exceed FIRST"));
    }
    Ok((a, b))
}

fn bad(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::Error::new(BadInput(e.to_string()))
}

/// One stimulus of a forecast.
#[derive(Debug, Clone, Serialize)]
pub struct ForecastRow {
    /// Stimulus id.
    pub id: String,
    /// Label (the levels of the factors that vary).
    pub label: String,
    /// The sha256 of the sequence's manifest as the set's index.json records it: which
    /// rendering was judged, so that a forecast made again can be told apart from one made on
    /// other frames.
    pub manifest_sha256: String,
    /// The SHA-256 of the stamp (`reference.json`) of the rendered reference it was judged
    /// against (ColorVideoVDP): which reference frames, as the manifest hash says which
    /// sequence frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_sha256: Option<String>,
    /// ColorVideoVDP quality (JOD; mean of the eyes), or the FLIP distance.
    pub score: f64,
    /// Each eye's JOD (ColorVideoVDP; with one eye movement).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub eyes: Vec<f64>,
    /// The quality (JOD, mean of the eyes) under each eye movement of `--eye-movement both`:
    /// fixation, pursuit.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub by_eye_movement: Vec<f64>,
    /// Expected votes.
    pub votes: f64,
    /// Published votes, where a table was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub published: Option<u32>,
}

/// A forecast of one experiment.
#[derive(Debug, Clone, Serialize)]
pub struct Forecast {
    /// Format tag.
    pub format: String,
    /// Experiment name.
    pub experiment: String,
    /// The observer.
    pub observer: ObserverArg,
    /// ColorVideoVDP's settings (reference, clip, display; the first eye movement's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub settings: Option<ObserverSettings>,
    /// How the observers' eyes move.
    #[serde(skip_serializing_if = "EyeMovementArg::is_fixation")]
    pub eye_movement: EyeMovementArg,
    /// What sets each choice probability.
    #[serde(skip_serializing_if = "JudgingArg::is_reference")]
    pub judging: JudgingArg,
    /// With `--judging pair`, per eye movement: `pair_jod[m][i][j]`, the JOD between `i` and
    /// `j` judged as a pair (`10 - Q(worse against better)`; symmetric, 0 on the diagonal).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub pair_jod: Vec<Vec<Vec<f64>>>,
    /// What a score is.
    pub score: String,
    /// Per stimulus.
    pub stimuli: Vec<ForecastRow>,
    /// `P(row over column)`.
    pub probability: Vec<Vec<f64>>,
    /// Judgements per pair.
    pub judges: u32,
    /// Significance level.
    pub alpha: f64,
    /// `ceil(R_c)` of the grouping.
    pub ceil_rc: u64,
    /// David's groups of the expected votes, most preferred first.
    pub groups: Vec<Vec<String>>,
    /// The published table, where given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub published_table: Option<PathBuf>,
    /// The published groups (the table's `expected_groups`, else David's groups of its votes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub published_groups: Option<Vec<Vec<String>>>,
    /// Agreement with the table.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub agreement: Option<Agreement>,
}

/// A label's level tokens, sorted: `A4T3`, `T3-A4` and `a4 t3` give `[A4, T3]`.
fn level_tokens(label: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    for c in label.chars() {
        let after_digit = cur.chars().last().is_some_and(|p| p.is_ascii_digit());
        if c.is_ascii_alphabetic() && after_digit {
            out.push(std::mem::take(&mut cur));
        }
        if c.is_ascii_alphanumeric() {
            cur.push(c.to_ascii_uppercase());
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out.sort();
    out
}

/// The position in `labels` of a published table's label (the same factor levels).
pub(crate) fn label_index(label: &str, labels: &[String]) -> Option<usize> {
    let t = level_tokens(label);
    labels.iter().position(|l| level_tokens(l) == t)
}

/// The votes of a published table for each of the experiment's stimuli (by `labels`); every
/// stimulus must appear, and nothing else.
fn match_table(table: &VoteTable, labels: &[String]) -> anyhow::Result<Vec<u32>> {
    let mut votes = vec![None; labels.len()];
    for (label, v) in table.labels.iter().zip(&table.votes) {
        let k = label_index(label, labels).ok_or_else(|| {
            bad(format!(
                "{}: stimulus `{label}` is not one of the experiment's ({})",
                table.path.display(),
                labels.join(", ")
            ))
        })?;
        votes[k] = Some(*v);
    }
    let missing: Vec<&str> = labels.iter().zip(&votes).filter(|(_, v)| v.is_none()).map(|(l, _)| l.as_str()).collect();
    if !missing.is_empty() {
        return Err(bad(format!(
            "{}: the table has no votes for {} of the experiment's stimuli",
            table.path.display(),
            missing.join(", ")
        )));
    }
    Ok(votes.into_iter().flatten().collect())
}

/// The experiment's judged stimuli (its `[stimuli]` grid) and their labels.
fn stimuli_of(definition: &ExperimentDefinition) -> (Vec<StimulusId>, Vec<String>) {
    let mut ids: Vec<StimulusId> = definition.stimuli.clone();
    ids.sort();
    ids.dedup();
    let varying = analysis::experiment::varying_factors(&ids);
    let labels = ids.iter().map(|id| analysis::experiment::short_label(id, &varying)).collect();
    (ids, labels)
}

/// Opens the set for the stimuli `definition`'s trials show (its grid, and its practice pairs
/// where `practice`; the briefing's examples are not judged), naming any it lacks, with its
/// design and preset.
pub fn open_set(
    set_dir: &Path,
    definition: &ExperimentDefinition,
    practice: bool,
) -> anyhow::Result<(StimulusSet, study::design::Design, study::design::Preset)> {
    let mut judged = definition.clone();
    judged.briefing.examples.clear();
    if !practice {
        judged.practice.clear();
    }
    let set = StimulusSet::open_for(set_dir, &judged).map_err(|e| match e {
        e @ (runner::RunnerError::MissingStimuli { .. } | runner::RunnerError::Sequence { .. }) => bad(e),
        e => anyhow::Error::new(e),
    })?;
    let design_path = set_dir.join("design.toml");
    let design = study::design::Design::load(&design_path).map_err(|e| bad(format!("the set's design: {e}")))?;
    let preset = design.preset(&set.index.preset).map_err(|e| bad(format!("the set's preset: {e}")))?;
    Ok((set, design, preset))
}

/// Forecasts `definition` on the set in `args.stimuli`.
pub fn forecast(definition: &ExperimentDefinition, args: &Args) -> anyhow::Result<Forecast> {
    if definition.task != Task::TwoAfc {
        return Err(bad(format!(
            "{}: a {} experiment; `predict` forecasts 2AFC preference votes (matching trials are answered by `blurlab run --simulate cvvdp`)",
            definition.path.display(),
            definition.task
        )));
    }
    if args.observer == ObserverArg::Flip && args.eye_movement != EyeMovementArg::Fixation {
        let name = args.eye_movement.to_possible_value().map(|v| v.get_name().to_owned()).unwrap_or_default();
        return Err(bad(format!(
            "--eye-movement {name}: eye movements are ColorVideoVDP's (`--observer cvvdp`); FLIP judges still frames"
        )));
    }
    if args.observer == ObserverArg::Flip && args.judging != JudgingArg::Reference {
        let name = args.judging.to_possible_value().map(|v| v.get_name().to_owned()).unwrap_or_default();
        return Err(bad(format!(
            "--judging {name}: pairs are judged by ColorVideoVDP (`--observer cvvdp`); FLIP measures distances to the gold standard"
        )));
    }
    let (ids, labels) = stimuli_of(definition);
    let table = args.votes.as_deref().map(VoteTable::read).transpose().map_err(bad)?;
    let published = table.as_ref().map(|t| match_table(t, &labels)).transpose()?;
    let judges = match (args.judges, &table) {
        (Some(j), _) => j,
        (None, Some(t)) => t.judges().map_err(bad)?.unwrap_or(20),
        (None, None) => 20,
    };
    let alpha = match (args.alpha, &table) {
        (Some(a), _) => a,
        (None, Some(t)) => t.alpha().map_err(bad)?.unwrap_or(0.01),
        (None, None) => 0.01,
    };
    let (set, design, preset) = open_set(&args.stimuli, definition, false)?;
    let mut by_movement = vec![Vec::new(); ids.len()];
    // The stamp of each stimulus's rendered reference (the same under every eye movement).
    let mut references: Vec<Option<String>> = vec![None; ids.len()];
    type Scores = (Vec<f64>, Vec<Vec<f64>>, ExpectedVotes, Option<ObserverSettings>, String, Vec<Vec<Vec<f64>>>);
    let (rows_score, eyes, expected, settings, score, pair_jod): Scores = match args.observer {
        ObserverArg::Cvvdp => {
            let base = ObserverSettings::new(
                &design,
                &preset,
                args.reference,
                args.reference_spp,
                args.sub_frames,
                args.clip,
            )?;
            let movements = args.eye_movement.movements();
            // Per eye movement: each stimulus's quality.
            let mut jods: Vec<Vec<f64>> = Vec::new();
            let mut eyes = Vec::new();
            for &m in movements {
                let settings = base.clone().with_eye_movement(m);
                let q = observer::qualities(&set, &design, &preset, &ids, &settings, args.device.into())?;
                jods.push(ids.iter().map(|id| q[id].judgement.jod()).collect());
                eyes = ids.iter().map(|id| q[id].judgement.eyes.clone()).collect();
                references = ids.iter().map(|id| Some(q[id].reference_sha256.clone())).collect();
            }
            let shares = movements.len() as f64;
            let jod: Vec<f64> = (0..ids.len()).map(|i| jods.iter().map(|q| q[i]).sum::<f64>() / shares).collect();
            if movements.len() > 1 {
                eyes = vec![Vec::new(); ids.len()];
                by_movement = (0..ids.len()).map(|i| jods.iter().map(|q| q[i]).collect()).collect();
            }
            // Per eye movement: the JOD between each pair judged against itself.
            let mut pair_jods: Vec<Vec<Vec<f64>>> = Vec::new();
            if args.judging == JudgingArg::Pair {
                for (&m, q) in movements.iter().zip(&jods) {
                    let settings = base.clone().with_eye_movement(m);
                    // (better, worse) by the shared reference; a tie judges the later id
                    // against the earlier (the probability is a coin toss either way).
                    let pairs: Vec<(usize, usize)> = (0..ids.len())
                        .flat_map(|i| ((i + 1)..ids.len()).map(move |j| (i, j)))
                        .map(|(i, j)| if q[j] > q[i] { (j, i) } else { (i, j) })
                        .collect();
                    let by_id: Vec<(StimulusId, StimulusId)> = pairs.iter().map(|&(b, w)| (ids[b], ids[w])).collect();
                    let judged = observer::pair_qualities(&set, &design, &preset, &by_id, &settings)?;
                    let mut d = vec![vec![0.0; ids.len()]; ids.len()];
                    for (&(b, w), key) in pairs.iter().zip(&by_id) {
                        let jod = 10.0 - judged[key].jod().min(10.0);
                        (d[b][w], d[w][b]) = (jod, jod);
                    }
                    pair_jods.push(d);
                }
            }
            let expected = ExpectedVotes::new(labels.clone(), judges, |i, j| {
                let p = |(k, q): (usize, &Vec<f64>)| match pair_jods.get(k) {
                    Some(d) => preference_from_pair(q[i], q[j], 10.0 - d[i][j]),
                    None => preference_from_jod(q[i], q[j]),
                };
                jods.iter().enumerate().map(p).sum::<f64>() / shares
            });
            let what = format!(
                "ColorVideoVDP quality (JOD, 10 = no visible difference) against the `{}` reference{}{}",
                base.reference.name(),
                if args.judging == JudgingArg::Pair {
                    " (it names the better of each pair; the pair judged against itself sets the probability)"
                } else {
                    ""
                },
                match args.eye_movement {
                    EyeMovementArg::Fixation => "",
                    EyeMovementArg::Pursuit => ", seen by an eye that follows the sphere",
                    EyeMovementArg::Both => ", the mean of a fixating and a pursuing eye's",
                }
            );
            (jod, eyes, expected, Some(base.with_eye_movement(movements[0])), what, pair_jods)
        }
        ObserverArg::Flip => {
            // The counted trials only: practice pairs need not be in the set.
            let mut counted = definition.clone();
            counted.practice.clear();
            let schedule = runner::schedule::build(&counted, 0);
            let d = runner::flip_observer::distances(&set, &schedule)?;
            let dist: Vec<f64> =
                ids.iter().map(|id| d.iter().find(|((_, to), _)| to == id).map_or(0.0, |(_, v)| *v)).collect();
            let sigma = runner::flip_observer::DEFAULT_SIGMA;
            let expected =
                ExpectedVotes::new(labels.clone(), judges, |i, j| preference_from_distances(dist[i], dist[j], sigma));
            let what = format!(
                "mean FLIP distance to the gold standard (the same shutter at the set's highest sampling level); decision noise {sigma} per distance"
            );
            (dist, vec![Vec::new(); ids.len()], expected, None, what, Vec::new())
        }
    };
    let (critical, groups) = expected.groups(alpha).map_err(bad)?;
    let (published_groups, agreement) = match (&table, &published) {
        (Some(t), Some(p)) => {
            let pg = match t.expected_groups() {
                Some(g) => g,
                None => analysis::votes::analyze_votes(t, judges, alpha).map_err(bad)?.groups,
            };
            // The table's labels are its own spelling: map them to ours.
            let pg = pg
                .into_iter()
                .map(|members| {
                    members
                        .iter()
                        .map(|m| {
                            label_index(m, &labels).map(|k| labels[k].clone()).ok_or_else(|| {
                                bad(format!("{}: group member `{m}` is not one of the stimuli", t.path.display()))
                            })
                        })
                        .collect::<anyhow::Result<Vec<String>>>()
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let pv: Vec<f64> = p.iter().map(|&v| f64::from(v)).collect();
            let a = agreement(&labels, &expected.votes, &groups, &pv, &pg);
            (Some(pg), Some(a))
        }
        _ => (None, None),
    };
    let stimuli = ids
        .iter()
        .enumerate()
        .map(|(i, id)| ForecastRow {
            id: id.to_string(),
            label: labels[i].clone(),
            manifest_sha256: set.index.manifest_sha256(*id).unwrap_or_default().to_owned(),
            reference_sha256: references[i].clone(),
            score: rows_score[i],
            eyes: eyes[i].clone(),
            by_eye_movement: by_movement[i].clone(),
            votes: expected.votes[i],
            published: published.as_ref().map(|p| p[i]),
        })
        .collect();
    Ok(Forecast {
        format: "blurlab-predict/1".into(),
        experiment: definition.name.clone(),
        observer: args.observer,
        settings,
        eye_movement: if args.observer == ObserverArg::Cvvdp { args.eye_movement } else { EyeMovementArg::Fixation },
        judging: args.judging,
        pair_jod,
        score,
        stimuli,
        probability: expected.probability,
        judges,
        alpha,
        ceil_rc: critical.ceil_rc,
        groups,
        published_table: args.votes.clone(),
        published_groups,
        agreement,
    })
}

/// The Markdown report of a forecast.
pub fn markdown(f: &Forecast, command: &str) -> String {
    let mut md = format!("# Forecast: {}\n\nCommand: `{command}`\n\n", f.experiment);
    md.push_str(&format!("Observer: `{}`. Score: {}.\n", f.observer.name(), f.score));
    if let Some(s) = &f.settings {
        md.push_str(&format!(
            "\n- reference: `{}` at {} samples per pixel{}\n- clip: frames {}..{} of the set's sequences at {} fps\n- display: {:.2} pixels per degree, peak {} cd/m², black {} cd/m², ambient {} lux\n- metric: {}\n- stereo: each eye judged apart, the quality is the mean of the two eyes' JOD\n",
            s.reference.name(),
            s.reference_spp,
            if s.reference.has_sub_frames() { format!(", {} sub-frames per frame", s.sub_frames) } else { String::new() },
            s.clip.0,
            s.clip.1,
            s.fps,
            s.pixels_per_degree,
            s.peak_luminance,
            s.black_level,
            s.ambient_lux,
            s.metric
        ));
        match f.eye_movement {
            EyeMovementArg::Fixation => {}
            EyeMovementArg::Pursuit => md.push_str(
                "- eyes: following the sphere (smooth pursuit): each sub-frame of test and reference resampled around the sphere's centre at its middle instant\n",
            ),
            EyeMovementArg::Both => md.push_str(
                "- eyes: half the observers fixate, half follow the sphere; P(i over j) is the mean of the two, the score the mean of their JOD\n",
            ),
        }
    }
    md.push_str(&format!(
        "\nChoice model: P(i over j) = {}. Expected votes: {} judgements of each pair; David's groups at alpha = {} (ceil(R_c) = {}).\n\n",
        match (f.observer, f.judging) {
            (ObserverArg::Cvvdp, JudgingArg::Reference) =>
                "Phi(z75 (Q_i - Q_j)), z75 = Phi^-1(0.75): 1 JOD = 75 % preference, no fitted slope",
            (ObserverArg::Cvvdp, JudgingArg::Pair) =>
                "Phi(z75 (10 - Q_pair)) if Q_i > Q_j, its complement if Q_i < Q_j, 1/2 on a tie, where Q_pair is the worse of the two judged with the better one as its reference (the pair's JOD below), z75 = Phi^-1(0.75), no fitted slope",
            (ObserverArg::Flip, _) => "Phi((d_j - d_i) / (sigma sqrt 2)): the FLIP observer's noisy decision",
        },
        f.judges,
        f.alpha,
        f.ceil_rc
    ));
    md.push_str("| stimulus | id | score | expected votes | published votes |\n| --- | --- | ---: | ---: | ---: |\n");
    let mut order: Vec<&ForecastRow> = f.stimuli.iter().collect();
    order.sort_by(|a, b| b.votes.total_cmp(&a.votes));
    for r in order {
        let eyes = if r.by_eye_movement.len() > 1 {
            format!(
                " (fixation {:.3}, pursuit {:.3})",
                r.by_eye_movement[0],
                r.by_eye_movement[r.by_eye_movement.len() - 1]
            )
        } else if r.eyes.len() > 1 {
            format!(" ({})", r.eyes.iter().map(|e| format!("{e:.3}")).collect::<Vec<_>>().join(" / "))
        } else {
            String::new()
        };
        md.push_str(&format!(
            "| {} | {} | {:.4}{eyes} | {:.2} | {} |\n",
            r.label,
            r.id,
            r.score,
            r.votes,
            r.published.map_or("-".into(), |p| p.to_string())
        ));
    }
    for (k, d) in f.pair_jod.iter().enumerate() {
        let movement = match (f.eye_movement, k) {
            (EyeMovementArg::Both, 0) => " (fixating eye)",
            (EyeMovementArg::Both, _) => " (pursuing eye)",
            _ => "",
        };
        md.push_str(&format!(
            "\nJOD between the two sequences of each pair, judged against each other{movement}:\n\n|   |"
        ));
        let labels: Vec<&str> = f.stimuli.iter().map(|r| r.label.as_str()).collect();
        md.push_str(&labels.iter().map(|l| format!(" {l} |")).collect::<String>());
        md.push_str(&format!("\n| --- |{}\n", " ---: |".repeat(labels.len())));
        for (l, row) in labels.iter().zip(d) {
            md.push_str(&format!("| {l} |{}\n", row.iter().map(|v| format!(" {v:.3} |")).collect::<String>()));
        }
    }
    let fmt_groups =
        |g: &[Vec<String>]| g.iter().map(|m| format!("{{{}}}", m.join(", "))).collect::<Vec<_>>().join(" ");
    md.push_str(&format!("\nForecast groups: {}\n", fmt_groups(&f.groups)));
    if let (Some(pg), Some(a)) = (&f.published_groups, &f.agreement) {
        md.push_str(&format!(
            "\nPublished groups: {}\n\nAgreement with `{}`: Spearman {:.3}, Kendall tau-b {:.3}, adjusted Rand index of the groups {:.3}{}.\n",
            fmt_groups(pg),
            f.published_table.as_ref().map_or(String::new(), |p| p.display().to_string()),
            a.spearman,
            a.kendall,
            a.adjusted_rand,
            if a.same_groups { " (the same groups)" } else { "" }
        ));
    }
    md
}

/// Writes the report folder.
pub fn write(f: &Forecast, out: &Path, command: &str) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    let mut written = Vec::new();
    let mut put = |name: &str, bytes: &[u8]| -> anyhow::Result<()> {
        let p = out.join(name);
        study::fsio::write_atomic(&p, bytes).with_context(|| format!("{}: cannot write", p.display()))?;
        written.push(p);
        Ok(())
    };
    put("predict.json", &serde_json::to_vec_pretty(f)?)?;
    put("predict.md", markdown(f, command).as_bytes())?;
    let mut votes = String::from("stimulus,id,score,expected_votes,published_votes\n");
    for r in &f.stimuli {
        votes.push_str(&format!(
            "{},{},{},{},{}\n",
            r.label,
            r.id,
            r.score,
            r.votes,
            r.published.map_or(String::new(), |p| p.to_string())
        ));
    }
    put("votes.csv", votes.as_bytes())?;
    let labels: Vec<String> = f.stimuli.iter().map(|r| r.label.clone()).collect();
    let mut matrix = format!("row_over_column,{}\n", labels.join(","));
    for (l, row) in labels.iter().zip(&f.probability) {
        matrix.push_str(&format!("{l},{}\n", row.iter().map(f64::to_string).collect::<Vec<_>>().join(",")));
    }
    put("matrix.csv", matrix.as_bytes())?;
    let index = |g: &[Vec<String>]| -> Vec<Vec<usize>> {
        g.iter().map(|m| m.iter().filter_map(|x| labels.iter().position(|l| l == x)).collect()).collect()
    };
    let forecast_figure = VotesFigure {
        title: format!("forecast ({}, rounded)", f.observer.name()),
        labels: labels.clone(),
        votes: f.stimuli.iter().map(|r| r.votes.round().max(0.0) as u32).collect(),
        groups: index(&f.groups),
        ceil_rc: Some(f.ceil_rc),
    };
    let mut figures = Vec::new();
    match (&f.published_groups, &f.agreement) {
        (Some(pg), Some(a)) => {
            let published = VotesFigure {
                title: "published".into(),
                labels: labels.clone(),
                votes: f.stimuli.iter().map(|r| r.published.unwrap_or(0)).collect(),
                groups: index(pg),
                ceil_rc: None,
            };
            figures.extend(save_figure(&SideBySideVotes { left: forecast_figure, right: published }, out, "groups")?);
            let scatter = ForecastScatter {
                title: format!(
                    "{}: Spearman {:.2}, Kendall {:.2}, ARI {:.2}",
                    f.experiment, a.spearman, a.kendall, a.adjusted_rand
                ),
                labels: labels.clone(),
                predicted: f.stimuli.iter().map(|r| r.votes).collect(),
                published: f.stimuli.iter().map(|r| f64::from(r.published.unwrap_or(0))).collect(),
            };
            figures.extend(save_figure(&scatter, out, "predicted-vs-published")?);
        }
        _ => figures.extend(save_figure(&forecast_figure, out, "groups")?),
    }
    written.extend(figures);
    Ok(written)
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let definition = ExperimentDefinition::read(&args.experiment).map_err(bad)?;
    let f = forecast(&definition, args)?;
    let command: String = std::env::args().collect::<Vec<_>>().join(" ");
    let written = write(&f, &args.out, &command)?;
    print!("{}", markdown(&f, &command));
    eprintln!("wrote {}", written.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "));
    eprintln!(
        "predicted in {:.1} s, peak memory {}",
        started.elapsed().as_secs_f64(),
        runner::bench::memory_kib()
            .map_or("unknown".into(), |(_, peak)| format!("{:.0} MB", peak as f64 * 1024.0 / 1e6))
    );
    Ok(())
}

/// The per-stimulus qualities a forecast is made of, for other commands (`run --simulate
/// cvvdp`, `demo`).
pub fn qualities_for(
    definition: &ExperimentDefinition,
    set_dir: &Path,
    reference: ReferenceKind,
    clip: Option<(u32, u32)>,
    device: render::DeviceChoice,
) -> anyhow::Result<(BTreeMap<StimulusId, f64>, ObserverSettings)> {
    let (set, design, preset) = open_set(set_dir, definition, true)?;
    let settings = ObserverSettings::new(&design, &preset, reference, None, observer::DEFAULT_SUB_FRAMES, clip)?;
    let mut judged = definition.clone();
    judged.briefing.examples.clear();
    let ids: Vec<StimulusId> = judged.all_stimuli().into_iter().collect();
    let q = observer::qualities(&set, &design, &preset, &ids, &settings, device)?;
    Ok((q.into_iter().map(|(id, q)| (id, q.judgement.jod())).collect(), settings))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_labels_match_whatever_their_spelling() {
        let ours: Vec<String> = ["T3-A3", "T3-A4", "T4-A3"].iter().map(|s| s.to_string()).collect();
        assert_eq!(label_index("A4T3", &ours), Some(1));
        assert_eq!(label_index("a3 t4", &ours), Some(2));
        assert_eq!(label_index("A5T3", &ours), None);
        assert_eq!(level_tokens("A10T3"), ["A10", "T3"]);
        assert_eq!(parse_clip("45..75"), Ok((45, 75)));
        assert!(parse_clip("5..5").is_err() && parse_clip("x..3").is_err() && parse_clip("3").is_err());
    }
}
