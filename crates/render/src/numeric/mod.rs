//! One home for the renderer's numerics, after pbrt-v4's `util/math.h`: error-free
//! transforms and the difference of products ([`eft`]), robust quadratic roots
//! ([`quadratic`]), ray-origin offsets ([`offset`]), compensated summation ([`sum`]) and the
//! tracer's trigonometry of angles in turns ([`trig`]).
//!
//! Every helper has an f64 version (the CPU reference tracer, the analytic rasterizer) and
//! an f32 version (the GPU kernels' CPU twins). The WGSL versions are in
//! `crates/gpu/shaders/numeric.wgsl`; `render/tests/numeric_wgsl.rs` compares them with
//! these. Each is tested here against an f64 or double-double reference on random inputs,
//! cancellation cases included.

pub mod eft;
pub mod offset;
pub mod quadratic;
pub mod sum;
pub mod trig;

pub use eft::{difference_of_products, difference_of_products_f32, two_product, two_sum, two_sum_f32};
pub use offset::{gamma_f32, next_float_down_f32, next_float_up_f32, offset_along_normal, offset_ray_origin_f32};
pub use quadratic::{solve_quadratic, solve_quadratic_f32};
pub use sum::{CompensatedSum, CompensatedSumF32};
