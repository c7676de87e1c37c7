//! The scene of one frame of one stimulus, fully resolved: cameras, the rolling sphere's
//! motion as a function of time, floor, material, environment, shutter interval, sampling
//! and exposure. Renderers consume this and nothing else, so every method renders the same
//! scene; `blurlab stimuli describe` prints it.
//!
//! Units: metres, seconds, radians; world frame right-handed with +y up, the floor at
//! `floor.height`, the camera looking roughly along -z. Times are seconds from the start
//! of the sequence.

use glam::{DQuat, DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::ids::StimulusId;
use crate::seed::Eye;

/// A pinhole camera with an optionally shifted sensor (off-axis projection).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Centre of projection.
    pub position: DVec3,
    /// Unit vector the camera looks along.
    pub forward: DVec3,
    /// Unit vector to the image's right.
    pub right: DVec3,
    /// Unit vector to the image's top.
    pub up: DVec3,
    /// Lens focal length in metres (0.05 for the study's 50 mm lens).
    pub focal_length: f64,
    /// Sensor width in metres; the height follows from the pixel aspect (square pixels).
    pub sensor_width: f64,
    /// Sensor shift in metres (x right, y up) in the sensor plane; non-zero for the
    /// off-axis cameras of a parallel stereo rig.
    pub sensor_shift: DVec2,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// A camera at `position` looking at `target` with +y as the up hint.
    pub fn look_at(
        position: DVec3,
        target: DVec3,
        focal_length: f64,
        sensor_width: f64,
        width: u32,
        height: u32,
    ) -> Self {
        let forward = (target - position).normalize();
        let right = forward.cross(DVec3::Y).normalize();
        let up = right.cross(forward);
        Camera { position, forward, right, up, focal_length, sensor_width, sensor_shift: DVec2::ZERO, width, height }
    }

    /// Sensor height in metres.
    pub fn sensor_height(&self) -> f64 {
        self.sensor_width * f64::from(self.height) / f64::from(self.width)
    }

    /// Horizontal field of view of the unshifted sensor, radians.
    pub fn horizontal_fov(&self) -> f64 {
        2.0 * (0.5 * self.sensor_width / self.focal_length).atan()
    }

    /// Unit direction of the ray through continuous pixel coordinates (x right, y down,
    /// pixel (i, j) covers [i, i+1) x [j, j+1)).
    pub fn ray_direction(&self, pixel: DVec2) -> DVec3 {
        let sx = (pixel.x / f64::from(self.width) - 0.5) * self.sensor_width + self.sensor_shift.x;
        let sy = (0.5 - pixel.y / f64::from(self.height)) * self.sensor_height() + self.sensor_shift.y;
        (self.forward * self.focal_length + self.right * sx + self.up * sy).normalize()
    }

    /// Continuous pixel coordinates where world point `p` projects, or `None` behind the camera.
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        let d = p - self.position;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = self.focal_length * d.dot(self.right) / z - self.sensor_shift.x;
        let sy = self.focal_length * d.dot(self.up) / z - self.sensor_shift.y;
        Some(DVec2::new(
            (sx / self.sensor_width + 0.5) * f64::from(self.width),
            (0.5 - sy / self.sensor_height()) * f64::from(self.height),
        ))
    }
}

/// How the two cameras of a stereo pair converge on the focus point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StereoConvergence {
    /// Parallel optical axes with shifted sensors (no keystone distortion); the default.
    OffAxis,
    /// Each camera rotated to look at the focus point.
    ToeIn,
}

/// The cameras of a view: the centre camera alone, or the two eyes of a rig built around it.
pub fn eye_camera(
    centre: &Camera,
    eye: Eye,
    interocular: f64,
    focus_distance: f64,
    convergence: StereoConvergence,
) -> Camera {
    let offset = match eye {
        Eye::Centre => return centre.clone(),
        Eye::Left => -0.5 * interocular,
        Eye::Right => 0.5 * interocular,
    };
    let position = centre.position + centre.right * offset;
    match convergence {
        StereoConvergence::OffAxis => {
            // Shift the sensor so the focus point, offset -offset from this eye, lands at
            // the image centre: zero disparity at the focus distance.
            let shift = DVec2::new(-offset * centre.focal_length / focus_distance, 0.0) + centre.sensor_shift;
            Camera { position, sensor_shift: shift, ..centre.clone() }
        }
        StereoConvergence::ToeIn => {
            let focus = centre.position + centre.forward * focus_distance;
            Camera::look_at(position, focus, centre.focal_length, centre.sensor_width, centre.width, centre.height)
        }
    }
}

/// A sphere rolling without slipping over the floor along a straight line at constant speed.
///
/// The centre moves as `start + velocity * t`; optionally the path wraps: once the centre
/// passes `wrap_length` metres beyond the path start it re-enters at the start, so the
/// sphere crosses the view repeatedly during a sequence (placed off-screen by the design).
/// The rotation accumulates without wrapping, so the rolling stays continuous.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RollingSphere {
    /// Radius in metres (0.1 for the study's 20 cm sphere).
    pub radius: f64,
    /// Centre at t = 0 (a point `radius` above the floor).
    pub start: DVec3,
    /// Velocity in m/s, parallel to the floor.
    pub velocity: DVec3,
    /// Orientation at t = 0 (object to world).
    pub start_orientation: DQuat,
    /// Up normal of the floor the sphere rolls on.
    pub floor_normal: DVec3,
    /// Path length after which the centre re-enters at `start`; `None` for an unbounded path.
    pub wrap_length: Option<f64>,
}

impl RollingSphere {
    /// Speed in m/s.
    pub fn speed(&self) -> f64 {
        self.velocity.length()
    }

    /// Centre of the sphere at time `t`.
    pub fn centre_at(&self, t: f64) -> DVec3 {
        let speed = self.speed();
        if speed == 0.0 {
            return self.start;
        }
        let mut travelled = speed * t;
        if let Some(length) = self.wrap_length.filter(|l| *l > 0.0) {
            travelled = travelled.rem_euclid(length);
        }
        self.start + self.velocity * (travelled / speed)
    }

    /// Angular velocity vector (rad/s): `n x v / r`, which keeps the contact point at rest.
    pub fn angular_velocity(&self) -> DVec3 {
        self.floor_normal.cross(self.velocity) / self.radius
    }

    /// Orientation (object to world) at time `t`.
    pub fn orientation_at(&self, t: f64) -> DQuat {
        let omega = self.angular_velocity();
        let rate = omega.length();
        if rate == 0.0 {
            return self.start_orientation;
        }
        DQuat::from_axis_angle(omega / rate, rate * t) * self.start_orientation
    }

    /// A world point on (or near) the sphere at time `t` in the sphere's own frame, where
    /// its texture is defined; unit-free: divided by the radius.
    pub fn world_to_object(&self, p: DVec3, t: f64) -> DVec3 {
        self.orientation_at(t).inverse() * ((p - self.centre_at(t)) / self.radius)
    }

    /// Velocity of the material point at world position `p` (on the sphere) at time `t`.
    pub fn surface_velocity(&self, p: DVec3, t: f64) -> DVec3 {
        self.velocity + self.angular_velocity().cross(p - self.centre_at(t))
    }
}

/// Surface appearance of the sphere; all Lambertian (albedos are linear RGB reflectances).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Material {
    /// M1: a single colour; no texture is evaluated.
    Flat {
        /// Reflectance.
        albedo: [f64; 3],
    },
    /// M2: a checker of two colours over the sphere's longitude and latitude (abrupt edges).
    Checker {
        /// Reflectance of the first colour.
        albedo_a: [f64; 3],
        /// Reflectance of the second colour.
        albedo_b: [f64; 3],
        /// Squares around the equator.
        squares_around: u32,
        /// Squares from pole to pole.
        squares_pole_to_pole: u32,
    },
    /// M3: band-limited procedural noise in the sphere's own frame, blending two colours.
    Noise {
        /// Reflectance where the noise is lowest.
        albedo_a: [f64; 3],
        /// Reflectance where the noise is highest.
        albedo_b: [f64; 3],
        /// Frequency of the first octave in cycles per sphere radius.
        base_frequency: f64,
        /// Number of octaves, each doubling the frequency and halving the amplitude.
        octaves: u32,
        /// Seed of the noise lattice (part of the material, the same in every frame).
        seed: u64,
    },
}

impl Material {
    /// Whether shading needs a texture look-up (false for the flat material).
    pub fn is_textured(&self) -> bool {
        !matches!(self, Material::Flat { .. })
    }
}

/// The infinite (or bounded) Lambertian floor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Floor {
    /// Height of the floor plane (y).
    pub height: f64,
    /// Reflectance.
    pub albedo: [f64; 3],
}

/// Where the lighting comes from: a latitude-longitude radiance map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Environment {
    /// The built-in procedural map (`blurlab stimuli env` writes the same map to a file).
    Default {
        /// Width of the generated map in pixels (height is half).
        width: u32,
    },
    /// A map loaded from an EXR or Radiance HDR file.
    File {
        /// Path of the map, as resolved against the design file's folder.
        path: std::path::PathBuf,
    },
    /// The same radiance from every direction (white furnace tests).
    Uniform {
        /// Radiance in linear RGB.
        radiance: [f64; 3],
    },
}

/// The brightest radiance a design may light a scene with (the map's radiance times the
/// lighting's intensity): f32's largest value over 2^20, so that a renderer's f32 sums of up
/// to 2^20 such values (samples per pixel, filter taps, path contributions) stay finite.
pub const MAX_RADIANCE: f64 = f32::MAX as f64 / (1u64 << 20) as f64;

/// An upper bound on the radiance of the built-in default map (its key light is 150 at the
/// centre, plus the glow, the fill and the sky); the renderer's tests hold its map to it.
pub const DEFAULT_MAP_PEAK_RADIANCE: f64 = 160.0;

/// The environment and how it is placed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lighting {
    /// The radiance map.
    pub environment: Environment,
    /// Multiplier on the map's radiance.
    pub intensity: f64,
    /// Rotation of the map about +y, radians.
    pub rotation_y: f64,
}

/// The interval during which the shutter is open.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Shutter {
    /// Opening time, seconds.
    pub open: f64,
    /// Closing time, seconds; equal to `open` for an instantaneous exposure (T1).
    pub close: f64,
}

impl Shutter {
    /// Whether the exposure has a duration (a time dimension to sample).
    pub fn is_open_interval(&self) -> bool {
        self.close > self.open
    }

    /// How long the shutter is open, seconds (0 for an instantaneous exposure).
    pub fn duration(&self) -> f64 {
        (self.close - self.open).max(0.0)
    }

    /// The closing time, never before the opening (a shutter given backwards is closed).
    pub fn end(&self) -> f64 {
        self.close.max(self.open)
    }

    /// The centre instant of the exposure.
    pub fn centre(&self) -> f64 {
        0.5 * (self.open + self.close)
    }

    /// The time at fraction `u` in [0, 1] of the interval (box shutter filter).
    pub fn time_at(&self, u: f64) -> f64 {
        if self.is_open_interval() { self.open + (self.close - self.open) * u } else { self.open }
    }
}

/// How the path tracer terminates paths.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Integrator {
    /// Maximum number of bounces after the camera ray's first hit (at least 3).
    pub max_bounces: u32,
    /// Bounce from which Russian roulette may stop a path.
    pub russian_roulette_from: u32,
}

/// How linear radiance becomes a display image.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Exposure {
    /// Exposure in stops applied to radiance before tone mapping (multiplier 2^stops).
    pub stops: f64,
    /// Tone curve applied before the sRGB transfer function.
    pub tone_map: ToneMap,
}

/// A tone curve mapping exposed linear values to [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMap {
    /// Clamp at 1.
    Clamp,
    /// x / (1 + x) per channel.
    Reinhard,
}

/// One camera of a frame with its own sample seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EyeView {
    /// Which eye.
    pub eye: Eye,
    /// Its camera.
    pub camera: Camera,
    /// Seed of all random choices for this eye and frame.
    pub seed: u64,
}

fn default_pixel_jitter() -> bool {
    true
}

/// What morphological antialiasing finds its edges in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MlaaEdges {
    /// Steps of the display values' luminance (what the frame shows).
    #[default]
    Luminance,
    /// Steps of inverse view depth at the pixels' centres at the shutter's centre (the scene's
    /// geometry, as a depth buffer holds it): the thesis's first choice.
    Depth,
}

impl MlaaEdges {
    /// Whether this is the default, luminance.
    pub fn is_luminance(&self) -> bool {
        *self == MlaaEdges::Luminance
    }
}

/// A filter applied to a frame's display values after it is rendered, one eye at a time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum Antialias {
    /// Morphological antialiasing (the thesis's Part II).
    Mlaa {
        /// Smallest step that is an edge, in (0, 1]: of display luminance, or of inverse
        /// view depth in 1/m with depth edges.
        threshold: f64,
        /// Longest search towards each end of a line, pixels (1-64).
        search_distance: u32,
        /// What the edges are found in.
        #[serde(default, skip_serializing_if = "MlaaEdges::is_luminance")]
        edges: MlaaEdges,
    },
}

/// Everything needed to render one frame of one stimulus.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameScene {
    /// The stimulus.
    pub stimulus: StimulusId,
    /// Frame index from 0.
    pub frame: u32,
    /// The frame's nominal time (seconds); the shutter is placed relative to it.
    pub frame_time: f64,
    /// Open interval of the shutter for this frame.
    pub shutter: Shutter,
    /// The cameras, left to right in the composed image.
    pub views: Vec<EyeView>,
    /// The moving sphere.
    pub sphere: RollingSphere,
    /// Its material.
    pub material: Material,
    /// The floor.
    pub floor: Floor,
    /// Environment lighting.
    pub lighting: Lighting,
    /// Camera samples per pixel.
    pub samples_per_pixel: u32,
    /// Whether each camera sample draws its position in the pixel (the box filter). False
    /// puts every sample through the pixel's centre, as a rasterizer samples: edges alias,
    /// which is what an antialiasing filter such as MLAA is given (the tracer's
    /// `pixel_jitter` setting).
    #[serde(default = "default_pixel_jitter")]
    pub pixel_jitter: bool,
    /// Antialiasing of the rendered frame's display values (a method level's `antialias`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub antialias: Option<Antialias>,
    /// Path termination.
    pub integrator: Integrator,
    /// Display mapping.
    pub exposure: Exposure,
    /// A participating medium (`None`: the scene has none and no volume code runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub medium: Option<crate::medium::SceneMedium>,
}

impl FrameScene {
    /// Whether anything moves while the shutter is open, i.e. whether time must be sampled:
    /// the sphere, or a medium whose grids change.
    pub fn needs_time_sampling(&self) -> bool {
        self.shutter.is_open_interval()
            && (self.sphere.speed() > 0.0 || self.medium.as_ref().is_some_and(|m| m.is_animated()))
    }

    /// This frame with an instantaneous shutter at time `t` (what the tracer renders for one
    /// instant of an accumulation buffer or for a G-buffer).
    pub fn at_instant(&self, t: f64) -> FrameScene {
        FrameScene { shutter: Shutter { open: t, close: t }, ..self.clone() }
    }

    /// Width of the composed image (eyes side by side).
    pub fn composed_width(&self) -> u32 {
        self.views.iter().map(|v| v.camera.width).sum()
    }

    /// Height of the composed image.
    pub fn composed_height(&self) -> u32 {
        self.views.first().map_or(0, |v| v.camera.height)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shutters_duration_centre_and_end() {
        let open = Shutter { open: 1.0, close: 1.25 };
        assert_eq!((open.duration(), open.centre(), open.end()), (0.25, 1.125, 1.25));
        let instant = Shutter { open: 2.0, close: 2.0 };
        assert_eq!((instant.duration(), instant.centre(), instant.end()), (0.0, 2.0, 2.0));
        // Given backwards, a shutter is closed: no duration, and it ends where it opens.
        let backwards = Shutter { open: 3.0, close: 2.5 };
        assert_eq!((backwards.duration(), backwards.end()), (0.0, 3.0));
        for s in [open, instant, backwards] {
            assert_eq!(s.duration(), s.end() - s.open);
        }
    }

    fn sphere() -> RollingSphere {
        RollingSphere {
            radius: 0.1,
            start: DVec3::new(-1.0, 0.1, 0.0),
            velocity: DVec3::new(1.5, 0.0, 0.0),
            start_orientation: DQuat::IDENTITY,
            floor_normal: DVec3::Y,
            wrap_length: None,
        }
    }

    #[test]
    fn contact_point_is_at_rest_and_top_moves_at_twice_the_speed() {
        let s = sphere();
        for t in [0.0, 0.37, 2.0] {
            let c = s.centre_at(t);
            let contact = c - DVec3::Y * s.radius;
            assert!(s.surface_velocity(contact, t).length() < 1e-12);
            let top = c + DVec3::Y * s.radius;
            assert!((s.surface_velocity(top, t) - 2.0 * s.velocity).length() < 1e-12);
        }
    }

    #[test]
    fn a_material_point_follows_rolling_kinematics() {
        // A point that touches the floor at t = 0 is back at the bottom after one
        // circumference of travel and on top after half of one.
        let s = sphere();
        let local = s.world_to_object(s.start - DVec3::Y * s.radius, 0.0);
        let circumference_time = 2.0 * std::f64::consts::PI * s.radius / s.speed();
        let world_at = |t: f64| s.centre_at(t) + s.orientation_at(t) * (local * s.radius);
        let bottom = world_at(circumference_time);
        assert!((bottom - (s.centre_at(circumference_time) - DVec3::Y * 0.1)).length() < 1e-12);
        let top = world_at(0.5 * circumference_time);
        assert!((top - (s.centre_at(0.5 * circumference_time) + DVec3::Y * 0.1)).length() < 1e-12);
    }

    #[test]
    fn wrapping_path_reenters_at_start() {
        let s = RollingSphere { wrap_length: Some(3.0), ..sphere() };
        let t = 3.0 / 1.5 + 0.1;
        assert!((s.centre_at(t) - (s.start + DVec3::X * 0.15)).length() < 1e-12);
    }

    #[test]
    fn projection_inverts_ray_direction_and_off_axis_rig_has_zero_disparity_at_focus() {
        let centre = Camera::look_at(DVec3::new(0.0, 0.5, 3.0), DVec3::new(0.0, 0.1, 0.0), 0.05, 0.036, 640, 360);
        let px = DVec2::new(100.25, 300.5);
        let p = centre.position + centre.ray_direction(px) * 2.7;
        assert!((centre.project(p).unwrap() - px).length() < 1e-9);

        let focus_distance = (DVec3::new(0.0, 0.1, 0.0) - centre.position).length();
        let focus = centre.position + centre.forward * focus_distance;
        let left = eye_camera(&centre, Eye::Left, 0.065, focus_distance, StereoConvergence::OffAxis);
        let right = eye_camera(&centre, Eye::Right, 0.065, focus_distance, StereoConvergence::OffAxis);
        let (l, r) = (left.project(focus).unwrap(), right.project(focus).unwrap());
        assert!((l - r).length() < 1e-9 && (l - DVec2::new(320.0, 180.0)).length() < 1e-9);
        // Nearer than focus: crossed disparity (left image point right of the right one).
        let near = centre.position + centre.forward * (focus_distance * 0.5);
        assert!(left.project(near).unwrap().x > right.project(near).unwrap().x);
        let far = centre.position + centre.forward * (focus_distance * 2.0);
        assert!(left.project(far).unwrap().x < right.project(far).unwrap().x);
    }
}
