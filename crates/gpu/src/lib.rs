//! blurlab's GPU house, below the renderer and the runner (neither depends on the other; both
//! depend on this crate):
//!
//! - [`acquire`]: a wgpu device from the best adapter, hardware (discrete, integrated,
//!   virtual) before software (Mesa's lavapipe "llvmpipe"), as an [`AdapterChoice`] allows;
//!   optional features (the timestamp queries) requested only where offered and limits
//!   clamped to what the adapter offers ([`DeviceRequest`]). `WGPU_BACKEND` and
//!   `WGPU_ADAPTER_NAME` narrow the search. The result is a [`GpuContext`] with a
//!   [`GpuInfo`] describing the adapter.
//! - Readback of buffers ([`read_buffer`], [`read_buffer_as`]) and textures
//!   ([`read_texture`], any single-plane format with 1x1 texel blocks, the 256-byte row
//!   alignment of copies handled).
//! - [`GpuTimer`]: GPU time of a compute or render pass, of an encoder's commands, or of the
//!   dispatches inside a pass, from timestamp queries where the device has them and from the
//!   wall clock (submit to completion) otherwise; every [`GpuTiming`] says which
//!   ([`TimingSource`]).
//! - [`WgslAssembler`]: WGSL from shared include files (`shaders/*.wgsl`, compiled into the
//!   binary and listed in [`INCLUDES`]) resolved from `//! include NAME` lines, plus typed
//!   constants emitted as `const` declarations with exact literals; [`validate_wgsl`] checks
//!   the result with naga on the CPU.
//! - [`storage_entry`] and [`uniform_entry`]: the bind-group layout entries every compute
//!   kernel's buffers use.
//! - [`GpuContext::run_kernel`]: a one-shot compute kernel over an input and an output
//!   storage buffer, read back (the shape of every twin test).
//! - The one rule for GPU tests: [`test_context`] returns a device or, without one, prints
//!   `SKIPPED: no GPU adapter (...)` to the process's stderr (visible in plain `cargo test`
//!   output), unless `BLURLAB_REQUIRE_GPU=1` ([`require_gpu`]), where it panics instead.
//!
//! The crate re-exports [`wgpu`], the single wgpu version of the workspace (the one eframe
//! uses), so its types are the ones the window shares.

mod device;
mod error;
mod kernel;
mod layout;
mod readback;
mod testing;
mod timer;
mod wgsl;

pub use device::{AdapterChoice, DeviceRequest, GpuContext, GpuInfo, TIMESTAMP_FEATURES, acquire, adapter_infos};
pub use error::GpuError;
pub use layout::{storage_entry, uniform_entry};
pub use readback::{read_buffer, read_buffer_as, read_texture};
pub use testing::{REQUIRE_GPU_ENV, require_gpu, skip_or_fail, test_context, test_context_with};
pub use timer::{GpuTimer, GpuTiming, TimingSource};
pub use wgpu;
pub use wgsl::{INCLUDES, WgslAssembler, validate_wgsl};
