//! The tracer benchmark's frame: the full-resolution M3-S3-T5 mono frame of a design at the
//! instant the sphere is nearest the image centre, optionally made static (the frozen
//! sphere at that instant, for comparison with renderers that have no motion blur).

use study::design::Design;
use study::ids::{StimulusId, View};
use study::scene::FrameScene;

/// The stimulus the benchmark renders.
pub const BENCH_STIMULUS: StimulusId = StimulusId { material: 3, speed: 3, shutter: 5, samples: 1, view: View::Mono };

/// The benchmark frame of `design` at `spp` samples per pixel: the frame (of the full
/// preset) whose sphere centre projects nearest the image centre. `freeze` replaces the
/// motion by the sphere at the frame time and closes the shutter (the "static frame").
pub fn benchmark_frame(design: &Design, spp: u32, freeze: bool) -> Result<FrameScene, study::design::DesignError> {
    let first = design.frame_scene(&BENCH_STIMULUS, 0)?;
    let frames = design.spec.sequence.frames;
    let cam = &first.views[0].camera;
    let centre_px = glam::DVec2::new(f64::from(cam.width) * 0.5, f64::from(cam.height) * 0.5);
    let mut best = (f64::INFINITY, 0);
    for f in 0..frames {
        let t = design.frame_time(&design.preset("full")?, f);
        if let Some(p) = cam.project(first.sphere.centre_at(t)) {
            let d = (p - centre_px).length();
            if d < best.0 {
                best = (d, f);
            }
        }
    }
    let mut scene = design.frame_scene(&BENCH_STIMULUS, best.1)?;
    scene.samples_per_pixel = spp;
    if freeze {
        let t = scene.frame_time;
        freeze_at(&mut scene, t);
    }
    Ok(scene)
}

/// Replaces the scene's motion by the sphere as it is at time `t` (speed zero, same
/// position and orientation) and closes the shutter at `t`.
pub fn freeze_at(scene: &mut FrameScene, t: f64) {
    let s = &mut scene.sphere;
    let (centre, orientation) = (s.centre_at(t), s.orientation_at(t));
    s.start = centre;
    s.start_orientation = orientation;
    s.velocity = glam::DVec3::ZERO;
    s.wrap_length = None;
    scene.shutter = study::scene::Shutter { open: t, close: t };
}

/// The sphere of a static frame as another renderer needs it: centre, rotation (object to
/// world, row-major) and the albedo texture baked over Mitsuba's sphere parametrisation.
pub struct PeerSphere {
    /// Centre at the shutter's opening.
    pub centre: [f64; 3],
    /// Rotation matrix rows (object to world).
    pub rotation: [[f64; 3]; 3],
    /// Albedo, `2 h x h` texels: u = phi / 2 pi (phi from +x towards +y), v = theta / pi
    /// (theta from +z) of the point in the object frame, filtered for the footprint of a
    /// pixel at the sphere's distance as this tracer's camera rays see it.
    pub albedo: crate::io::LinearImage,
}

/// Bakes the sphere of `scene` (at its shutter's opening) for a peer renderer.
pub fn peer_sphere(scene: &FrameScene, height: u32) -> PeerSphere {
    use std::f64::consts::PI;
    let cam = &scene.views[0].camera;
    let s = &scene.sphere;
    let t = scene.shutter.open;
    let (centre, orientation) = (s.centre_at(t), s.orientation_at(t));
    let distance = (centre - cam.position).length();
    let footprint = distance * (cam.sensor_width / f64::from(cam.width) / cam.focal_length) / s.radius;
    let shader = super::material::Shader::new(&scene.material);
    let (tw, th) = (2 * height, height);
    let mut albedo = crate::io::LinearImage::new(tw, th);
    for y in 0..th {
        let theta = PI * (f64::from(y) + 0.5) / f64::from(th);
        for x in 0..tw {
            let phi = 2.0 * PI * (f64::from(x) + 0.5) / f64::from(tw);
            let local = glam::DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let a = shader.albedo(local, footprint);
            albedo.set(x, y, [a.x as f32, a.y as f32, a.z as f32]);
        }
    }
    let m = glam::DMat3::from_quat(orientation);
    let rotation = [0, 1, 2].map(|r| [m.col(0)[r], m.col(1)[r], m.col(2)[r]]);
    PeerSphere { centre: centre.to_array(), rotation, albedo }
}
