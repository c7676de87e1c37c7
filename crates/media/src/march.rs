//! The thesis's ray marcher (section 2.3), in f32: the CPU twin of the WGSL passes, sample
//! for sample, and the arithmetic a GPU port must reproduce.
//!
//! A ray in the unit cube's coordinates is cut into segments on a lattice fixed to the ray's
//! origin (the eye): segment `i` is `[i step, (i + 1) step]`, clipped to where the ray is
//! inside the cube, and sampled at its midpoint. Each segment of extinction `sigma` and source
//! `S` adds `T (1 - exp(-sigma l)) S` and attenuates `T` by `exp(-sigma l)`: the exact
//! integral over a segment of constant density. (The thesis's equation 2.4 adds
//! `sigma l exp(-sigma l) S` instead, which agrees for thin steps but goes dark in an opaque
//! medium where `sigma l >> 1`; the exact form keeps opaque smoke at its source radiance.)
//!
//! The source `S` is the lighting model of figure 2.3:
//! - [`LightingModel::AlphaCompositing`]: a constant colour, density as opacity, no lights;
//! - [`LightingModel::PrimaryRays`]: single scattering of every light at full strength,
//!   `albedo / (4 pi) sum_n E_n` (isotropic phase);
//! - [`LightingModel::PrimaryAndShadowRays`]: each light attenuated by a shadow ray marched
//!   from the sample to the cube's face on the same kind of lattice (self-shadowing).
//!
//! The two accelerations change which segments are looked at, never the image: the validity
//! mask ([`first_segment`]) finds the first segment with density above the threshold (none:
//! the pixel is not marched), and the distance map lets primary and shadow rays jump over
//! segments whose density is zero for certain. With a threshold of zero, brute force, mask
//! and mask plus distance map give the same bytes; only the number of density lookups
//! differs, which is what Table 2.1's speed-ups come from.

use glam::Vec3;

use crate::distance::{DistanceMap, TENT_REACH};
use crate::grid::DensityGrid;

/// The cap on distances and skips, in voxels and segments (the WGSL's `NO_LIMIT`).
pub const NO_LIMIT: f32 = 1e9;

/// A pinhole camera in the cube's frame: pixel `(x, y)` looks from `eye` through
/// `corner + (x + 0.5) du + (y + 0.5) dv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelCamera {
    /// The eye.
    pub eye: Vec3,
    /// The image plane's corner (pixel (0, 0)'s outer corner).
    pub corner: Vec3,
    /// One pixel to the right.
    pub du: Vec3,
    /// One pixel down.
    pub dv: Vec3,
}

impl PixelCamera {
    /// A camera at `eye` looking at `target` with vertical field of view `fov_y` (radians)
    /// over `width x height` pixels, y up.
    pub fn look_at(eye: Vec3, target: Vec3, fov_y: f32, width: u32, height: u32) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * fov_y).tan();
        let half_w = half_h * width as f32 / height as f32;
        let du = right * (2.0 * half_w / width as f32);
        let dv = -up * (2.0 * half_h / height as f32);
        let corner = eye + forward - right * half_w + up * half_h;
        Self { eye, corner, du, dv }
    }

    /// The unit direction of pixel `(x, y)`, as the WGSL computes it.
    pub fn ray(&self, x: u32, y: u32) -> Vec3 {
        let target = self.corner + (x as f32 + 0.5) * self.du + (y as f32 + 0.5) * self.dv;
        (target - self.eye).normalize()
    }
}

/// The marcher over a whole image, row by row in parallel: the CPU twin of the two passes.
pub fn march_image(
    medium: &MarchMedium,
    lights: &[MarchLight],
    camera: &PixelCamera,
    (width, height): (u32, u32),
    settings: &MarchSettings,
    use_mask: bool,
) -> Vec<MarchResult> {
    use rayon::prelude::*;
    (0..width * height)
        .into_par_iter()
        .map(|n| march(medium, lights, camera.eye, camera.ray(n % width, n / width), settings, use_mask))
        .collect()
}

/// The lighting models of the thesis's figure 2.3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightingModel {
    /// Back-to-front alpha compositing of a constant colour.
    AlphaCompositing,
    /// Single scattering with primary rays only: no shadowing.
    PrimaryRays,
    /// Single scattering with primary and shadow rays: self-shadowing.
    PrimaryAndShadowRays,
}

/// A light of the constellation, in the cube's frame, f32 as the GPU holds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarchLight {
    /// Unit direction towards the light.
    pub direction: Vec3,
    /// Irradiance at normal incidence (linear RGB).
    pub irradiance: Vec3,
}

/// The medium as the marcher sees it.
#[derive(Debug, Clone, Copy)]
pub struct MarchMedium<'a> {
    /// The density grid.
    pub grid: &'a DensityGrid,
    /// The distance map, for empty-space skipping (`None`: no skipping).
    pub distance: Option<&'a DistanceMap>,
    /// Extinction at density 1, per unit-cube length.
    pub sigma_t: f32,
    /// Single-scattering albedo.
    pub albedo: f32,
    /// The colour of [`LightingModel::AlphaCompositing`].
    pub alpha_colour: Vec3,
    /// The length along rays of one voxel (the shortest of its edges), in the rays' units:
    /// what turns the distance map's voxels into ray lengths. In the unit cube with unit
    /// directions it is `1 / longest side in voxels` ([`MarchMedium::unit_cube_voxel`]).
    pub voxel_length: f32,
}

impl MarchMedium<'_> {
    /// The voxel length of `grid` in the unit cube.
    pub fn unit_cube_voxel(grid: &DensityGrid) -> f32 {
        let dims = grid.dims();
        1.0 / dims[0].max(dims[1]).max(dims[2]) as f32
    }
}

/// The marcher's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarchSettings {
    /// Segment length in unit-cube lengths (primary and shadow rays).
    pub step: f32,
    /// The lighting model.
    pub model: LightingModel,
    /// Density at or below which the validity mask counts a sample as empty.
    pub threshold: f32,
    /// Evaluate the lights (and shadow rays) at segments of zero density too, as the
    /// thesis's shader does (Listing 2.1 lights every slice and weights by the extinction
    /// afterwards); `false` tests the density first. The image is the same either way.
    pub shade_empty: bool,
}

/// One pixel's result.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MarchResult {
    /// Radiance scattered towards the eye (linear RGB).
    pub radiance: Vec3,
    /// Transmittance through the medium: what is behind shows through by this much.
    pub transmittance: f32,
    /// Density lookups on the primary ray (the mask's included when it was used).
    pub primary_lookups: u32,
    /// Density lookups on shadow rays.
    pub shadow_lookups: u32,
}

/// The trilinear density at `p` (unit cube), in f32, in the order the WGSL kernel computes
/// it; zero outside the cube.
pub fn density(grid: &DensityGrid, p: Vec3) -> f32 {
    if !(0.0..=1.0).contains(&p.x) || !(0.0..=1.0).contains(&p.y) || !(0.0..=1.0).contains(&p.z) {
        return 0.0;
    }
    let dims = grid.dims();
    let mut lo = [0usize; 3];
    let mut hi = [0usize; 3];
    let mut t = [0.0f32; 3];
    for a in 0..3 {
        let n = dims[a];
        let g = (p[a] * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
        let f = g.floor();
        lo[a] = f as usize;
        hi[a] = (lo[a] + 1).min(n - 1);
        t[a] = g - f;
    }
    let v = |i: usize, j: usize, k: usize| grid.voxel(i, j, k);
    let x00 = v(lo[0], lo[1], lo[2]) + (v(hi[0], lo[1], lo[2]) - v(lo[0], lo[1], lo[2])) * t[0];
    let x10 = v(lo[0], hi[1], lo[2]) + (v(hi[0], hi[1], lo[2]) - v(lo[0], hi[1], lo[2])) * t[0];
    let x01 = v(lo[0], lo[1], hi[2]) + (v(hi[0], lo[1], hi[2]) - v(lo[0], lo[1], hi[2])) * t[0];
    let x11 = v(lo[0], hi[1], hi[2]) + (v(hi[0], hi[1], hi[2]) - v(lo[0], hi[1], hi[2])) * t[0];
    let y0 = x00 + (x10 - x00) * t[1];
    let y1 = x01 + (x11 - x01) * t[1];
    y0 + (y1 - y0) * t[2]
}

/// The ray's interval inside the unit cube (`t >= 0`), in f32.
pub fn cube_interval(origin: Vec3, direction: Vec3) -> Option<(f32, f32)> {
    let inv = direction.recip();
    let t0 = (Vec3::ZERO - origin) * inv;
    let t1 = (Vec3::ONE - origin) * inv;
    let near = t0.min(t1);
    let far = t0.max(t1);
    let enter = near.x.max(near.y).max(near.z).max(0.0);
    let exit = far.x.min(far.y).min(far.z);
    (exit > enter).then_some((enter, exit))
}

/// How many whole segments the distance map lets a ray skip from `p`: segments wholly
/// inside the empty ball around `p`.
fn skippable(distance: Option<&DistanceMap>, p: Vec3, step: f32, dims: [usize; 3], voxel_length: f32) -> u32 {
    let Some(map) = distance else { return 0 };
    // the GPU cannot hold infinity: both sides cap the empty distance at NO_LIMIT
    // nearest voxel centre, as DistanceMap::skip does, in f32
    let mut off2 = 0.0f32;
    let mut c = [0usize; 3];
    for a in 0..3 {
        let g = p[a] * dims[a] as f32 - 0.5;
        let i = g.round().clamp(0.0, (dims[a] - 1) as f32);
        off2 += (g - i) * (g - i);
        c[a] = i as usize;
    }
    let free_voxels = map.voxel(c[0], c[1], c[2]).min(NO_LIMIT) - off2.sqrt() - TENT_REACH as f32;
    let free = free_voxels * voxel_length;
    // the next segment's whole extent must lie inside the ball: floor(free / step) - 1
    ((free / step).floor() - 1.0).clamp(0.0, NO_LIMIT) as u32
}

/// The segments to skip after a sample of density `rho` at `p`: none inside the medium
/// (where the map's distance is zero anyway, so its lookup is saved).
fn skip_from(medium: &MarchMedium, rho: f32, p: Vec3, step: f32) -> u32 {
    if rho > 0.0 { 0 } else { skippable(medium.distance, p, step, medium.grid.dims(), medium.voxel_length) }
}

/// The segment `i` of a ray clipped to `[enter, exit]`: its midpoint parameter and length.
fn segment(i: u32, step: f32, enter: f32, exit: f32) -> Option<(f32, f32)> {
    let a = (i as f32 * step).max(enter);
    let b = ((i + 1) as f32 * step).min(exit);
    (b > a).then_some((0.5 * (a + b), b - a))
}

/// The validity mask of one pixel: the first segment whose midpoint density is above the
/// threshold, or `None` (the pixel shows no medium). Counts its lookups into `lookups`.
pub fn first_segment(
    medium: &MarchMedium,
    origin: Vec3,
    direction: Vec3,
    settings: &MarchSettings,
    lookups: &mut u32,
) -> Option<u32> {
    first_in(medium, (origin, direction), cube_interval(origin, direction)?, settings, lookups)
}

/// [`first_segment`] over the part `[enter, exit]` of the ray.
fn first_in(
    medium: &MarchMedium,
    (origin, direction): (Vec3, Vec3),
    (enter, exit): (f32, f32),
    settings: &MarchSettings,
    lookups: &mut u32,
) -> Option<u32> {
    let step = settings.step;
    let mut i = (enter / step).floor() as u32;
    while let Some((t, _)) = segment(i, step, enter, exit) {
        let p = origin + t * direction;
        *lookups += 1;
        let rho = density(medium.grid, p);
        if rho > settings.threshold {
            return Some(i);
        }
        i = i.saturating_add(1).saturating_add(skip_from(medium, rho, p, step));
    }
    None
}

/// The transmittance from `p` towards a light in `direction`, by a shadow ray on its own
/// lattice of segments `step` long (the marcher's shadow rays, also what the smoke's shadow
/// on a surface is made of).
pub fn shadow(medium: &MarchMedium, p: Vec3, direction: Vec3, step: f32, lookups: &mut u32) -> f32 {
    let Some((enter, exit)) = cube_interval(p, direction) else { return 1.0 };
    let mut depth = 0.0f32;
    let mut i = (enter / step).floor() as u32;
    while let Some((t, l)) = segment(i, step, enter, exit) {
        let q = p + t * direction;
        *lookups += 1;
        let rho = density(medium.grid, q);
        depth += medium.sigma_t * rho * l;
        i = i.saturating_add(1).saturating_add(skip_from(medium, rho, q, step));
    }
    (-depth).exp()
}

/// Marches one primary ray. `use_mask` runs the validity mask first and starts at its
/// segment; the distance map is used wherever `medium.distance` is given.
pub fn march(
    medium: &MarchMedium,
    lights: &[MarchLight],
    origin: Vec3,
    direction: Vec3,
    settings: &MarchSettings,
    use_mask: bool,
) -> MarchResult {
    march_to(medium, lights, (origin, direction, f32::INFINITY), settings, use_mask)
}

/// Marches one primary ray `(origin, direction, limit)` up to the ray parameter `limit`,
/// where a surface hides what lies behind (the segment that holds it is cut there).
/// `direction` need not be unit length: ray lengths are then in its units.
pub fn march_to(
    medium: &MarchMedium,
    lights: &[MarchLight],
    (origin, direction, limit): (Vec3, Vec3, f32),
    settings: &MarchSettings,
    use_mask: bool,
) -> MarchResult {
    let mut result = MarchResult { transmittance: 1.0, ..MarchResult::default() };
    let Some((enter, exit)) = cube_interval(origin, direction) else { return result };
    let exit = exit.min(limit);
    if exit <= enter {
        return result;
    }
    let step = settings.step;
    let mut i = (enter / step).floor() as u32;
    if use_mask {
        match first_in(medium, (origin, direction), (enter, exit), settings, &mut result.primary_lookups) {
            Some(first) => i = first,
            None => return result,
        }
    }
    let unshadowed: Vec3 =
        lights.iter().map(|l| l.irradiance).sum::<Vec3>() * (medium.albedo / (4.0 * std::f32::consts::PI));
    while let Some((t, l)) = segment(i, step, enter, exit) {
        let p = origin + t * direction;
        result.primary_lookups += 1;
        let rho = density(medium.grid, p);
        let sigma = medium.sigma_t * rho;
        if sigma > 0.0 || settings.shade_empty {
            let source = match settings.model {
                LightingModel::AlphaCompositing => medium.alpha_colour,
                LightingModel::PrimaryRays => unshadowed,
                LightingModel::PrimaryAndShadowRays => {
                    lights
                        .iter()
                        .map(|light| {
                            light.irradiance * shadow(medium, p, light.direction, step, &mut result.shadow_lookups)
                        })
                        .sum::<Vec3>()
                        * (medium.albedo / (4.0 * std::f32::consts::PI))
                }
            };
            let tau = (-sigma * l).exp();
            result.radiance += result.transmittance * (1.0 - tau) * source;
            result.transmittance *= tau;
        }
        i = i.saturating_add(1).saturating_add(skip_from(medium, rho, p, step));
    }
    result
}

/// The surface a composited frame's primary ray ends on, for the smoke's shadow on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The point, in the cube's frame.
    pub point: Vec3,
    /// The surface's unit normal in the world's frame (where the lights' world directions are).
    pub normal: Vec3,
}

/// One pixel's primary ray of a frame whose surfaces come from elsewhere (the tracer): the
/// ray in the cube's frame (its direction need not be unit length; lengths are then in its
/// units), the ray parameter of the first surface ([`NO_LIMIT`]: none, the sky), and that
/// surface where its shadow is wanted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceRay {
    /// Origin, in the cube's frame.
    pub origin: Vec3,
    /// Direction, in the cube's frame.
    pub direction: Vec3,
    /// The ray parameter where a surface hides what lies behind; [`NO_LIMIT`] for none.
    pub limit: f32,
    /// The surface at `limit`, for its shadow (primary and shadow rays only).
    pub surface: Option<SurfacePoint>,
}

/// The smoke's shadow on a surface: the lights' irradiance on it through the medium over
/// that without the medium, per channel, `sum E_n max(0, n.l_n) T_n / sum E_n max(0, n.l_n)`
/// in light order (1 where no light reaches the surface's side). `world_directions[n]` is
/// light `n`'s direction in the world, for the cosine; its shadow ray runs along the light's
/// direction in the cube's frame.
pub fn surface_shadow(
    medium: &MarchMedium,
    lights: &[MarchLight],
    world_directions: &[Vec3],
    surface: &SurfacePoint,
    step: f32,
    lookups: &mut u32,
) -> Vec3 {
    let (mut lit, mut unlit) = (Vec3::ZERO, Vec3::ZERO);
    for (light, world) in lights.iter().zip(world_directions) {
        let cosine = surface.normal.dot(*world);
        if cosine <= 0.0 {
            continue;
        }
        let e = light.irradiance * cosine;
        unlit += e;
        lit += e * shadow(medium, surface.point, light.direction, step, lookups);
    }
    let ratio = |l: f32, u: f32| if u > 0.0 { l / u } else { 1.0 };
    Vec3::new(ratio(lit.x, unlit.x), ratio(lit.y, unlit.y), ratio(lit.z, unlit.z))
}

/// One pixel of a composited frame: the march up to the ray's surface, and the smoke's
/// shadow on that surface (primary and shadow rays with a surface; 1 otherwise). The CPU
/// twin of `march.wgsl` given per-pixel rays.
pub fn march_surface_ray(
    medium: &MarchMedium,
    lights: &[MarchLight],
    world_directions: &[Vec3],
    ray: &SurfaceRay,
    settings: &MarchSettings,
    use_mask: bool,
) -> (MarchResult, Vec3) {
    let mut result = march_to(medium, lights, (ray.origin, ray.direction, ray.limit), settings, use_mask);
    let shadowed = match &ray.surface {
        Some(surface) if settings.model == LightingModel::PrimaryAndShadowRays => {
            surface_shadow(medium, lights, world_directions, surface, settings.step, &mut result.shadow_lookups)
        }
        _ => Vec3::ONE,
    };
    (result, shadowed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::smoke::{SmokeSettings, SmokeSimulation};

    const MODELS: [LightingModel; 3] =
        [LightingModel::AlphaCompositing, LightingModel::PrimaryRays, LightingModel::PrimaryAndShadowRays];

    fn sun() -> Vec<MarchLight> {
        vec![
            MarchLight { direction: Vec3::Y, irradiance: Vec3::new(3.0, 2.5, 2.0) },
            MarchLight { direction: Vec3::new(0.6, 0.0, 0.8), irradiance: Vec3::new(0.2, 0.3, 0.5) },
        ]
    }

    fn medium(grid: &DensityGrid, sigma_t: f32) -> MarchMedium<'_> {
        MarchMedium {
            grid,
            distance: None,
            sigma_t,
            albedo: 0.9,
            alpha_colour: Vec3::splat(0.5),
            voxel_length: MarchMedium::unit_cube_voxel(grid),
        }
    }

    #[test]
    fn no_density_no_medium() {
        let grid = DensityGrid::constant([8, 8, 8], 0.0).unwrap();
        let m = medium(&grid, 10.0);
        for model in MODELS {
            let s = MarchSettings { step: 0.01, model, threshold: 0.0, shade_empty: false };
            let r = march(&m, &sun(), Vec3::new(-0.5, 0.4, 0.5), Vec3::X, &s, false);
            assert_eq!((r.radiance, r.transmittance), (Vec3::ZERO, 1.0));
            // the mask sees nothing and marches nothing
            let r = march(&m, &sun(), Vec3::new(-0.5, 0.4, 0.5), Vec3::X, &s, true);
            assert_eq!((r.radiance, r.transmittance, r.shadow_lookups), (Vec3::ZERO, 1.0, 0));
        }
    }

    #[test]
    fn homogeneous_cube_matches_the_closed_forms() {
        // ray along x at height y through a constant cube, light straight above:
        // T = exp(-sigma), primary: S (1 - T), shadowed: S exp(-sigma (1 - y)) (1 - T)
        let grid = DensityGrid::constant([4, 4, 4], 1.0).unwrap();
        let m = medium(&grid, 2.0);
        let light = [MarchLight { direction: Vec3::Y, irradiance: Vec3::new(4.0, 2.0, 1.0) }];
        let s0 = light[0].irradiance * (0.9 / (4.0 * std::f32::consts::PI));
        let y = 0.3f32;
        for step in [0.37f32, 0.05, 0.003] {
            let run = |model| {
                march(
                    &m,
                    &light,
                    Vec3::new(-0.25, y, 0.5),
                    Vec3::X,
                    &MarchSettings { step, model, threshold: 0.0, shade_empty: false },
                    false,
                )
            };
            let t = (-2.0f32).exp();
            let p = run(LightingModel::PrimaryRays);
            assert!((p.transmittance - t).abs() < 1e-5, "{step}: {}", p.transmittance);
            assert!((p.radiance - s0 * (1.0 - t)).abs().max_element() < 1e-5, "{step}: {}", p.radiance);
            let sh = run(LightingModel::PrimaryAndShadowRays);
            let expected = s0 * (-2.0 * (1.0 - y)).exp() * (1.0 - t);
            assert!((sh.radiance - expected).abs().max_element() < 1e-5, "{step}: {} vs {expected}", sh.radiance);
            let a = run(LightingModel::AlphaCompositing);
            assert!((a.radiance - Vec3::splat(0.5) * (1.0 - t)).abs().max_element() < 1e-5);
        }
    }

    #[test]
    fn a_surface_ray_stops_at_its_surface_and_takes_the_smokes_shadow() {
        // a constant cube; the ray along x at height y ends on a surface at x = 0.4, lit
        // from straight above and from the side (+x, in the surface's plane: no cosine)
        let grid = DensityGrid::constant([4, 4, 4], 1.0).unwrap();
        let m = medium(&grid, 2.0);
        let lights = [
            MarchLight { direction: Vec3::Y, irradiance: Vec3::new(4.0, 2.0, 1.0) },
            MarchLight { direction: Vec3::X, irradiance: Vec3::splat(9.0) },
        ];
        let world = [Vec3::Y, Vec3::X];
        let y = 0.3f32;
        let surface = SurfacePoint { point: Vec3::new(0.4, y, 0.5), normal: Vec3::Y };
        let ray =
            SurfaceRay { origin: Vec3::new(-0.25, y, 0.5), direction: Vec3::X, limit: 0.65, surface: Some(surface) };
        let settings = |model| MarchSettings { step: 0.01, model, threshold: 0.0, shade_empty: false };
        let (r, shadowed) =
            march_surface_ray(&m, &lights, &world, &ray, &settings(LightingModel::PrimaryAndShadowRays), true);
        assert!((r.transmittance - (-2.0f32 * 0.4).exp()).abs() < 1e-5, "{}", r.transmittance);
        // only the light above reaches the surface, through 1 - y of the medium
        assert!((shadowed - Vec3::splat((-2.0 * (1.0 - y)).exp())).abs().max_element() < 1e-5, "{shadowed}");
        for model in [LightingModel::AlphaCompositing, LightingModel::PrimaryRays] {
            assert_eq!(march_surface_ray(&m, &lights, &world, &ray, &settings(model), true).1, Vec3::ONE);
        }
        // no medium: no shadow, exactly
        let empty = DensityGrid::constant([4, 4, 4], 0.0).unwrap();
        let m = medium(&empty, 2.0);
        let (r, shadowed) =
            march_surface_ray(&m, &lights, &world, &ray, &settings(LightingModel::PrimaryAndShadowRays), true);
        assert_eq!((r.radiance, r.transmittance, shadowed), (Vec3::ZERO, 1.0, Vec3::ONE));
        // a surface facing away from every light keeps its radiance
        let away = SurfaceRay { surface: Some(SurfacePoint { normal: -Vec3::Y, ..surface }), ..ray };
        let m = medium(&grid, 2.0);
        assert_eq!(
            march_surface_ray(&m, &lights, &world, &away, &settings(LightingModel::PrimaryAndShadowRays), true).1,
            Vec3::ONE
        );
    }

    #[test]
    fn an_opaque_medium_shows_its_source_not_black() {
        let grid = DensityGrid::constant([2, 2, 2], 1.0).unwrap();
        let m = medium(&grid, 1e6);
        let r = march(
            &m,
            &sun(),
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::Z,
            &MarchSettings { step: 0.1, model: LightingModel::PrimaryRays, threshold: 0.0, shade_empty: false },
            true,
        );
        let s: Vec3 = sun().iter().map(|l| l.irradiance).sum::<Vec3>() * (0.9 / (4.0 * std::f32::consts::PI));
        assert_eq!(r.transmittance, 0.0);
        assert!((r.radiance - s).abs().max_element() < 1e-6, "{} vs {s}", r.radiance);
    }

    #[test]
    fn accelerations_change_the_work_not_the_image() {
        let mut sim =
            SmokeSimulation::new(SmokeSettings { resolution: [24, 32, 24], ..SmokeSettings::default() }).unwrap();
        for _ in 0..25 {
            sim.step();
        }
        let grid = sim.density();
        let map = DistanceMap::new(&grid, 0.0);
        let plain = medium(&grid, 30.0);
        let skipping = MarchMedium { distance: Some(&map), ..plain };
        let eye = Vec3::new(0.5, 0.5, -1.5);
        for model in MODELS {
            let s = MarchSettings { step: 1.0 / 64.0, model, threshold: 0.0, shade_empty: false };
            let (mut brute_work, mut fast_work, mut lit) = (0u64, 0u64, 0);
            for py in 0..24 {
                for px in 0..24 {
                    let target = Vec3::new(px as f32 / 23.0, py as f32 / 23.0, 0.5);
                    let d = (target - eye).normalize();
                    let brute = march(&plain, &sun(), eye, d, &s, false);
                    let masked = march(&plain, &sun(), eye, d, &s, true);
                    let both = march(&skipping, &sun(), eye, d, &s, true);
                    let thesis = march(&skipping, &sun(), eye, d, &MarchSettings { shade_empty: true, ..s }, true);
                    assert_eq!((thesis.radiance, thesis.transmittance), (both.radiance, both.transmittance));
                    assert_eq!((brute.radiance, brute.transmittance), (masked.radiance, masked.transmittance));
                    assert_eq!(
                        (brute.radiance, brute.transmittance),
                        (both.radiance, both.transmittance),
                        "{model:?} ({px}, {py})"
                    );
                    brute_work += u64::from(brute.primary_lookups + brute.shadow_lookups);
                    fast_work += u64::from(both.primary_lookups + both.shadow_lookups);
                    lit += usize::from(brute.transmittance < 1.0);
                }
            }
            assert!(lit > 20, "the plume should be in view ({lit} pixels)");
            // shadow rays start inside the plume, where nothing can be skipped
            let least = if model == LightingModel::PrimaryAndShadowRays { 1.3 } else { 2.0 };
            assert!(fast_work as f64 * least < brute_work as f64, "{model:?}: {fast_work} lookups vs {brute_work}");
        }
    }

    #[test]
    fn a_one_voxel_grid_is_a_constant_cube() {
        let grid = DensityGrid::constant([1, 1, 1], 0.5).unwrap();
        let m = medium(&grid, 4.0);
        let s = MarchSettings { step: 0.07, model: LightingModel::PrimaryRays, threshold: 0.0, shade_empty: false };
        let r = march(&m, &sun(), Vec3::new(0.5, -1.0, 0.5), Vec3::Y, &s, true);
        assert!((r.transmittance - (-2.0f32).exp()).abs() < 1e-6, "{}", r.transmittance);
    }

    #[test]
    fn a_thin_wisp_is_missed_by_long_steps_and_caught_by_short_ones() {
        // a sheet one voxel thick (of 64) across the ray: a step of several voxels samples
        // it where it happens to land, a step of a quarter voxel integrates it
        let n = 64;
        let data = (0..n * n * n).map(|v| if v % n == 40 { 1.0 } else { 0.0 }).collect();
        let grid = DensityGrid::new([n, n, n], data).unwrap();
        let m = medium(&grid, 60.0);
        let light = [MarchLight { direction: Vec3::Y, irradiance: Vec3::splat(100.0) }];
        let depth = |step: f32, start: f32| {
            let s = MarchSettings { step, model: LightingModel::PrimaryRays, threshold: 0.0, shade_empty: false };
            let r = march(&m, &light, Vec3::new(start, 0.5, 0.5), Vec3::X, &s, false);
            -r.transmittance.ln()
        };
        // the sheet's optical depth: its tent integrates to one voxel's width
        let exact = 60.0 / n as f32;
        for start in [-0.013f32, -0.02, -0.031] {
            assert!((depth(0.25 / n as f32, start) - exact).abs() < 0.02 * exact, "{}", depth(0.25 / n as f32, start));
        }
        let coarse: Vec<f32> = [-0.013f32, -0.02, -0.031, -0.04].iter().map(|s| depth(4.0 / n as f32, *s)).collect();
        let worst = coarse.iter().map(|d| (d - exact).abs() / exact).fold(0.0, f32::max);
        assert!(worst > 0.5, "four-voxel steps should misjudge the sheet badly somewhere: {coarse:?} vs {exact}");
    }

    #[test]
    fn an_empty_hole_is_skipped_and_costs_its_chord() {
        // a constant cube with a spherical hole of radius 0.3 in the middle
        let n = 48;
        let data = (0..n * n * n)
            .map(|v| {
                let c = Vec3::new((v % n) as f32, ((v / n) % n) as f32, (v / (n * n)) as f32) + 0.5;
                if (c / n as f32 - Vec3::splat(0.5)).length() < 0.3 { 0.0 } else { 1.0 }
            })
            .collect();
        let grid = DensityGrid::new([n, n, n], data).unwrap();
        let map = DistanceMap::new(&grid, 0.0);
        let plain = medium(&grid, 3.0);
        let skipping = MarchMedium { distance: Some(&map), ..plain };
        let s = MarchSettings {
            step: 0.25 / n as f32,
            model: LightingModel::PrimaryRays,
            threshold: 0.0,
            shade_empty: false,
        };
        let brute = march(&plain, &sun(), Vec3::new(-0.5, 0.5, 0.5), Vec3::X, &s, false);
        let fast = march(&skipping, &sun(), Vec3::new(-0.5, 0.5, 0.5), Vec3::X, &s, true);
        assert_eq!((brute.radiance, brute.transmittance), (fast.radiance, fast.transmittance));
        assert!(fast.primary_lookups < brute.primary_lookups, "{} vs {}", fast.primary_lookups, brute.primary_lookups);
        // through the centre the medium is as long as the voxels that are not hole: the
        // sphere's chord, 0.6, as the voxels draw it (the four rows around the ray agree)
        let hole = (0..n).filter(|i| grid.voxel(*i, n / 2, n / 2) == 0.0).count() as f32 / n as f32;
        assert!((hole - 0.6).abs() < 0.03, "{hole}");
        let expected = (-3.0 * (1.0 - hole)).exp();
        assert!((brute.transmittance - expected).abs() < 1e-3 * expected, "{} vs {expected}", brute.transmittance);
    }

    #[test]
    fn f32_density_agrees_with_the_f64_reference() {
        let mut sim =
            SmokeSimulation::new(SmokeSettings { resolution: [8, 12, 8], ..SmokeSettings::default() }).unwrap();
        for _ in 0..6 {
            sim.step();
        }
        let grid = sim.density();
        for n in 0..500 {
            let p = glam::DVec3::new((n % 10) as f64 / 9.0, ((n / 10) % 10) as f64 / 9.3, (n / 100) as f64 / 4.1);
            let a = density(&grid, p.as_vec3());
            let b = grid.density(p);
            assert!((f64::from(a) - b).abs() < 1e-5 * (1.0 + b), "{p}: {a} vs {b}");
        }
    }
}
