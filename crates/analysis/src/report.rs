//! The report folder: `report.md` (tables), `report.json` (every number, format
//! `blurlab-report/1`) and the figures as PNG and SVG. Render costs come from the stimulus
//! set's manifests (`index.json` and each sequence's `manifest.json`).
//!
//! Incomplete designs ([`crate::incomplete`]) say so in place of Kendall's statistics and
//! list the scale's groups; every 2AFC experiment gets the heat map of the pairs shown
//! (`EXP-pairs`) and the observer screening (`EXP-screening`, [`crate::screening`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;
use study::manifest::{SequenceManifest, SetIndex};
use study::{Factor, StimulusId};

use crate::experiment::{
    AnalysisOptions, Cost, ExperimentReport, Group, GroupMember, PairedReport, Recommendation,
    analyze_experiment_screened,
};
use crate::incomplete::Design;
use crate::logs::{LoadOptions, LogError, load_experiments};
use crate::plots::{
    Figure, GridCell, GridFigure, HeatmapFigure, PairCountFigure, PlotError, PreferenceFigure, ScaleFigure,
    ScreeningFigure, SideBySide, VotesFigure, save_figure,
};
use crate::votes::VoteTable;

/// Format tag of report.json.
pub const REPORT_FORMAT: &str = "blurlab-report/1";

/// Why a report cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Logs could not be read or are inconsistent.
    #[error(transparent)]
    Logs(#[from] LogError),
    /// The manifest could not be read.
    #[error(transparent)]
    Manifest(#[from] study::manifest::ManifestError),
    /// The set given with `--manifest` is damaged or is not the one the logs were run with.
    #[error("{}: {message}", path.display())]
    Set {
        /// The set's index or a manifest.
        path: PathBuf,
        /// What differs.
        message: String,
    },
    /// A figure failed.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// Writing failed.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// File or folder.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
}

/// A whole report: one analysis per experiment and the mono/stereo pairs found.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Always [`REPORT_FORMAT`].
    pub format: &'static str,
    /// blurlab version.
    pub software_version: &'static str,
    /// Stimulus set whose manifest gave the costs.
    pub manifest: Option<String>,
    /// Per experiment.
    pub experiments: Vec<ExperimentReport>,
    /// `(mono, stereo)` experiment names compared side by side.
    pub mono_stereo_pairs: Vec<(String, String)>,
    /// Figures written, relative to the report folder.
    pub figures: Vec<String>,
    /// Vote tables written (`blurlab-votes/1`, one per complete 2AFC experiment), relative to
    /// the report folder.
    pub vote_tables: Vec<String>,
}

/// Render costs of every sequence in a set (`SET` folder or its `index.json`).
pub fn load_costs(set: &Path) -> Result<BTreeMap<StimulusId, Cost>, ReportError> {
    load_set(set).map(|s| s.costs)
}

/// A set read for the analysis: costs and the hashes logs record for it.
pub struct LoadedSet {
    /// The index file.
    pub index_path: PathBuf,
    /// Render cost per sequence.
    pub costs: BTreeMap<StimulusId, Cost>,
    /// Content hash ([`SetIndex::content_sha256`]) over its verified manifests.
    pub content_sha256: String,
    /// SHA-256 of its index.json (what logs of earlier versions recorded).
    pub index_sha256: String,
}

/// Reads a set (`SET` folder or its `index.json`), checking every manifest against the hash
/// the index records.
pub fn load_set(set: &Path) -> Result<LoadedSet, ReportError> {
    let (root, index_path) = if set.is_dir() {
        (set.to_owned(), set.join("index.json"))
    } else {
        (set.parent().unwrap_or(Path::new(".")).to_owned(), set.to_owned())
    };
    let index = SetIndex::read(&index_path)?;
    let index_sha256 = study::fsio::sha256_file(&index_path)
        .map_err(|source| study::manifest::ManifestError::Io { path: index_path.clone(), source })?;
    let mut costs = BTreeMap::new();
    for entry in &index.sequences {
        let path = root.join(&entry.folder).join("manifest.json");
        let actual = study::fsio::sha256_file(&path)
            .map_err(|source| study::manifest::ManifestError::Io { path: path.clone(), source })?;
        if actual != entry.manifest_sha256 {
            return Err(ReportError::Set {
                path,
                message: format!(
                    "sequence {}: the manifest's sha256 is {actual}, and index.json records {}: the set was altered or damaged",
                    entry.id, entry.manifest_sha256
                ),
            });
        }
        let manifest = SequenceManifest::read(&path)?;
        costs.insert(entry.id, Cost { wall_seconds: manifest.wall_seconds(), cpu_seconds: manifest.cpu_seconds() });
    }
    Ok(LoadedSet { content_sha256: index.content_sha256(), index_sha256, costs, index_path })
}

/// Reads the logs under `results`, analyses every experiment and builds the report.
pub fn build_report(
    results: &[PathBuf],
    manifest: Option<&Path>,
    experiments_dir: Option<&Path>,
    options: AnalysisOptions,
) -> Result<Report, ReportError> {
    build_report_screened(results, manifest, experiments_dir, options, false)
}

/// [`build_report`]; with `exclude_outliers` the sessions of the participants observer
/// screening flags are left out of each 2AFC experiment's analysis (`analyze --exclude-outliers`).
pub fn build_report_screened(
    results: &[PathBuf],
    manifest: Option<&Path>,
    experiments_dir: Option<&Path>,
    options: AnalysisOptions,
    exclude_outliers: bool,
) -> Result<Report, ReportError> {
    let set = manifest.map(load_set).transpose()?;
    let costs = set.as_ref().map(|s| s.costs.clone()).unwrap_or_default();
    let load = LoadOptions {
        experiments_dir: experiments_dir.map(Path::to_owned),
        known_stimuli: manifest.map(|_| costs.keys().copied().collect()),
    };
    let data = load_experiments(results, &load)?;
    // The costs must come from the set the participants saw.
    if let Some(set) = &set {
        for d in &data {
            let logged = d.stimulus_set_sha256.as_str();
            if logged != set.content_sha256 && logged != set.index_sha256 {
                let log = d.sessions.first().map_or_else(String::new, |s| s.path.display().to_string());
                return Err(ReportError::Set {
                    path: set.index_path.clone(),
                    message: format!(
                        "the logs of experiment `{}` ({log}, ...) were run with stimulus set {logged}, and this set is {} (index.json {}): it is another set or another design's; give the set the sessions showed",
                        d.name, set.content_sha256, set.index_sha256
                    ),
                });
            }
        }
    }
    let experiments: Vec<ExperimentReport> =
        data.iter().map(|d| analyze_experiment_screened(d, &costs, options, exclude_outliers)).collect();
    let mut pairs = Vec::new();
    for e in &experiments {
        if let Some(rest) = e.name.strip_prefix("mono-") {
            let stereo = format!("stereo-{rest}");
            if experiments.iter().any(|x| x.name == stereo) {
                pairs.push((e.name.clone(), stereo));
            }
        }
    }
    Ok(Report {
        format: REPORT_FORMAT,
        software_version: study::SOFTWARE_VERSION,
        manifest: manifest.map(|m| m.display().to_string()),
        experiments,
        mono_stereo_pairs: pairs,
        figures: Vec::new(),
        vote_tables: Vec::new(),
    })
}

/// The vote totals of a complete 2AFC experiment's complete judges as a vote table, with the
/// number of judges and the level its groups were made at: `analyze --votes` groups it as the
/// report did, and `predict --votes` compares a forecast with it. `None` where David's grouping
/// does not apply (an incomplete design, no complete judge, or no 2AFC trials).
pub fn vote_table(e: &ExperimentReport) -> Option<VoteTable> {
    let p = e.paired.as_ref().filter(|p| !p.design.is_incomplete())?;
    let critical = p.critical?;
    let left_out = if p.excluded_participants.is_empty() {
        String::new()
    } else {
        format!(", {} flagged participant(s) left out", p.excluded_participants.len())
    };
    let source = format!(
        "blurlab analyze {}: the votes of {} complete passes over the pairs in {} session(s){left_out}; experiment sha256 {}, stimulus set sha256 {}",
        study::SOFTWARE_VERSION,
        p.complete_judges,
        e.sessions.len(),
        e.experiment_sha256,
        e.stimulus_set_sha256
    );
    Some(VoteTable {
        path: PathBuf::from(format!("{}-votes.csv", e.name)),
        header: vec![
            ("source".into(), source),
            ("experiment".into(), e.name.clone()),
            ("judges".into(), critical.judges.to_string()),
            ("alpha".into(), critical.alpha.to_string()),
        ],
        labels: e.labels.clone(),
        votes: p.votes.clone(),
    })
}

fn votes_figure(e: &ExperimentReport) -> Option<VotesFigure> {
    let p = e.paired.as_ref().filter(|p| !p.design.is_incomplete())?;
    Some(VotesFigure {
        title: format!("{}: votes", e.name),
        labels: e.labels.clone(),
        votes: p.votes.clone(),
        groups: p
            .groups
            .iter()
            .map(|g| g.members.iter().filter_map(|m| e.labels.iter().position(|l| *l == m.label)).collect())
            .collect(),
        ceil_rc: p.critical.map(|c| c.ceil_rc),
    })
}

/// The shutter x sampling grid when exactly those two factors vary.
fn grid_figure(e: &ExperimentReport) -> Option<GridFigure> {
    let p = e.paired.as_ref().filter(|p| !p.design.is_incomplete())?;
    if e.varying != [Factor::Shutter, Factor::Samples] {
        return None;
    }
    let mut shutters: Vec<u8> = e.stimuli.iter().map(|s| s.shutter).collect();
    let mut samples: Vec<u8> = e.stimuli.iter().map(|s| s.samples).collect();
    shutters.sort_unstable();
    shutters.dedup();
    samples.sort_unstable();
    samples.dedup();
    let cells = e
        .stimuli
        .iter()
        .enumerate()
        .map(|(i, s)| GridCell {
            column: shutters.iter().position(|&x| x == s.shutter).unwrap_or(0),
            row: samples.iter().position(|&x| x == s.samples).unwrap_or(0),
            label: e.labels[i].clone(),
            votes: p.votes[i],
            groups: p.memberships[i].clone(),
        })
        .collect();
    Some(GridFigure {
        title: format!("{}: groups (shutter left to right, sampling bottom to top)", e.name),
        columns: shutters.iter().map(|l| format!("T{l}")).collect(),
        rows: samples.iter().map(|l| format!("A{l}")).collect(),
        cells,
    })
}

/// Writes the report folder: figures, report.json and report.md. Returns report.md's path.
pub fn write_report(report: &mut Report, dir: &Path) -> Result<PathBuf, ReportError> {
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io { path: dir.to_owned(), source })?;
    let mut figures: Vec<String> = Vec::new();
    let mut save = |fig_result: Result<Vec<PathBuf>, PlotError>| -> Result<(), ReportError> {
        for p in fig_result? {
            figures.push(p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default());
        }
        Ok(())
    };
    for e in &report.experiments {
        if let Some(f) = votes_figure(e) {
            save(save_figure(&f, dir, &format!("{}-votes", e.name)))?;
        }
        if let Some(f) = grid_figure(e) {
            save(save_figure(&f, dir, &format!("{}-grid", e.name)))?;
        }
        if let Some(p) = &e.paired {
            let fig = ScaleFigure {
                title: format!(
                    "{}: Thurstone Case V scale, {:.0} % bootstrap intervals",
                    e.name,
                    p.scale.options.confidence * 100.0
                ),
                labels: e.labels.clone(),
                scores: p.scale.scores.clone(),
                lower: p.scale.lower.clone(),
                upper: p.scale.upper.clone(),
            };
            save(save_figure(&fig, dir, &format!("{}-scale", e.name)))?;
            let fig = PairCountFigure {
                title: format!("{}: times each pair was shown", e.name),
                labels: e.labels.clone(),
                counts: p.pair_counts(),
            };
            save(save_figure(&fig, dir, &format!("{}-pairs", e.name)))?;
            let fig = ScreeningFigure {
                title: format!("{}: observer screening (leave one participant out)", e.name),
                participants: p.screening.observers.iter().map(|o| o.participant.clone()).collect(),
                values: p.screening.observers.iter().map(|o| o.log10_likelihood).collect(),
                flagged: p.screening.observers.iter().map(|o| o.flagged).collect(),
                threshold: p.screening.threshold,
                q1: p.screening.q1,
            };
            save(save_figure(&fig, dir, &format!("{}-screening", e.name)))?;
            if p.factor_preferences.get("all").is_some_and(|v| !v.is_empty()) {
                let series = p.factor_preferences.iter().map(|(k, v)| (k.clone(), v.clone())).collect::<Vec<_>>();
                // "all" first.
                let mut series = series;
                series.sort_by_key(|(k, _)| k != "all");
                let fig =
                    PreferenceFigure { title: format!("{}: preference per factor (error bars: SE)", e.name), series };
                save(save_figure(&fig, dir, &format!("{}-preferences", e.name)))?;
            }
        }
        if let Some(m) = &e.matching {
            let fig = HeatmapFigure {
                title: format!("{}: matching accuracy {:.2} %", e.name, m.overall * 100.0),
                labels: e.labels.clone(),
                values: m.accuracy.clone(),
            };
            save(save_figure(&fig, dir, &format!("{}-matching", e.name)))?;
        }
    }
    for (mono, stereo) in &report.mono_stereo_pairs {
        let find = |n: &str| report.experiments.iter().find(|e| e.name == n);
        let (Some(a), Some(b)) = (find(mono), find(stereo)) else { continue };
        let stem = format!("{}-mono-vs-stereo", mono.trim_start_matches("mono-"));
        if let (Some(fa), Some(fb)) = (votes_figure(a), votes_figure(b)) {
            save(save_figure(&SideBySide { panels: vec![fa, fb] }, dir, &format!("{stem}-votes")))?;
        }
        if let (Some(pa), Some(pb)) = (&a.paired, &b.paired) {
            let all =
                |p: &crate::experiment::PairedReport| p.factor_preferences.get("all").cloned().unwrap_or_default();
            if !all(pa).is_empty() {
                let fig = PreferenceFigure {
                    title: format!("{stem}: preference per factor, mono vs stereo (error bars: SE)"),
                    series: vec![("mono".into(), all(pa)), ("stereo".into(), all(pb))],
                };
                save(save_figure(&fig, dir, &format!("{stem}-preferences")))?;
            }
        }
    }
    report.figures = figures;
    report.vote_tables.clear();
    for table in report.experiments.iter().filter_map(vote_table) {
        let path = dir.join(&table.path);
        study::fsio::write_atomic(&path, table.to_text().as_bytes())
            .map_err(|source| ReportError::Io { path: path.clone(), source })?;
        report.vote_tables.push(table.path.display().to_string());
    }
    let json = serde_json::to_string_pretty(&*report).expect("report serialises");
    let json_path = dir.join("report.json");
    study::fsio::write_atomic(&json_path, json.as_bytes())
        .map_err(|source| ReportError::Io { path: json_path, source })?;
    let md_path = dir.join("report.md");
    study::fsio::write_atomic(&md_path, markdown(report).as_bytes())
        .map_err(|source| ReportError::Io { path: md_path.clone(), source })?;
    Ok(md_path)
}

fn fmt_p(p: f64) -> String {
    if !p.is_finite() {
        "-".into()
    } else if p < 1e-4 {
        format!("{p:.1e}")
    } else {
        format!("{p:.4}")
    }
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".into(), |v| format!("{v:.digits$}"))
}

/// The report as Markdown.
pub fn markdown(report: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# blurlab analysis report\n");
    let _ = writeln!(
        s,
        "blurlab {}; costs from {}.\n",
        report.software_version,
        report.manifest.as_deref().unwrap_or("(no manifest given)")
    );
    for e in &report.experiments {
        let _ = writeln!(s, "## {} ({}, {:?})\n", e.name, e.task, e.view);
        let completed = e.sessions.iter().filter(|x| x.completed).count();
        let participants: std::collections::BTreeSet<&str> =
            e.sessions.iter().map(|x| x.participant.as_str()).collect();
        let _ = writeln!(
            s,
            "{} sessions ({} completed) from {} participants; {} stimuli; definition: {}; experiment sha256 `{}`.\n",
            e.sessions.len(),
            completed,
            participants.len(),
            e.stimuli.len(),
            e.definition.as_deref().unwrap_or("not found (stimuli taken from the logs)"),
            e.experiment_sha256
        );
        if let Some(p) = &e.paired {
            let _ = writeln!(s, "**Judges.** {}\n", p.judges_statement);
            if !p.excluded_participants.is_empty() {
                let _ = writeln!(
                    s,
                    "**Excluded** (`--exclude-outliers`): the sessions of {} were left out of this analysis; observer screening below was computed before.\n",
                    p.excluded_participants.join(", ")
                );
            }
            let incomplete = p.design.is_incomplete();
            if incomplete {
                incomplete_markdown(&mut s, e, p);
            }
        }
        if let Some(p) = e.paired.as_ref().filter(|p| !p.design.is_incomplete()) {
            let _ = writeln!(s, "![votes]({}-votes.png)\n", e.name);
            let _ = writeln!(
                s,
                "| stimulus | id | votes (complete judges) | votes (all trials) | groups | scale (JOD) | CI |"
            );
            let _ = writeln!(s, "| --- | --- | ---: | ---: | --- | ---: | --- |");
            let all_scores = p.matrix_all.scores();
            let mut order: Vec<usize> = (0..e.stimuli.len()).collect();
            order.sort_by(|&a, &b| p.votes[b].cmp(&p.votes[a]).then(a.cmp(&b)));
            for i in order {
                let groups = p.memberships[i].iter().map(|g| format!("G{}", g + 1)).collect::<Vec<_>>().join(" ");
                let ci = match (p.scale.lower.get(i), p.scale.upper.get(i)) {
                    (Some(l), Some(u)) => format!("[{l:.2}, {u:.2}]"),
                    _ => "-".into(),
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {:.3} | {} |",
                    e.labels[i], e.stimuli[i], p.votes[i], all_scores[i], groups, p.scale.scores[i], ci
                );
            }
            let _ = writeln!(s);
            match &p.critical {
                Some(c) => {
                    let _ = writeln!(
                        s,
                        "**Significance grouping** (David): alpha = {}, t = {}, m = {}: W = {:.4}, R_c = {:.3}, ceil(R_c) = {}; {} groups.\n",
                        c.alpha,
                        c.t,
                        c.judges,
                        c.w,
                        c.rc,
                        c.ceil_rc,
                        p.groups.len()
                    );
                    let _ = writeln!(
                        s,
                        "The vote totals as a table: [`{0}-votes.csv`]({0}-votes.csv) (`blurlab-votes/1`, m = {1}, alpha = {2}): `blurlab analyze --votes` groups it again, `blurlab predict --votes` compares a forecast with it, and `blurlab stats ceiling` says how far the same test run again would agree with its order.\n",
                        e.name, c.judges, c.alpha
                    );
                }
                None => {
                    let _ = writeln!(s, "**Significance grouping**: not available (no complete judge).\n");
                }
            }
            if !p.groups.is_empty() {
                groups_table(&mut s, &p.groups, "votes");
            }
            if let Some(r) = &p.recommendation {
                recommendation_text(&mut s, r);
            }
            if e.varying == [Factor::Shutter, Factor::Samples] {
                let _ = writeln!(s, "![grid]({}-grid.png)\n", e.name);
            }
            let _ = writeln!(
                s,
                "**Consistency and agreement.** Mean zeta = {} over {} complete judges.",
                fmt_opt(p.mean_zeta, 4),
                p.complete_judges
            );
            match &p.agreement {
                Ok(a) => {
                    let _ = writeln!(
                        s,
                        " Kendall's u = {:.4} in [{:.4}, 1] (m = {}), chi-square = {:.2}, df = {:.2}, p = {}.\n",
                        a.u,
                        a.u_min,
                        a.judges,
                        a.chi_square,
                        a.df,
                        fmt_p(a.p_value)
                    );
                }
                Err(why) => {
                    let _ = writeln!(s, " Agreement not available: {why}.\n");
                }
            }
            let _ =
                writeln!(s, "| judge | complete | judgments | circular triads | zeta | triads chi-square (df) | p |");
            let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | --- | ---: |");
            for j in &p.judges {
                let (chi, pv) = match j.triad_test {
                    Some(tt) => (format!("{:.2} ({:.2})", tt.chi_square, tt.df), fmt_p(tt.p_value)),
                    None => ("-".into(), "-".into()),
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} |",
                    j.name,
                    if j.complete { "yes" } else { "no" },
                    j.judgments,
                    j.circular_triads.map_or("-".into(), |d| d.to_string()),
                    fmt_opt(j.zeta, 4),
                    chi,
                    pv
                );
            }
            let _ = writeln!(s);
        }
        if let Some(p) = &e.paired {
            if p.factor_preferences.get("all").is_some_and(|v| !v.is_empty()) {
                let _ = writeln!(s, "**Preference per factor** (chi-square against 50 : 50, 1 df):\n");
                let _ = writeln!(s, "| segment | levels | n | first level | second level | SE | chi-square | p |");
                let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |");
                for (segment, prefs) in &p.factor_preferences {
                    for q in prefs {
                        let _ = writeln!(
                            s,
                            "| {segment} | {} vs {} | {} | {:.1} % | {:.1} % | {:.1} % | {:.2} | {} |",
                            q.level_a,
                            q.level_b,
                            q.n,
                            q.p_a * 100.0,
                            q.p_b * 100.0,
                            q.se * 100.0,
                            q.chi_square,
                            fmt_p(q.p_value)
                        );
                    }
                }
                let _ = writeln!(s, "\n![preferences]({}-preferences.png)\n", e.name);
            }
            let _ = writeln!(
                s,
                "**Scale.** Thurstone Case V (MAP, prior sd {} JOD), {} bootstrap resamples over {}, seed {}: ![scale]({}-scale.png)\n",
                p.scale.options.prior_sd,
                p.scale.options.resamples,
                if p.design.is_incomplete() { "participants" } else { "judges" },
                p.scale.options.seed,
                e.name
            );
            pairs_and_screening_markdown(&mut s, e, p);
        }
        if let Some(m) = &e.matching {
            let _ = writeln!(s, "**Matching accuracy**: {:.2} % of {} trials.\n", m.overall * 100.0, m.trials);
            let _ = write!(s, "| |");
            for l in &e.labels {
                let _ = write!(s, " {l} |");
            }
            let _ = writeln!(s);
            let _ = writeln!(s, "|---{}", "|---".repeat(e.labels.len()));
            for (i, row) in m.accuracy.iter().enumerate() {
                let _ = write!(s, "| {} |", e.labels[i]);
                for (j, v) in row.iter().enumerate() {
                    let _ =
                        write!(s, " {} |", v.map_or("-".into(), |a| format!("{:.0} % ({})", a * 100.0, m.total[i][j])));
                }
                let _ = writeln!(s);
            }
            for (segment, a) in &m.segments {
                let _ = writeln!(s, "\n{segment}: {:.2} %", a * 100.0);
            }
            let _ = writeln!(s, "\n![matching]({}-matching.png)\n", e.name);
        }
        if !e.warnings.is_empty() {
            let _ = writeln!(s, "**Warnings**\n");
            for w in &e.warnings {
                let _ = writeln!(s, "- {w}");
            }
            let _ = writeln!(s);
        }
    }
    for (mono, stereo) in &report.mono_stereo_pairs {
        let stem = format!("{}-mono-vs-stereo", mono.trim_start_matches("mono-"));
        let _ = writeln!(s, "## {mono} vs {stereo}\n\n![votes]({stem}-votes.png)\n");
    }
    let _ = writeln!(s, "Figures: {}", report.figures.join(", "));
    s
}

fn member_text(m: &GroupMember) -> String {
    match (m.scale, m.cost) {
        (Some(v), Some(c)) => format!("{} ({v:.2} JOD, {:.1} s)", m.label, c.wall_seconds),
        (Some(v), None) => format!("{} ({v:.2} JOD)", m.label),
        (None, Some(c)) => format!("{} ({}, {:.1} s)", m.label, m.votes, c.wall_seconds),
        (None, None) => format!("{} ({})", m.label, m.votes),
    }
}

fn groups_table(s: &mut String, groups: &[Group], score: &str) {
    let _ = writeln!(s, "| group | members ({score}, wall s) | cheapest | saving vs most expensive of G1 |");
    let _ = writeln!(s, "| --- | --- | --- | ---: |");
    for g in groups {
        let members = g.members.iter().map(member_text).collect::<Vec<_>>().join(", ");
        let _ = writeln!(
            s,
            "| G{} | {} | {} | {} |",
            g.number,
            members,
            g.cheapest.as_deref().unwrap_or("-"),
            g.saving_vs_top_most_expensive.map_or("-".into(), |v| format!("{:.1} %", v * 100.0))
        );
    }
    let _ = writeln!(s);
}

fn recommendation_text(s: &mut String, r: &Recommendation) {
    let _ = writeln!(
        s,
        "**Recommendation.** {} ({:.1} s) is perceptually equivalent to {} ({:.1} s): render it instead and save {:.1} % of the cost.\n",
        r.cheapest,
        r.cheapest_wall_seconds,
        r.reference,
        r.reference_wall_seconds,
        r.saving * 100.0
    );
}

/// The incomplete design's statement, scale table and scale groups (in place of the vote
/// table, David's grouping and Kendall's statistics).
fn incomplete_markdown(s: &mut String, e: &ExperimentReport, p: &PairedReport) {
    let Design::Incomplete { reason } = &p.design else { return };
    let _ = writeln!(
        s,
        "**Incomplete design.** {reason}. Kendall's coefficients of consistency (circular triads, zeta) and agreement (u), their chi-square tests and David's vote-count grouping need every pair judged by every judge, so they are not reported. The stimuli are ranked on the Thurstone Case V scale over all {} trials, with bootstrap intervals over participants, and grouped by the scale (see [the pairs shown](#pairs-shown-{})).\n",
        p.matrix_all.total(),
        e.name
    );
    let counts = p.pair_counts();
    let _ = writeln!(s, "| stimulus | id | times shown | wins | groups | scale (JOD) | CI |");
    let _ = writeln!(s, "| --- | --- | ---: | ---: | --- | ---: | --- |");
    let wins = p.matrix_all.scores();
    let mut order: Vec<usize> = (0..e.stimuli.len()).collect();
    order.sort_by(|&a, &b| p.scale.scores[b].total_cmp(&p.scale.scores[a]).then(a.cmp(&b)));
    for i in order {
        let groups = p.memberships[i].iter().map(|g| format!("G{}", g + 1)).collect::<Vec<_>>().join(" ");
        let ci = match (p.scale.lower.get(i), p.scale.upper.get(i)) {
            (Some(l), Some(u)) => format!("[{l:.2}, {u:.2}]"),
            _ => "-".into(),
        };
        let shown: u32 = counts[i].iter().sum();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.3} | {} |",
            e.labels[i], e.stimuli[i], shown, wins[i], groups, p.scale.scores[i], ci
        );
    }
    let _ = writeln!(s);
    match &p.scale_grouping {
        Some(Ok(g)) => {
            let _ = writeln!(
                s,
                "**Significance grouping** (scale, alpha = {}): {}. {} of {} pairs differ significantly; {} groups.\n",
                g.alpha,
                g.test,
                g.significant_pairs,
                e.stimuli.len() * e.stimuli.len().saturating_sub(1) / 2,
                p.groups.len()
            );
        }
        Some(Err(why)) => {
            let _ = writeln!(s, "**Significance grouping**: not available: {why}.\n");
        }
        None => {}
    }
    if !p.groups.is_empty() {
        groups_table(s, &p.groups, "scale");
    }
    if let Some(r) = &p.recommendation {
        recommendation_text(s, r);
    }
}

/// The heat map of the pairs shown and the observer screening (every 2AFC experiment).
fn pairs_and_screening_markdown(s: &mut String, e: &ExperimentReport, p: &PairedReport) {
    let counts = p.pair_counts();
    let t = e.stimuli.len();
    let pairs = t * t.saturating_sub(1) / 2;
    let shown = (0..t).map(|i| (i + 1..t).filter(|&j| counts[i][j] > 0).count()).sum::<usize>();
    let _ = writeln!(s, "<a id=\"pairs-shown-{}\"></a>", e.name);
    let _ = writeln!(
        s,
        "**Pairs shown.** {shown} of {pairs} pairs were shown at least once ({} trials): ![pairs]({}-pairs.png)\n",
        p.matrix_all.total(),
        e.name
    );
    let sc = &p.screening;
    let _ = writeln!(s, "**Observer screening.** {}.\n", sc.statistic);
    let _ = writeln!(s, "![screening]({}-screening.png)\n", e.name);
    let _ = writeln!(s, "| participant | trials | L (log10 per trial) | distance (IQR below Q1) | flagged |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | --- |");
    for o in &sc.observers {
        let _ = writeln!(
            s,
            "| {} | {} | {:.4} | {:.2} | {} |",
            o.participant,
            o.trials,
            o.log10_likelihood,
            o.distance,
            if o.flagged { "yes" } else { "no" }
        );
    }
    let _ = writeln!(s);
    if sc.flagged.is_empty() {
        let _ = writeln!(s, "No participant is flagged.\n");
    } else if p.excluded_participants.is_empty() {
        let _ = writeln!(
            s,
            "Flagged: {}. They are kept in this analysis; `blurlab analyze --exclude-outliers` leaves their sessions out.\n",
            sc.flagged.join(", ")
        );
    } else {
        let _ = writeln!(s, "Flagged and excluded: {}.\n", p.excluded_participants.join(", "));
    }
}

/// Draws a figure of a vote table (for `analyze --votes`).
pub fn votes_table_figure(
    title: &str,
    labels: &[String],
    votes: &[u32],
    groups: &[Vec<String>],
    ceil_rc: u64,
) -> impl Figure {
    VotesFigure {
        title: title.to_owned(),
        labels: labels.to_vec(),
        votes: votes.to_vec(),
        groups: groups.iter().map(|g| g.iter().filter_map(|m| labels.iter().position(|l| l == m)).collect()).collect(),
        ceil_rc: Some(ceil_rc),
    }
}
