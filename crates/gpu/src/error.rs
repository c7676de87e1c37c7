//! [`GpuError`]: everything the gpu crate reports, each naming what was looked for or where.

use crate::device::AdapterChoice;

/// An error of device acquisition, readback, timing or WGSL assembly.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter fits the request.
    #[error(
        "no GPU adapter: looked for {wanted} on backends {backends}{filter}; adapters seen: {}",
        seen_list(.seen)
    )]
    NoAdapter {
        /// The kinds of adapter that were acceptable.
        wanted: AdapterChoice,
        /// The backends the instance enumerated (`WGPU_BACKEND` chooses them).
        backends: String,
        /// `", named like \"...\""` when `WGPU_ADAPTER_NAME` narrowed the choice, else empty.
        filter: String,
        /// Every adapter the instance found, with why it was passed over.
        seen: Vec<String>,
    },
    /// The adapter refused the device request.
    #[error("requesting a device from adapter {adapter}: {source}")]
    RequestDevice {
        /// The adapter asked.
        adapter: String,
        /// wgpu's reason.
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// A readback was asked for something that cannot be read back as asked.
    #[error("reading back {what}: {message}")]
    Readback {
        /// The buffer or texture, by size (and format).
        what: String,
        /// What is wrong.
        message: String,
    },
    /// Mapping a staging buffer failed.
    #[error("mapping the staging buffer of {what}: {source}")]
    Map {
        /// The buffer or texture read back.
        what: String,
        /// wgpu's reason.
        #[source]
        source: wgpu::BufferAsyncError,
    },
    /// Waiting for the device failed (device lost, timeout).
    #[error("waiting for the GPU ({what}): {source}")]
    Poll {
        /// What was waited for.
        what: String,
        /// wgpu's reason.
        #[source]
        source: wgpu::PollError,
    },
    /// wgpu reported a validation error for commands this crate recorded.
    #[error("GPU validation error in {what}: {message}")]
    Validation {
        /// What was recorded.
        what: String,
        /// wgpu's message.
        message: String,
    },
    /// A `//! include` line that cannot be resolved.
    #[error("{file}:{line}: {message}")]
    Include {
        /// The WGSL file holding the line.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong (unknown name, with the names known; malformed line).
        message: String,
    },
    /// A typed constant that cannot be emitted.
    #[error("WGSL constant {name}: {message}")]
    Constant {
        /// The constant's name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// Assembled WGSL that naga does not parse or validate.
    #[error("WGSL {file} does not compile:\n{message}")]
    Wgsl {
        /// The file assembled.
        file: String,
        /// naga's diagnostic.
        message: String,
    },
}

fn seen_list(seen: &[String]) -> String {
    if seen.is_empty() { "none".to_owned() } else { seen.join("; ") }
}
