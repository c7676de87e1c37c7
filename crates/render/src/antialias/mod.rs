//! Antialiasing of a display frame after it is rendered: [`mlaa`], the morphological
//! antialiasing of the thesis's Part II, and [`frame`], which applies what a frame's scene
//! asks for to a rendered frame.

pub mod frame;
pub mod mlaa;
