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
