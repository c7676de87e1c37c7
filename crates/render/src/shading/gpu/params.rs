//! What the GPU tracer's kernel reads, built on the CPU once per eye and frame: the frame's
//! parameters ([`FrameParams`], one storage struct, f32 and u32 only), the environment's
//! tables as one u32 buffer ([`EnvTables`]), a batch of samples ([`Batch`]) and the
//! kernel's specialisation ([`Specialisation`], its pipeline override constants). The CPU
//! twin ([`super::radiance`]) reads exactly the same values.
//!
//! Everything that needs f64 to be right is done here, in f64, and handed over as f32
//! offsets small enough that f32 keeps them exact to well below a pixel: the sphere's centre
//! at the shutter's opening (wrapped onto its path), its displacement over the shutter and,
//! when the path wraps during the exposure, the fraction of the shutter at which it does and
//! the jump it makes; its orientation at the opening as a matrix and its spin over the
//! shutter as an angle about a fixed axis.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use study::scene::{EyeView, FrameScene, Material};
use study::seed::splitmix64;

use super::sampler32::eye_seed32;
use crate::env::EnvironmentMap;
use crate::shading::camera::CameraRays;

/// Material kinds, the values of the `MATERIAL` override constant.
pub mod material_kind {
    /// Constant albedo.
    pub const FLAT: u32 = 0;
    /// Checker over longitude and latitude.
    pub const CHECKER: u32 = 1;
    /// Band-limited noise.
    pub const NOISE: u32 = 2;
}

/// The kernel's specialisation: the pipeline override constants `TIME_SAMPLING`,
/// `MATERIAL` and `PIXEL_JITTER`. A frame gets the cheapest kernel that renders it ([`Specialisation::of`]);
/// forcing a more general one renders the same image at more cost (which is how the saving
/// is measured, and tested).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Specialisation {
    /// Each sample draws a time in the shutter and moves the sphere there.
    pub time_sampling: bool,
    /// One of [`material_kind`].
    pub material: u32,
    /// Camera samples are jittered within the pixel (false: all through its centre).
    pub pixel_jitter: bool,
}

impl Specialisation {
    /// The cheapest kernel for `scene`: time sampling only for an open shutter with motion,
    /// texture code only for the material the scene has.
    pub fn of(scene: &FrameScene) -> Self {
        Specialisation {
            time_sampling: scene.needs_time_sampling(),
            material: material_kind_of(&scene.material),
            pixel_jitter: scene.pixel_jitter,
        }
    }

    /// The override constants as wgpu takes them.
    pub fn constants(&self) -> [(&'static str, f64); 3] {
        [
            ("TIME_SAMPLING", if self.time_sampling { 1.0 } else { 0.0 }),
            ("MATERIAL", f64::from(self.material)),
            ("PIXEL_JITTER", if self.pixel_jitter { 1.0 } else { 0.0 }),
        ]
    }
}

fn material_kind_of(material: &Material) -> u32 {
    match material {
        Material::Flat { .. } => material_kind::FLAT,
        Material::Checker { .. } => material_kind::CHECKER,
        Material::Noise { .. } => material_kind::NOISE,
    }
}

/// One eye of one frame, as the kernel reads it (`struct FrameParams` in `radiance.wgsl`,
/// field for field). Vectors are `[x, y, z, extra]` with the extra component named.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameParams {
    /// Camera position; w: the angle one pixel subtends (radians).
    pub cam_origin: [f32; 4],
    /// Unnormalised direction through the image's top-left corner.
    pub cam_corner: [f32; 4],
    /// Step of one pixel right.
    pub cam_step_x: [f32; 4],
    /// Step of one pixel down.
    pub cam_step_y: [f32; 4],
    /// Sphere centre at the shutter's opening; w: radius.
    pub centre_open: [f32; 4],
    /// Displacement of the centre over the whole shutter; w: the shutter fraction from
    /// which the path has wrapped (2 when it does not wrap during the exposure).
    pub travel: [f32; 4],
    /// Displacement added once the path has wrapped; w: floor height.
    pub wrap_jump: [f32; 4],
    /// World-to-object rotation at the opening, by rows.
    pub w2o_row0: [f32; 4],
    /// Second row.
    pub w2o_row1: [f32; 4],
    /// Third row.
    pub w2o_row2: [f32; 4],
    /// Unit spin axis (world); w: the spin angle over the whole shutter (radians).
    pub spin: [f32; 4],
    /// First albedo; w: checker squares around, or noise base frequency.
    pub albedo_a: [f32; 4],
    /// Second albedo; w: checker squares from pole to pole.
    pub albedo_b: [f32; 4],
    /// Floor albedo; w: 1 / samples per pixel (each sample is added pre-divided).
    pub floor_albedo: [f32; 4],
    /// Image width in pixels.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The eye's 32-bit seed ([`eye_seed32`]).
    pub eye_seed: u32,
    /// Scattering events at most.
    pub max_bounces: u32,
    /// Scattering event from which Russian roulette applies.
    pub russian_roulette_from: u32,
    /// Noise octaves.
    pub octaves: u32,
    /// Noise lattice seed (`splitmix64(seed) as u32`, as the CPU shader).
    pub noise_seed: u32,
    /// Environment width in pixels.
    pub env_width: u32,
    /// Environment height.
    pub env_height: u32,
    /// log2 of the pixels per side of a distribution cell.
    pub env_cell_shift: u32,
    /// Distribution width in cells.
    pub env_dist_width: u32,
    /// Distribution height in cells.
    pub env_dist_height: u32,
    /// 1 when the map can be importance sampled.
    pub env_samplable: u32,
    /// Marginal table: guide entries, guide shift, stride (u16 entries).
    pub marginal_guide_len: u32,
    /// See `marginal_guide_len`.
    pub marginal_guide_shift: u32,
    /// See `marginal_guide_len`.
    pub marginal_stride: u32,
    /// Conditional tables: guide entries, guide shift, stride.
    pub rows_guide_len: u32,
    /// See `rows_guide_len`.
    pub rows_guide_shift: u32,
    /// See `rows_guide_len`.
    pub rows_stride: u32,
    /// Word offsets in the environment buffer ([`EnvTables`]).
    pub off_row_edge_cos: u32,
    /// See `off_row_edge_cos`.
    pub off_col_edge: u32,
    /// See `off_row_edge_cos`.
    pub off_row_bins: u32,
    /// See `off_row_edge_cos`.
    pub off_col_bins: u32,
    /// See `off_row_edge_cos`.
    pub off_marginal: u32,
    /// See `off_row_edge_cos`.
    pub off_rows: u32,
    /// World-from-map rotation about +y: cosine.
    pub env_rot_cos: f32,
    /// And sine.
    pub env_rot_sin: f32,
    /// Padding to a multiple of 16 bytes.
    pub pad: [u32; 1],
}

/// A range of sample indices, one dispatch (`struct Batch` in `radiance.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct Batch {
    /// First sample index.
    pub first_sample: u32,
    /// Samples in the batch.
    pub count: u32,
    /// Padding (uniform structs are 16-byte sized).
    pub pad: [u32; 2],
}

/// One pixel's accumulator (`struct Accum` in `radiance.wgsl`): the sum of its samples'
/// radiance, each divided by the samples per pixel, and the count of discarded samples.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Accum {
    /// Radiance sum over samples (pre-divided: after all batches, the pixel's mean).
    pub sum: [f32; 3],
    /// Samples whose radiance was NaN or infinite.
    pub nonfinite: u32,
}

/// The environment's tables as one buffer of u32 words (f32 values as their bits), laid
/// out as [`FrameParams`]'s offsets say: texels (RGB, from word 0), row edge cosines,
/// column edge (sine, cosine) pairs, row and column search bins, and the marginal and
/// conditional 16-bit tables, two entries a word (low half first).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvTables {
    /// The words.
    pub words: Vec<u32>,
    /// The [`FrameParams`] fields that describe them (environment fields only).
    layout: EnvLayout,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct EnvLayout {
    width: u32,
    height: u32,
    cell_shift: u32,
    dist_width: u32,
    dist_height: u32,
    samplable: u32,
    marginal: (u32, u32, u32),
    rows: (u32, u32, u32),
    offsets: [u32; 6],
    rot: (f32, f32),
}

fn push_u16(words: &mut Vec<u32>, table: &[u16]) {
    words.extend(table.chunks(2).map(|c| u32::from(c[0]) | u32::from(*c.get(1).unwrap_or(&0)) << 16));
}

impl EnvTables {
    /// The tables of `env`.
    pub fn new(env: &EnvironmentMap) -> Self {
        let t = env.tables();
        let mut words: Vec<u32> = t.texels.iter().flat_map(|p| p.map(f32::to_bits)).collect();
        let mut offsets = [0u32; 6];
        offsets[0] = words.len() as u32;
        words.extend(t.row_edge_cos.iter().map(|&c| (c as f32).to_bits()));
        offsets[1] = words.len() as u32;
        words.extend(t.col_edge.iter().flat_map(|&(s, c)| [(s as f32).to_bits(), (c as f32).to_bits()]));
        offsets[2] = words.len() as u32;
        words.extend_from_slice(t.row_bins);
        offsets[3] = words.len() as u32;
        words.extend_from_slice(t.col_bins);
        offsets[4] = words.len() as u32;
        push_u16(&mut words, t.marginal.table());
        offsets[5] = words.len() as u32;
        push_u16(&mut words, t.rows.table());
        let cdf = |c: &crate::env::Cdf16| {
            let (len, shift) = c.guide();
            (len as u32, shift, c.stride() as u32)
        };
        let layout = EnvLayout {
            width: t.width,
            height: t.height,
            cell_shift: t.cell_shift,
            dist_width: t.dist_width,
            dist_height: t.dist_height,
            samplable: u32::from(t.samplable),
            marginal: cdf(t.marginal),
            rows: cdf(t.rows),
            offsets,
            rot: (t.rot_cos as f32, t.rot_sin as f32),
        };
        debug_assert_eq!(t.marginal.width(), t.dist_height as usize);
        EnvTables { words, layout }
    }

    /// Size in bytes.
    pub fn byte_len(&self) -> u64 {
        4 * self.words.len() as u64
    }
}

/// Why a frame cannot be handed to the GPU kernel.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamsError {
    /// The sphere's path wraps more than once during one exposure.
    #[error(
        "the sphere travels {travel} m during the shutter, more than its path's wrap length {wrap} m; the GPU tracer handles one wrap per exposure"
    )]
    WrapsTwice {
        /// Distance over the shutter.
        travel: f64,
        /// Wrap length.
        wrap: f64,
    },
    /// The scene has a participating medium, which only the f64 reference tracer renders.
    #[error(
        "the scene has a participating medium (the design's [medium]); the f32 tracer (GPU kernel and wide CPU tracer) does not render media: use --device cpu-reference"
    )]
    Medium,
    /// The image has no pixels or is too large to index with u32.
    #[error("image {width}x{height}: the GPU tracer needs 1 to 2^32 - 1 pixels")]
    ImageSize {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

impl FrameParams {
    /// The parameters of eye `view` of `scene`, with the environment described by `env`.
    pub fn new(scene: &FrameScene, view: &EyeView, env: &EnvTables) -> Result<Self, ParamsError> {
        if scene.medium.is_some() {
            return Err(ParamsError::Medium);
        }
        let cam = &view.camera;
        let (width, height) = (cam.width, cam.height);
        if width == 0 || height == 0 || u64::from(width) * u64::from(height) > u64::from(u32::MAX) {
            return Err(ParamsError::ImageSize { width, height });
        }
        let rays = CameraRays::new(cam);
        let s = &scene.sphere;
        let open = scene.shutter.open;
        let duration = scene.shutter.duration();
        let speed = s.speed();
        let centre_open = s.centre_at(open);
        let travel = s.velocity * duration;
        let (mut wrap_from, mut wrap_jump) = (2.0, DVec3::ZERO);
        if let Some(length) = s.wrap_length.filter(|l| *l > 0.0)
            && speed > 0.0
            && duration > 0.0
        {
            let distance = speed * duration;
            if distance >= length {
                return Err(ParamsError::WrapsTwice { travel: distance, wrap: length });
            }
            let travelled = (speed * open).rem_euclid(length);
            let left = length - travelled;
            if left <= distance {
                wrap_from = left / distance;
                wrap_jump = -s.velocity / speed * length;
            }
        }
        let w2o = s.orientation_at(open).inverse();
        let m = glam::DMat3::from_quat(w2o);
        let omega = s.angular_velocity();
        let rate = omega.length();
        let axis = if rate > 0.0 { omega / rate } else { DVec3::Y };
        let (a, b, p0, p1, octaves, noise_seed) = match &scene.material {
            Material::Flat { albedo } => (*albedo, *albedo, 0.0, 0.0, 0, 0),
            Material::Checker { albedo_a, albedo_b, squares_around, squares_pole_to_pole } => {
                (*albedo_a, *albedo_b, f64::from(*squares_around), f64::from(*squares_pole_to_pole), 0, 0)
            }
            Material::Noise { albedo_a, albedo_b, base_frequency, octaves, seed } => {
                (*albedo_a, *albedo_b, *base_frequency, 0.0, *octaves, splitmix64(*seed) as u32)
            }
        };
        let l = &env.layout;
        let spp = scene.samples_per_pixel.max(1);
        Ok(FrameParams {
            cam_origin: v4(cam.position, rays.pixel_angle),
            cam_corner: v4(rays.corner(), 0.0),
            cam_step_x: v4(rays.step_x(), 0.0),
            cam_step_y: v4(rays.step_y(), 0.0),
            centre_open: v4(centre_open, s.radius),
            travel: v4(travel, wrap_from),
            wrap_jump: v4(wrap_jump, scene.floor.height),
            w2o_row0: v4(m.row(0), 0.0),
            w2o_row1: v4(m.row(1), 0.0),
            w2o_row2: v4(m.row(2), 0.0),
            spin: v4(axis, rate * duration),
            albedo_a: v4(DVec3::from_array(a), p0),
            albedo_b: v4(DVec3::from_array(b), p1),
            floor_albedo: v4(DVec3::from_array(scene.floor.albedo), 1.0 / f64::from(spp)),
            width,
            height,
            eye_seed: eye_seed32(view.seed),
            max_bounces: scene.integrator.max_bounces,
            russian_roulette_from: scene.integrator.russian_roulette_from,
            octaves,
            noise_seed,
            env_width: l.width,
            env_height: l.height,
            env_cell_shift: l.cell_shift,
            env_dist_width: l.dist_width,
            env_dist_height: l.dist_height,
            env_samplable: l.samplable,
            marginal_guide_len: l.marginal.0,
            marginal_guide_shift: l.marginal.1,
            marginal_stride: l.marginal.2,
            rows_guide_len: l.rows.0,
            rows_guide_shift: l.rows.1,
            rows_stride: l.rows.2,
            off_row_edge_cos: l.offsets[0],
            off_col_edge: l.offsets[1],
            off_row_bins: l.offsets[2],
            off_col_bins: l.offsets[3],
            off_marginal: l.offsets[4],
            off_rows: l.offsets[5],
            env_rot_cos: l.rot.0,
            env_rot_sin: l.rot.1,
            pad: [0; 1],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_that_wraps_twice_in_one_exposure_is_refused_by_name() {
        let design = study::design::Design::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml"),
        )
        .unwrap();
        let mut scene = design.frame_scene(&"M3-S3-T5-A1".parse().unwrap(), 10).unwrap();
        let env = EnvTables::new(&EnvironmentMap::from_lighting(&scene.lighting).unwrap());
        assert!(FrameParams::new(&scene, &scene.views[0], &env).is_ok());
        scene.sphere.wrap_length = Some(0.01);
        let e = FrameParams::new(&scene, &scene.views[0], &env).unwrap_err();
        assert!(matches!(e, ParamsError::WrapsTwice { .. }), "{e}");
        let text = e.to_string();
        assert!(
            text.contains("more than its path's wrap length 0.01 m") && text.contains("one wrap per exposure"),
            "{text}"
        );
    }

    #[test]
    fn the_struct_is_a_whole_number_of_vec4s() {
        assert_eq!(std::mem::size_of::<FrameParams>() % 16, 0);
        assert_eq!(std::mem::size_of::<FrameParams>(), 14 * 16 + 28 * 4);
        assert_eq!(std::mem::size_of::<Accum>(), 16);
    }
}
