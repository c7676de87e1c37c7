//! The one rule for GPU tests in the workspace: a test that needs a device asks
//! [`test_context`] (or [`test_context_with`]). With an adapter it gets a device. Without one
//! it is skipped visibly: the line
//!
//! ```text
//! SKIPPED: no GPU adapter (<reason>): <test name>; set BLURLAB_REQUIRE_GPU=1 to require one
//! ```
//!
//! is written straight to the process's stderr (not through `eprintln!`, which libtest
//! captures and hides for passing tests), so plain `cargo test` output shows it. With
//! `BLURLAB_REQUIRE_GPU=1` (CI sets it: `.ci/run`) the test panics with the reason instead.
//! A test whose GPU step fails in another way (a UI harness that renders through its own
//! device) uses [`skip_or_fail`] for the same rule.
//!
//! These helpers panic by design: they are for tests only.

use std::io::Write as _;

use crate::{AdapterChoice, DeviceRequest, GpuContext, acquire};

/// The environment variable that turns a missing GPU into a test failure (`1`).
pub const REQUIRE_GPU_ENV: &str = "BLURLAB_REQUIRE_GPU";

/// Whether GPU tests must run: `BLURLAB_REQUIRE_GPU=1`.
pub fn require_gpu() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1")
}

/// The skip line for `test_name` skipped because of `reason`.
fn skipped_line(test_name: &str, reason: &dyn std::fmt::Display) -> String {
    let reason = reason.to_string();
    // A `GpuError::NoAdapter` says "no GPU adapter" itself.
    let reason = reason.strip_prefix("no GPU adapter: ").unwrap_or(&reason);
    format!("SKIPPED: no GPU adapter ({reason}): {test_name}; set {REQUIRE_GPU_ENV}=1 to require one\n")
}

/// The rule for a GPU step of `test_name` that could not run because of `reason`: panics
/// when [`require_gpu`], otherwise writes the `SKIPPED: no GPU adapter ...` line to the
/// process's stderr (uncaptured). The caller then returns (or skips the step).
pub fn skip_or_fail(test_name: &str, reason: &dyn std::fmt::Display) {
    if require_gpu() {
        panic!("{REQUIRE_GPU_ENV}=1 but {test_name} has no GPU: {reason}");
    }
    // Straight to the file descriptor: libtest captures only the print macros.
    let mut stderr = std::io::stderr().lock();
    // A test's stderr that cannot be written to has nowhere to report that either.
    let _ = stderr.write_all(skipped_line(test_name, reason).as_bytes());
    let _ = stderr.flush();
}

/// A device for `test_name` from a hardware adapter, or else a software one (CI runs on
/// lavapipe), with the default [`DeviceRequest`]; see [`test_context_with`].
pub fn test_context(test_name: &str) -> Option<GpuContext> {
    test_context_with(test_name, AdapterChoice::HardwareThenSoftware, &DeviceRequest::default())
}

/// A device for `test_name` as [`acquire`] gives it (the adapter is printed, shown with the
/// test's output when it fails); without one, `None` after the `SKIPPED` line, or a panic
/// when [`require_gpu`] ([`skip_or_fail`]).
pub fn test_context_with(test_name: &str, choice: AdapterChoice, request: &DeviceRequest) -> Option<GpuContext> {
    match acquire(choice, request) {
        Ok(ctx) => {
            eprintln!("{test_name}: GPU test on {}", ctx.info);
            Some(ctx)
        }
        Err(e) => {
            skip_or_fail(test_name, &e);
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_skip_line_names_the_reason_the_test_and_the_variable() {
        assert_eq!(
            skipped_line("runner::gpu::tests::x", &"no adapters on VULKAN"),
            "SKIPPED: no GPU adapter (no adapters on VULKAN): runner::gpu::tests::x; set BLURLAB_REQUIRE_GPU=1 to require one\n"
        );
        let e = crate::GpuError::NoAdapter {
            wanted: AdapterChoice::HardwareThenSoftware,
            backends: "VULKAN".into(),
            filter: String::new(),
            seen: vec![],
        };
        assert_eq!(
            skipped_line("t", &e),
            "SKIPPED: no GPU adapter (looked for a hardware adapter, then a software one on backends VULKAN; adapters seen: none): t; set BLURLAB_REQUIRE_GPU=1 to require one\n"
        );
    }
}
