//! The scene's participating medium for the renderers (issue 27): its grids, built once per
//! process for a render ([`grids`]: the smoke simulated, or the user's files read), and the
//! medium placed in the world as the tracer sees it at one instant ([`world`]).
//!
//! A scene without a medium never reaches this module: the tracers test
//! `FrameScene::medium` once per frame and run no volume code without one.

pub mod grids;
pub mod world;

pub use grids::{MediumGrids, VolumeError, grids_for};
pub use world::WorldMedium;
