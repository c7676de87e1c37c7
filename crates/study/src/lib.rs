//! blurlab's domain model, shared by the renderer, the experiment runner and the analysis:
//! stimulus ids and seeds, the scene of a stimulus at any time, manifests of rendered sets,
//! response logs, durable file writing, the sRGB curve and small statistics. It renders nothing and shows nothing.

pub mod color;
pub mod cost;
pub mod design;
pub mod experiment;
pub mod fsio;
pub mod ids;
pub mod lock;
pub mod manifest;
pub mod medium;
pub mod method;
pub mod response;
pub mod scene;
pub mod seed;
pub mod select;
pub mod stats;
pub mod testing;
pub mod toml_locate;

pub use ids::{Factor, StimulusId, View};
pub use method::Method;
pub use seed::Eye;

/// The version of blurlab recorded in every file it writes.
pub const SOFTWARE_VERSION: &str = env!("CARGO_PKG_VERSION");
