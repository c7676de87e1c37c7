//! One module per subcommand; each has clap `Args` and a `run` function.

pub mod analyze;
pub mod bench;
pub mod cost;
pub mod demo;
pub mod predict;
pub mod render_frame;
pub mod run;
pub mod stats;
pub mod stimuli;

/// Exit codes: 1 for any failure, 2 for bad input (usage, design or data files), 3 for
/// output that could not be written (unwritable folder or file system, full disk).
pub fn exit_code(error: &anyhow::Error) -> u8 {
    for cause in error.chain() {
        if let Some(io) = cause.downcast_ref::<std::io::Error>()
            && matches!(
                io.kind(),
                std::io::ErrorKind::PermissionDenied
                    | std::io::ErrorKind::ReadOnlyFilesystem
                    | std::io::ErrorKind::StorageFull
            )
        {
            return 3;
        }
        if cause.downcast_ref::<BadInput>().is_some() {
            return 2;
        }
    }
    1
}

/// Marks an error as caused by bad user input (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);
