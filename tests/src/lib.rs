//! End-to-end tests of the `blurlab` command live in `tests/`; this library gives them the
//! built binary and small helpers.
//!
//! The binary is `target/<profile>/blurlab` next to the running test's `deps/` folder.
//! `cargo test --workspace` builds it before running any test; when `cargo` runs only this
//! package, [`blurlab`] builds it first (`cargo build -p blurlab`, same target folder and
//! profile), so a test never runs a stale binary. `BLURLAB_BIN` overrides the path.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// The shipped design file.
pub fn shipped_design() -> PathBuf {
    repo_root().join("stimuli/navarro2011.toml")
}

/// Reports a test that cannot run here, on the process's stderr itself (libtest captures
/// the print macros of passing tests, so an `eprintln!` would hide the skip): the line
/// starts with `SKIPPED:` and names the test and the reason.
pub fn skipped(test: &str, reason: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "SKIPPED: {test}: {reason}");
}

/// Path of an up-to-date `blurlab` binary.
///
/// # Panics
/// When the binary cannot be found or built (a test set-up failure).
pub fn blurlab() -> PathBuf {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        if let Some(path) = std::env::var_os("BLURLAB_BIN") {
            return PathBuf::from(path);
        }
        let exe = std::env::current_exe().expect("test executable path");
        let profile_dir = exe.parent().and_then(Path::parent).expect("target/<profile>/deps/<test>").to_path_buf();
        let target_dir = profile_dir.parent().expect("target folder").to_path_buf();
        let profile = match profile_dir.file_name().and_then(|n| n.to_str()) {
            Some("debug") => "dev".to_owned(),
            Some(name) => name.to_owned(),
            None => "dev".to_owned(),
        };
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "--quiet", "-p", "blurlab", "--bin", "blurlab", "--profile", &profile])
            .env("CARGO_TARGET_DIR", &target_dir)
            .current_dir(repo_root())
            .status()
            .expect("running cargo build for the blurlab binary");
        assert!(status.success(), "cargo build -p blurlab failed");
        let bin = profile_dir.join(format!("blurlab{}", std::env::consts::EXE_SUFFIX));
        assert!(bin.is_file(), "{} was not built", bin.display());
        bin
    })
    .clone()
}

/// Runs `blurlab` with `args` in the repository root.
pub fn run(args: &[&str]) -> Output {
    Command::new(blurlab()).args(args).current_dir(repo_root()).output().expect("running blurlab")
}

/// Stdout of a run as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Stderr of a run as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Renders the quick preset's mono sequences of `design` that `only` selects (e.g.
/// `M3 S3 T5 A1,A5`) on the CPU into `out`. Panics with the command's stderr when it fails.
pub fn render_quick_set(design: &Path, only: &str, out: &Path) {
    let (design, out_arg) = (design.to_string_lossy().into_owned(), out.to_string_lossy().into_owned());
    let args = ["stimuli", "render", "--design", &design, "--preset", "quick", "--views", "mono", "--only", only];
    let out = run(&[&args[..], &["--device", "cpu", "--out", &out_arg, "--progress", "quiet"]].concat());
    assert!(out.status.success(), "{}", stderr(&out));
}

/// Runs `experiment` on the stimulus set `set` with three simulated participants (Thurstone
/// observers, seeds 1-3) into `results`, then `blurlab analyze --json` of its results into
/// `report`: the analysis as JSON. Panics with the command's stderr when one fails.
pub fn simulate_and_analyze(experiment: &Path, set: &Path, results: &Path, report: &Path) -> serde_json::Value {
    let text = |p: &Path| p.to_string_lossy().into_owned();
    let (experiment_arg, set_arg, results_arg) = (text(experiment), text(set), text(results));
    for (participant, seed) in [("P1", "1"), ("P2", "2"), ("P3", "3")] {
        let out = run(&[
            "run",
            &experiment_arg,
            "--stimuli",
            &set_arg,
            "--participant",
            participant,
            "--results",
            &results_arg,
            "--simulate",
            "thurstone",
            "--seed",
            seed,
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
    }
    let name = experiment.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let out = run(&[
        "analyze",
        &text(&results.join(name)),
        "--manifest",
        &set_arg,
        "--experiments",
        &text(&repo_root().join("experiments")),
        "--out",
        &text(report),
        "--json",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("analyze --json: {e}: {}", stdout(&out)))
}
