//! The analysis of one experiment's checked logs ([`crate::logs`]): every statistic of the
//! study in one serialisable report.
//!
//! **Judges.** A judge is one pass over the pairs: the k-th time a session shows a pair
//! belongs to the session's k-th replicate. So a participant who repeats a test (a second
//! session, or pairs repeated within a session) counts as several judges, as the thesis
//! counts them (5.6.3: 10 users judging every pair twice are n = 20; 6.5: 16 users doing two
//! full tests are n = 32). Circular triads, zeta, agreement `u` and the grouping use the
//! judges who judged every pair (complete judges); the Thurstone scale uses every trial.
//! With [`JudgeUnit::Participant`] the per-judge score table and the bootstrap pool each
//! participant's sessions instead; triads stay per replicate (they need single judgments).
//!
//! **Incomplete designs** (participants judging only some pairs; the rule is in
//! [`crate::incomplete`]): Kendall's statistics and David's grouping are not computed; the
//! scale's bootstrap resamples participants and the groups come from the scale
//! ([`crate::incomplete::scale_and_group`]). One warning says so, not one per pass.
//!
//! **Screening** ([`crate::screening`]) scores every participant against the scale fitted
//! without them, in complete and incomplete designs; [`analyze_experiment_screened`] can
//! leave the flagged participants' sessions out before the analysis.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;
use study::response::Task;
use study::{Factor, StimulusId};

use crate::factors::{LevelPreference, factor_preferences};
use crate::grouping::{CriticalRange, critical_range, memberships, significance_groups};
use crate::incomplete::{Design, ScaleGrouping, classify_design, scale_and_group};
use crate::logs::{ExperimentData, Session};
use crate::paired::{
    Agreement, PreferenceMatrix, TriadTest, agreement, circular_triads, consistency_zeta, triads_chi_square,
};
use crate::scaling::{Scale, ScaleOptions, scale_with_bootstrap};
use crate::screening::{Screening, screen_observers};

/// What a judge is in the per-judge tables and the bootstrap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum JudgeUnit {
    /// Every pass over the pairs (session x replicate) is a separate judge (the thesis).
    #[default]
    Replicate,
    /// A participant's sessions and replicates are pooled into one judge.
    Participant,
}

/// Options of the analysis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AnalysisOptions {
    /// Significance level of the grouping.
    pub alpha: f64,
    /// Judge definition for per-judge scores and the bootstrap.
    pub judge_unit: JudgeUnit,
    /// Scaling options (prior, bootstrap resamples, seed).
    pub scale: ScaleOptions,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        Self { alpha: 0.01, judge_unit: JudgeUnit::Replicate, scale: ScaleOptions::default() }
    }
}

/// Render cost of one stimulus, from the set's manifest.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Cost {
    /// Wall-clock seconds over all frames.
    pub wall_seconds: f64,
    /// CPU seconds over all frames.
    pub cpu_seconds: f64,
}

/// One judge (replicate) of a 2AFC experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JudgeSummary {
    /// `PARTICIPANT/session-S#replicate` (or the participant when pooled).
    pub name: String,
    /// Participant code.
    pub participant: String,
    /// Judged every pair exactly once.
    pub complete: bool,
    /// Judgments made.
    pub judgments: u32,
    /// Scores per stimulus.
    pub scores: Vec<u32>,
    /// Circular triads (complete replicates only).
    pub circular_triads: Option<u64>,
    /// Coefficient of consistency (complete replicates, t >= 3).
    pub zeta: Option<f64>,
    /// Chi-square test of the triads (t >= 5).
    pub triad_test: Option<TriadTest>,
}

/// A member of a group with its cost.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GroupMember {
    /// Label.
    pub label: String,
    /// Stimulus id.
    pub id: StimulusId,
    /// Score: votes of the complete judges, or wins over all trials in an incomplete design.
    pub votes: u32,
    /// Scale value (JOD), when the groups come from the scale (incomplete designs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<f64>,
    /// Render cost, when the manifest has it.
    pub cost: Option<Cost>,
}

/// A significance group with its cheapest member.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Group {
    /// 1-based number, most voted first.
    pub number: usize,
    /// Members by decreasing score.
    pub members: Vec<GroupMember>,
    /// The member with the lowest wall-clock render cost.
    pub cheapest: Option<String>,
    /// `1 - cost(cheapest) / cost(most expensive member of the top group)`.
    pub saving_vs_top_most_expensive: Option<f64>,
}

/// Cost-aware equivalence summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recommendation {
    /// The most expensive member of the top group (typically the gold standard).
    pub reference: String,
    /// Its wall-clock cost.
    pub reference_wall_seconds: f64,
    /// The cheapest member of the top group: perceptually equivalent to the reference.
    pub cheapest: String,
    /// Its wall-clock cost.
    pub cheapest_wall_seconds: f64,
    /// Fraction of the reference's cost saved.
    pub saving: f64,
}

/// The paired-comparison (2AFC) analysis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairedReport {
    /// Judge definition used.
    pub judge_unit: JudgeUnit,
    /// How judges are counted, in words (for the report).
    pub judges_statement: String,
    /// Judges (replicates, or participants when pooled).
    pub judges: Vec<JudgeSummary>,
    /// Number of complete replicates `m` (used by u, triads and the grouping).
    pub complete_judges: u32,
    /// Preference matrix over every counted trial.
    pub matrix_all: PreferenceMatrix,
    /// Preference matrix of the complete judges.
    pub matrix: PreferenceMatrix,
    /// Scores of the complete judges (the grouping's votes).
    pub votes: Vec<u32>,
    /// Mean zeta over complete replicates.
    pub mean_zeta: Option<f64>,
    /// Coefficient of agreement, or why it is unavailable.
    pub agreement: Result<Agreement, String>,
    /// `W`, `R_c`, `ceil(R_c)`.
    pub critical: Option<CriticalRange>,
    /// Groups with costs.
    pub groups: Vec<Group>,
    /// The groups each stimulus belongs to (0-based group indices).
    pub memberships: Vec<Vec<usize>>,
    /// Thurstone Case V scale with bootstrap intervals.
    pub scale: Scale,
    /// Cheapest equivalent of the top group's most expensive member.
    pub recommendation: Option<Recommendation>,
    /// Preference per factor level pair: segment name (`all`, `key=value`) to preferences.
    pub factor_preferences: BTreeMap<String, Vec<LevelPreference>>,
    /// Whether Kendall's statistics and David's grouping apply ([`crate::incomplete`]).
    pub design: Design,
    /// Incomplete designs: how the groups were found from the scale (or why they were not).
    pub scale_grouping: Option<Result<ScaleGrouping, String>>,
    /// Observer screening over every participant of the logs (before any exclusion).
    pub screening: Screening,
    /// Participants whose sessions were left out (`--exclude-outliers`).
    pub excluded_participants: Vec<String>,
}

impl PairedReport {
    /// Times each pair was shown over every counted trial (symmetric, zero diagonal).
    pub fn pair_counts(&self) -> Vec<Vec<u32>> {
        let t = self.matrix_all.t();
        (0..t).map(|i| (0..t).map(|j| if i == j { 0 } else { self.matrix_all.judged(i, j) }).collect()).collect()
    }
}

/// The matching analysis: accuracy per pair of candidate levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MatchingReport {
    /// Trials per unordered pair of candidates (symmetric; diagonal for identical candidates).
    pub total: Vec<Vec<u32>>,
    /// Correct answers per pair.
    pub correct: Vec<Vec<u32>>,
    /// Accuracy per pair (None where no trial).
    pub accuracy: Vec<Vec<Option<f64>>>,
    /// Overall accuracy.
    pub overall: f64,
    /// Trials.
    pub trials: u32,
    /// Overall accuracy per segment (`key=value`).
    pub segments: BTreeMap<String, f64>,
}

/// The analysis of one experiment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExperimentReport {
    /// Experiment name.
    pub name: String,
    /// Task.
    pub task: Task,
    /// View.
    pub view: study::View,
    /// Stimulus ids, sorted.
    pub stimuli: Vec<StimulusId>,
    /// Short labels (the factors that vary, e.g. `T3-A4`).
    pub labels: Vec<String>,
    /// Factors that vary across the stimuli.
    pub varying: Vec<Factor>,
    /// Sessions analysed (read, less those `--exclude-outliers` left out).
    pub sessions: Vec<Session>,
    /// Definition file used, if found.
    pub definition: Option<String>,
    /// Logs' recorded hashes.
    pub experiment_sha256: String,
    /// Stimulus set hash recorded in the logs.
    pub stimulus_set_sha256: String,
    /// Options used.
    pub options: AnalysisOptions,
    /// 2AFC analysis.
    pub paired: Option<PairedReport>,
    /// Matching analysis.
    pub matching: Option<MatchingReport>,
    /// Warnings from reading and analysing.
    pub warnings: Vec<String>,
}

/// The factors whose level differs among `stimuli`.
pub fn varying_factors(stimuli: &[StimulusId]) -> Vec<Factor> {
    Factor::WITH_METHOD
        .into_iter()
        .filter(|&f| stimuli.iter().map(|s| s.level(f)).collect::<BTreeSet<_>>().len() > 1)
        .collect()
}

/// A short label naming the varying factors' levels (`T3-A4`), or the id if none vary.
pub fn short_label(id: &StimulusId, varying: &[Factor]) -> String {
    if varying.is_empty() {
        return id.to_string();
    }
    varying.iter().map(|&f| id.level_label(f)).collect::<Vec<_>>().join("-")
}

/// Segments of the sessions: `key=value` for every attribute, with the session indices.
fn segments(sessions: &[Session]) -> BTreeMap<String, Vec<usize>> {
    let mut out: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (i, s) in sessions.iter().enumerate() {
        for (k, v) in &s.attributes {
            out.entry(format!("{k}={v}")).or_default().push(i);
        }
    }
    out
}

/// Analyses one experiment. `costs` maps stimuli to their render cost (from the manifest).
pub fn analyze_experiment(
    data: &ExperimentData,
    costs: &BTreeMap<StimulusId, Cost>,
    options: AnalysisOptions,
) -> ExperimentReport {
    analyze_experiment_screened(data, costs, options, false)
}

/// Each participant's trials as one matrix, by participant code.
pub fn participant_matrices(data: &ExperimentData) -> Vec<(String, PreferenceMatrix)> {
    let t = data.stimuli.len();
    let index: BTreeMap<StimulusId, usize> = data.stimuli.iter().enumerate().map(|(i, s)| (*s, i)).collect();
    let mut by: BTreeMap<String, PreferenceMatrix> = BTreeMap::new();
    for trial in &data.trials {
        let (Some(&a), Some(&b), Some(&w)) =
            (index.get(&trial.shown[0]), index.get(&trial.shown[1]), index.get(&trial.choice))
        else {
            continue;
        };
        let participant = &data.sessions[trial.session].participant;
        by.entry(participant.clone()).or_insert_with(|| PreferenceMatrix::new(t)).add(w, if w == a { b } else { a });
    }
    by.into_iter().collect()
}

/// `data` without the sessions of `participants` (trials renumbered to the kept sessions).
pub fn without_participants(data: &ExperimentData, participants: &[String]) -> ExperimentData {
    let mut new_index = vec![None; data.sessions.len()];
    let mut sessions = Vec::new();
    for (k, s) in data.sessions.iter().enumerate() {
        if !participants.contains(&s.participant) {
            new_index[k] = Some(sessions.len());
            sessions.push(s.clone());
        }
    }
    let trials = data
        .trials
        .iter()
        .filter_map(|tr| new_index[tr.session].map(|session| crate::logs::Trial { session, ..tr.clone() }))
        .collect();
    ExperimentData { sessions, trials, ..data.clone() }
}

/// [`analyze_experiment`] with observer screening: when `exclude_outliers`, the sessions of
/// the participants screening flags ([`crate::screening`], over every participant) are left
/// out before the analysis and named in the report and its warnings.
pub fn analyze_experiment_screened(
    data: &ExperimentData,
    costs: &BTreeMap<StimulusId, Cost>,
    options: AnalysisOptions,
    exclude_outliers: bool,
) -> ExperimentReport {
    let varying = varying_factors(&data.stimuli);
    let labels: Vec<String> = data.stimuli.iter().map(|s| short_label(s, &varying)).collect();
    let mut warnings = data.warnings.clone();
    let mut sessions = data.sessions.clone();
    let (paired, matching) = match data.task {
        Task::TwoAfc => {
            let screening = screen_observers(&participant_matrices(data), options.scale.prior_sd);
            let excluded = if exclude_outliers { screening.flagged.clone() } else { Vec::new() };
            let kept;
            let analysed = if excluded.is_empty() {
                data
            } else {
                warnings.push(format!(
                    "--exclude-outliers: left out the sessions of {} flagged participant(s): {}",
                    excluded.len(),
                    excluded.join(", ")
                ));
                kept = without_participants(data, &excluded);
                sessions = kept.sessions.clone();
                &kept
            };
            let mut p = analyze_paired(analysed, &labels, &varying, costs, options, &mut warnings, screening);
            p.excluded_participants = excluded;
            (Some(p), None)
        }
        Task::Match => (None, Some(analyze_matching(data))),
    };
    ExperimentReport {
        name: data.name.clone(),
        task: data.task,
        view: data.view,
        stimuli: data.stimuli.clone(),
        labels,
        varying,
        sessions,
        definition: data.definition.as_ref().map(|p| p.display().to_string()),
        experiment_sha256: data.experiment_sha256.clone(),
        stimulus_set_sha256: data.stimulus_set_sha256.clone(),
        options,
        paired,
        matching,
        warnings,
    }
}

fn analyze_paired(
    data: &ExperimentData,
    labels: &[String],
    varying: &[Factor],
    costs: &BTreeMap<StimulusId, Cost>,
    options: AnalysisOptions,
    warnings: &mut Vec<String>,
    screening: Screening,
) -> PairedReport {
    let t = data.stimuli.len();
    let index: BTreeMap<StimulusId, usize> = data.stimuli.iter().enumerate().map(|(i, s)| (*s, i)).collect();
    // Replicates: (session, k) -> matrix.
    let mut replicates: BTreeMap<(usize, u32), PreferenceMatrix> = BTreeMap::new();
    let mut occurrences: BTreeMap<(usize, usize, usize), u32> = BTreeMap::new();
    let mut all = PreferenceMatrix::new(t);
    for trial in &data.trials {
        let (a, b) = (index[&trial.shown[0]], index[&trial.shown[1]]);
        let winner = index[&trial.choice];
        let loser = if winner == a { b } else { a };
        let key = (trial.session, a.min(b), a.max(b));
        let k = occurrences.entry(key).or_insert(0);
        *k += 1;
        replicates.entry((trial.session, *k)).or_insert_with(|| PreferenceMatrix::new(t)).add(winner, loser);
        all.add(winner, loser);
    }
    let pairs = (t * (t - 1) / 2) as u32;
    let is_complete_pass = |m: &PreferenceMatrix| (0..t).all(|i| (i + 1..t).all(|j| m.judged(i, j) == 1));
    let (complete_passes, complete_trials) = replicates
        .values()
        .filter(|m| is_complete_pass(m))
        .fold((0u32, 0u64), |(n, trials), m| (n + 1, trials + u64::from(m.total())));
    let design = classify_design(complete_passes, replicates.len(), complete_trials, u64::from(all.total()));
    let incomplete = design.is_incomplete();
    let mut judges = Vec::new();
    let mut complete_matrix = PreferenceMatrix::new(t);
    let mut complete = 0u32;
    let mut zetas = Vec::new();
    for ((session, k), m) in &replicates {
        let s = &data.sessions[*session];
        let is_complete = is_complete_pass(m);
        let (triads, zeta, test) = if is_complete && !incomplete {
            complete += 1;
            complete_matrix.add_matrix(m);
            let d = circular_triads(m).ok();
            let zeta = d.and_then(|d| consistency_zeta(d, t));
            zetas.extend(zeta);
            (d, zeta, d.and_then(|d| triads_chi_square(d, t)))
        } else {
            (None, None, None)
        };
        judges.push(JudgeSummary {
            name: format!("{}/session-{}#{k}", s.participant, s.session),
            participant: s.participant.clone(),
            complete: is_complete,
            judgments: m.total(),
            scores: m.scores(),
            circular_triads: triads,
            zeta,
            triad_test: test,
        });
        if !is_complete && !incomplete {
            warnings.push(format!(
                "{} replicate {k}: judged {} of {pairs} pairs; left out of triads, agreement and grouping",
                s.path.display(),
                m.total()
            ));
        }
    }
    // Bootstrap units.
    let units: Vec<PreferenceMatrix> = match options.judge_unit {
        JudgeUnit::Replicate => replicates.values().cloned().collect(),
        JudgeUnit::Participant => {
            let mut by: BTreeMap<String, PreferenceMatrix> = BTreeMap::new();
            for ((session, _), m) in &replicates {
                by.entry(data.sessions[*session].participant.clone())
                    .or_insert_with(|| PreferenceMatrix::new(t))
                    .add_matrix(m);
            }
            judges = by
                .iter()
                .map(|(p, m)| JudgeSummary {
                    name: p.clone(),
                    participant: p.clone(),
                    complete: (0..t).all(|i| (i + 1..t).all(|j| m.judged(i, j) >= 1)),
                    judgments: m.total(),
                    scores: m.scores(),
                    circular_triads: None,
                    zeta: None,
                    triad_test: None,
                })
                .collect();
            by.into_values().collect()
        }
    };
    let judges_statement = if incomplete {
        format!(
            "Incomplete design: participants are the units ({} participants, {} passes over the pairs, {complete_passes} of them complete); the scale's bootstrap resamples participants.",
            participant_matrices(data).len(),
            replicates.len()
        )
    } else {
        match options.judge_unit {
            JudgeUnit::Replicate => format!(
                "Each pass over the pairs is a judge: a participant's repeated sessions, and pairs repeated within a session, count as separate judges (as in the thesis). {complete} complete judges of {} passes; m = {complete}.",
                replicates.len()
            ),
            JudgeUnit::Participant => format!(
                "Judges pooled per participant ({} participants) for the per-judge table and the bootstrap; triads, agreement and grouping still use the {complete} complete passes (m = {complete}).",
                units.len()
            ),
        }
    };
    let mean_zeta = (!zetas.is_empty()).then(|| zetas.iter().sum::<f64>() / zetas.len() as f64);
    let agreement = if let Design::Incomplete { reason } = &design {
        Err(format!("incomplete design: {reason}"))
    } else if complete >= 2 {
        agreement(&complete_matrix).map_err(|e| e.to_string())
    } else {
        Err(format!("{complete} complete judges; agreement needs at least 2"))
    };
    let critical =
        if complete >= 1 && t >= 2 && !incomplete { critical_range(t, complete, options.alpha).ok() } else { None };
    // Incomplete designs: the scale with participant resamples, and groups from it.
    let (scale, scale_grouping) = if incomplete {
        let participants: Vec<PreferenceMatrix> = participant_matrices(data).into_iter().map(|(_, m)| m).collect();
        let (scale, grouping) = scale_and_group(&all, &participants, options.scale, options.alpha);
        if let Design::Incomplete { reason } = &design {
            warnings.push(format!(
                "incomplete design ({reason}): {} passes judged only some pairs; Kendall's statistics and David's grouping are not reported, the Thurstone scale (bootstrap over {} participants) groups the stimuli instead",
                replicates.len() as u32 - complete_passes,
                participants.len()
            ));
        }
        (scale, Some(grouping.map_err(|e| e.to_string())))
    } else {
        (scale_with_bootstrap(&all, &units, options.scale), None)
    };
    let votes = complete_matrix.scores();
    let member_votes = if incomplete { all.scores() } else { votes.clone() };
    let index_groups = match &scale_grouping {
        Some(Ok(g)) => g.groups.clone(),
        Some(Err(_)) => Vec::new(),
        None => critical
            .map(|c| significance_groups(&votes.iter().map(|&v| f64::from(v)).collect::<Vec<_>>(), c.ceil_rc as f64))
            .unwrap_or_default(),
    };
    let member_of = memberships(t, &index_groups);
    let cost_of = |i: usize| costs.get(&data.stimuli[i]).copied();
    let top_reference = index_groups.first().and_then(|g| {
        g.iter().filter_map(|&i| cost_of(i).map(|c| (i, c.wall_seconds))).max_by(|a, b| a.1.total_cmp(&b.1))
    });
    let groups: Vec<Group> = index_groups
        .iter()
        .enumerate()
        .map(|(n, g)| {
            let cheapest =
                g.iter().filter_map(|&i| cost_of(i).map(|c| (i, c.wall_seconds))).min_by(|a, b| a.1.total_cmp(&b.1));
            Group {
                number: n + 1,
                members: g
                    .iter()
                    .map(|&i| GroupMember {
                        label: labels[i].clone(),
                        id: data.stimuli[i],
                        votes: member_votes[i],
                        scale: incomplete.then(|| scale.scores[i]),
                        cost: cost_of(i),
                    })
                    .collect(),
                cheapest: cheapest.map(|(i, _)| labels[i].clone()),
                saving_vs_top_most_expensive: match (cheapest, top_reference) {
                    (Some((_, c)), Some((_, r))) if r > 0.0 => Some(1.0 - c / r),
                    _ => None,
                },
            }
        })
        .collect();
    let recommendation = match (groups.first(), top_reference) {
        (Some(top), Some((r, rc))) => top.cheapest.as_ref().and_then(|name| {
            let i = labels.iter().position(|l| l == name)?;
            let c = cost_of(i)?.wall_seconds;
            Some(Recommendation {
                reference: labels[r].clone(),
                reference_wall_seconds: rc,
                cheapest: name.clone(),
                cheapest_wall_seconds: c,
                saving: if rc > 0.0 { 1.0 - c / rc } else { 0.0 },
            })
        }),
        _ => None,
    };
    // Factor preferences, overall and per segment.
    let mut factor_prefs = BTreeMap::new();
    let trials_of = |sessions: Option<&[usize]>| {
        data.trials
            .iter()
            .filter(|tr| sessions.is_none_or(|s| s.contains(&tr.session)))
            .map(|tr| (&tr.shown[0], &tr.shown[1], &tr.choice))
            .collect::<Vec<_>>()
    };
    let overall = trials_of(None);
    factor_prefs.insert("all".to_owned(), factor_preferences(&overall, varying));
    for (segment, sessions) in segments(&data.sessions) {
        let list = trials_of(Some(&sessions));
        factor_prefs.insert(segment, factor_preferences(&list, varying));
    }
    PairedReport {
        judge_unit: options.judge_unit,
        judges_statement,
        judges,
        complete_judges: complete,
        matrix_all: all,
        matrix: complete_matrix,
        votes,
        mean_zeta,
        agreement,
        critical,
        groups,
        memberships: member_of,
        scale,
        recommendation,
        factor_preferences: factor_prefs,
        design,
        scale_grouping,
        screening,
        excluded_participants: Vec::new(),
    }
}

fn analyze_matching(data: &ExperimentData) -> MatchingReport {
    let t = data.stimuli.len();
    let index: BTreeMap<StimulusId, usize> = data.stimuli.iter().enumerate().map(|(i, s)| (*s, i)).collect();
    let mut total = vec![vec![0u32; t]; t];
    let mut correct = vec![vec![0u32; t]; t];
    let mut by_segment: BTreeMap<String, (u32, u32)> = BTreeMap::new();
    let segs = segments(&data.sessions);
    for trial in &data.trials {
        let (a, b) = (index[&trial.shown[1]], index[&trial.shown[2]]);
        let ok = u32::from(trial.correct == Some(true));
        for (i, j) in [(a, b), (b, a)] {
            total[i][j] += 1;
            correct[i][j] += ok;
            if i == j {
                break;
            }
        }
        for (segment, sessions) in &segs {
            if sessions.contains(&trial.session) {
                let e = by_segment.entry(segment.clone()).or_default();
                e.0 += ok;
                e.1 += 1;
            }
        }
    }
    let accuracy = total
        .iter()
        .zip(&correct)
        .map(|(tr, cr)| tr.iter().zip(cr).map(|(&n, &k)| (n > 0).then(|| f64::from(k) / f64::from(n))).collect())
        .collect();
    let trials = data.trials.len() as u32;
    let right = data.trials.iter().filter(|t| t.correct == Some(true)).count() as f64;
    MatchingReport {
        total,
        correct,
        accuracy,
        overall: if trials > 0 { right / f64::from(trials) } else { f64::NAN },
        trials,
        segments: by_segment.into_iter().map(|(k, (c, n))| (k, f64::from(c) / f64::from(n))).collect(),
    }
}
