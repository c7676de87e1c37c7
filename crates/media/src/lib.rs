//! Participating media for blurlab, after Part I of the thesis (Navarro 2011, chapter 2):
//! the data a medium is made of and the precomputations its renderers share.
//!
//! - [`grid`]: a density grid (one per frame), its trilinear lookup and validation;
//! - [`grid_file`]: the raw grid file format (`blurlab-grid/1`) a user brings grids in;
//! - [`smoke`]: a seeded, deterministic stable-fluids smoke simulation (Stam 1999, with
//!   buoyancy and vorticity confinement after Fedkiw et al. 2001) that makes grid sequences;
//! - [`distance`]: the view-independent distance map (each voxel's distance to the nearest
//!   non-empty voxel) that lets a ray marcher skip empty space;
//! - [`constellation`]: an environment map turned into N directional lights by median cut
//!   (Debevec 2005), energy conserved;
//! - [`tracking`]: delta and ratio tracking through a grid (or any [`Medium`]), for the
//!   unbiased reference;
//! - [`scatter`]: the reference's light transport in a medium (single or multiple
//!   scattering under a sky, next-event estimated);
//! - [`shutter`]: motion blur of a medium (grids interpolated in time; the reference's
//!   blended lookups, the marcher's accumulation buffer over sub-frames);
//! - [`march`]: the thesis's ray marcher (three lighting models, validity mask, distance
//!   map) in f32, the CPU twin of its WGSL passes;
//! - [`gpu`]: those passes on the GPU (`march.wgsl`);
//! - [`bench`]: the thesis's Table 2.1 redone (each lighting model and acceleration).
//!
//! The crate knows nothing of the scene: the renderer places a grid in the world, turns its
//! rays into the cube's frame and composes what the marcher returns with the rest.

pub mod bench;
pub mod constellation;
pub mod distance;
pub mod gpu;
pub mod grid;
pub mod grid_file;
pub mod march;
pub mod scatter;
pub mod shutter;
pub mod smoke;
pub mod tracking;

pub use constellation::{Constellation, DirectionalLight, LatLongMap};
pub use distance::DistanceMap;
pub use grid::{DensityGrid, GridError};
pub use march::{LightingModel, MarchLight, MarchMedium, MarchResult, MarchSettings, PixelCamera};
pub use smoke::{SmokeSettings, SmokeSimulation};
pub use tracking::{ConstantSphere, GridMedium, Medium};
