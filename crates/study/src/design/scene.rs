//! The geometry a design implies: viewing angle to pixels and metres per second, the centre
//! camera and the stereo eyes, the rolling sphere's wrapping path, frame times and shutter
//! intervals, and from them the [`FrameScene`] of any frame of any stimulus.

use glam::{DQuat, DVec3, EulerRot};

use super::{Design, DesignError, Direction, Preset, ShutterPlacement};
use crate::ids::StimulusId;
use crate::scene::{Camera, Exposure, EyeView, Floor, FrameScene, Integrator, RollingSphere, Shutter, eye_camera};
use crate::seed::{Eye, frame_seed};

impl Design {
    /// Pixels per degree of visual angle at the centre of the screen, for an image `width`
    /// pixels wide: the screen is flat, so a degree covers `d * pi/180` metres there, and
    /// the image is `2 d tan(angle/2)` metres wide.
    pub fn pixels_per_degree(&self, width: u32) -> f64 {
        let v = &self.spec.viewing;
        let screen_width = 2.0 * v.distance * (0.5 * v.image_angle_degrees.to_radians()).tan();
        f64::from(width) / screen_width * v.distance * 1f64.to_radians()
    }

    /// Speed on the sphere's plane (m/s) that the observer sees as `degrees_per_second` at
    /// the screen centre. Independent of the resolution: image pixels per degree times the
    /// object-plane metres per image pixel at the focus distance `D` (`D * sensor / (f * W)`).
    pub fn metres_per_second(&self, degrees_per_second: f64) -> f64 {
        let c = &self.spec.camera;
        let v = &self.spec.viewing;
        let object_plane_width = c.distance * c.sensor_width / c.focal_length;
        degrees_per_second * 1f64.to_radians() / (2.0 * (0.5 * v.image_angle_degrees.to_radians()).tan())
            * object_plane_width
    }

    /// Centre of the sphere as it crosses the image centre (the focus point).
    pub fn focus_point(&self) -> DVec3 {
        DVec3::new(0.0, self.spec.floor.height + 0.5 * self.spec.sphere.diameter, 0.0)
    }

    /// The centre camera at `width` x `height` pixels: `camera.distance` from the focus
    /// point, `camera.height` above the floor, looking at the focus point, on the +z side.
    pub fn centre_camera(&self, width: u32, height: u32) -> Camera {
        let c = &self.spec.camera;
        let focus = self.focus_point();
        let eye_y = self.spec.floor.height + c.height;
        let rise = eye_y - focus.y;
        let horizontal = (c.distance * c.distance - rise * rise).sqrt();
        Camera::look_at(
            DVec3::new(focus.x, eye_y, focus.z + horizontal),
            focus,
            c.focal_length,
            c.sensor_width,
            width,
            height,
        )
    }

    /// The sphere's motion at speed level `speed` (1-based).
    ///
    /// The path runs along the camera's right axis through the focus point. A sphere
    /// crossing the view takes less time than a sequence at the study's speeds, so the path
    /// wraps: the sphere leaves the view and re-enters on the other side, and does so as
    /// soon as it is out of view. Both wrap points lie `h = D tan(a) + r / cos(a) + margin`
    /// from the focus point (`a` the half field of view: the sphere is then entirely
    /// outside the view's side planes); the path starts at the entry point at t = 0 and
    /// wraps every `2h`. A sphere at rest stays at the focus point.
    pub fn sphere_motion(&self, speed: u8) -> Result<RollingSphere, DesignError> {
        let level = self
            .spec
            .factors
            .speed
            .get(usize::from(speed).wrapping_sub(1))
            .ok_or_else(|| self.request(format!("speed level S{speed} does not exist")))?;
        let s = &self.spec.sphere;
        let c = &self.spec.camera;
        let radius = 0.5 * s.diameter;
        let camera = self.centre_camera(self.spec.sequence.width, self.spec.sequence.height);
        let sign = match s.direction {
            Direction::LeftToRight => 1.0,
            Direction::RightToLeft => -1.0,
        };
        let axis = camera.right * sign;
        let speed_ms = self.metres_per_second(level.degrees_per_second);
        let start_orientation = {
            let [x, y, z] = s.start_orientation_degrees;
            DQuat::from_euler(EulerRot::XYZ, x.to_radians(), y.to_radians(), z.to_radians())
        };
        let tan_half = 0.5 * c.sensor_width / c.focal_length;
        let half_view = c.distance * tan_half + radius * (1.0 + tan_half * tan_half).sqrt() + s.offscreen_margin;
        let (offset, wrap_length) = if speed_ms > 0.0 { (-half_view, Some(2.0 * half_view)) } else { (0.0, None) };
        Ok(RollingSphere {
            radius,
            start: self.focus_point() + axis * offset,
            velocity: axis * speed_ms,
            start_orientation,
            floor_normal: DVec3::Y,
            wrap_length,
        })
    }

    /// The nominal time of frame `frame` of `preset` (seconds from the sequence start).
    pub fn frame_time(&self, preset: &Preset, frame: u32) -> f64 {
        (f64::from(preset.first_frame + frame) + self.spec.sequence.frame_time_offset) / self.spec.sequence.fps
    }

    /// The shutter interval of a frame at `frame_time` for shutter level `shutter` (1-based).
    pub fn shutter(&self, shutter: u8, frame_time: f64) -> Result<Shutter, DesignError> {
        let level = self
            .spec
            .factors
            .shutter
            .get(usize::from(shutter).wrapping_sub(1))
            .ok_or_else(|| self.request(format!("shutter level T{shutter} does not exist")))?;
        let duration = level.fraction / self.spec.sequence.fps;
        Ok(match self.spec.sequence.shutter_placement {
            ShutterPlacement::Centred if duration == 0.0 => Shutter { open: frame_time, close: frame_time },
            ShutterPlacement::Centred => {
                Shutter { open: frame_time - 0.5 * duration, close: frame_time + 0.5 * duration }
            }
            ShutterPlacement::Opening => Shutter { open: frame_time, close: frame_time + duration },
        })
    }

    /// The scene of frame `frame` of `id` in the full preset.
    pub fn frame_scene(&self, id: &StimulusId, frame: u32) -> Result<FrameScene, DesignError> {
        self.frame_scene_with(&self.preset("full")?, id, frame)
    }

    /// The scene of frame `frame` (0-based within the preset's frames) of `id` in `preset`.
    pub fn frame_scene_with(&self, preset: &Preset, id: &StimulusId, frame: u32) -> Result<FrameScene, DesignError> {
        self.check_id(id)?;
        if frame >= preset.frames {
            return Err(self.request(format!(
                "stimulus {id}: frame {frame} does not exist (preset `{}` has frames 0..{})",
                preset.name,
                preset.frames - 1
            )));
        }
        let s = &self.spec;
        let frame_time = self.frame_time(preset, frame);
        let centre = self.centre_camera(preset.width, preset.height);
        let views = Eye::of_view(id.view)
            .iter()
            .map(|&eye| EyeView {
                eye,
                camera: eye_camera(&centre, eye, s.stereo.interocular, s.camera.distance, s.stereo.convergence),
                seed: frame_seed(s.master_seed, id, eye, frame),
            })
            .collect();
        Ok(FrameScene {
            stimulus: *id,
            frame,
            frame_time,
            shutter: self.shutter(id.shutter, frame_time)?,
            views,
            sphere: self.sphere_motion(id.speed)?,
            material: self
                .material_of(usize::from(id.material - 1), &s.factors.material[usize::from(id.material - 1)])?,
            floor: Floor { height: s.floor.height, albedo: s.floor.albedo },
            lighting: self.lighting.clone(),
            samples_per_pixel: preset.samples_of(id).ok_or_else(|| {
                self.request(format!(
                    "stimulus {id}: the preset `{}` has {} sample levels",
                    preset.name,
                    preset.samples_per_pixel.len()
                ))
            })?,
            pixel_jitter: true,
            antialias: self.antialias_of(id)?,
            integrator: Integrator {
                max_bounces: s.integrator.max_bounces,
                russian_roulette_from: s.integrator.russian_roulette_from,
            },
            exposure: Exposure { stops: s.exposure.stops, tone_map: s.exposure.tone_map },
            medium: self.medium_for(preset),
        })
    }
}
