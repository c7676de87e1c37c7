//! Antialiasing of a display frame after it is rendered: [`mlaa`], the morphological
//! antialiasing of the thesis's Part II.

pub mod mlaa;
