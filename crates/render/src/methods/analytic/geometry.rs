//! The study scene as moving triangles in camera space: the rolling sphere tessellated into
//! a UV sphere whose vertices move linearly from their positions at shutter open to those at
//! shutter close (the paper's assumption), translating rigidly with the centre while shading
//! applies the rotation ([`VertexPaths`] says why), and the static floor, clipped to the camera's near
//! plane once, so none of its vertices ever has `w <= 0`.
//!
//! Camera space is `(x, y, w) = (d.right, d.up, d.forward)` with `d` the offset from the
//! centre of projection; a pixel's sample point is `s = (sx, sy, 1)` on the plane `w = 1`
//! ([`CameraFrame::sample`]), so the ray through it is the tracer's camera ray. Triangles
//! are wound so that a front-facing one has a positive determinant `p0 . (p1 x p2)`.

use glam::{DVec2, DVec3};
use study::scene::{Camera, FrameScene};

/// Which surface a triangle belongs to (what shading evaluates there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceKind {
    /// The rolling sphere.
    Sphere,
    /// The floor.
    Floor,
}

/// A triangle whose vertices move linearly in camera space over the normalised shutter
/// time `t` in [0, 1]: `p(t) = open + t (close - open)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MovingTriangle {
    /// Vertices at shutter open (camera space).
    pub open: [DVec3; 3],
    /// Vertices at shutter close (camera space).
    pub close: [DVec3; 3],
    /// The surface it belongs to.
    pub surface: SurfaceKind,
    /// Whether its back side is drawn too (false: back-facing instants are culled).
    pub two_sided: bool,
}

impl MovingTriangle {
    /// A triangle that does not move.
    pub fn fixed(v: [DVec3; 3], surface: SurfaceKind) -> Self {
        MovingTriangle { open: v, close: v, surface, two_sided: false }
    }

    /// The vertices at normalised time `t`.
    pub fn at(&self, t: f64) -> [DVec3; 3] {
        [0, 1, 2].map(|i| self.open[i] + (self.close[i] - self.open[i]) * t)
    }

    /// Whether the triangle is the same at every instant.
    pub fn is_static(&self) -> bool {
        self.open == self.close
    }
}

/// A camera reduced to what the rasterizer needs: world-to-camera-space and the sample point
/// of a continuous pixel position.
#[derive(Clone, Copy, Debug)]
pub struct CameraFrame {
    /// Centre of projection (world).
    pub origin: DVec3,
    /// Right axis (world).
    pub right: DVec3,
    /// Up axis (world).
    pub up: DVec3,
    /// Viewing axis (world).
    pub forward: DVec3,
    /// Pixel width, height in sensor units divided by the focal length.
    step: DVec2,
    /// The sample point of pixel position (0, 0).
    corner: DVec2,
    /// Image size in pixels.
    size: (u32, u32),
}

impl CameraFrame {
    /// Prepares `camera`.
    pub fn new(camera: &Camera) -> Self {
        let (w, h) = (f64::from(camera.width), f64::from(camera.height));
        let f = camera.focal_length;
        let sh = camera.sensor_height();
        CameraFrame {
            origin: camera.position,
            right: camera.right,
            up: camera.up,
            forward: camera.forward,
            step: DVec2::new(camera.sensor_width / w / f, -sh / h / f),
            corner: DVec2::new(
                (camera.sensor_shift.x - 0.5 * camera.sensor_width) / f,
                (camera.sensor_shift.y + 0.5 * sh) / f,
            ),
            size: (camera.width, camera.height),
        }
    }

    /// A world point in camera space.
    pub fn to_camera(&self, p: DVec3) -> DVec3 {
        let d = p - self.origin;
        DVec3::new(d.dot(self.right), d.dot(self.up), d.dot(self.forward))
    }

    /// A camera-space point in the world.
    pub fn to_world(&self, q: DVec3) -> DVec3 {
        self.origin + self.right * q.x + self.up * q.y + self.forward * q.z
    }

    /// The sample point `(sx, sy)` (of `s = (sx, sy, 1)`) at continuous pixel coordinates
    /// (x right, y down).
    pub fn sample(&self, pixel: DVec2) -> DVec2 {
        self.corner + self.step * pixel
    }

    /// The unit world direction of the ray through sample point `s`.
    pub fn direction(&self, s: DVec2) -> DVec3 {
        (self.forward + self.right * s.x + self.up * s.y).normalize()
    }
}

/// The unit UV sphere of `segments` around the equator and `segments / 2` rings (at least
/// 2) from pole to pole: vertices, and triangles wound outward (`(v1 - v0) x (v2 - v0)` points
/// away from the centre).
pub fn unit_sphere(segments: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let n = segments.max(3);
    let rings = (n / 2).max(2);
    let mut vertices = vec![DVec3::Y];
    for i in 1..rings {
        let theta = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        for j in 0..n {
            let phi = std::f64::consts::TAU * f64::from(j) / f64::from(n);
            vertices.push(DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    let south = vertices.len() as u32;
    vertices.push(-DVec3::Y);
    let ring = |i: u32, j: u32| 1 + (i - 1) * n + j % n;
    let mut tris = Vec::new();
    for j in 0..n {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
        tris.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
        for i in 1..rings - 1 {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            tris.push([a, c, d]);
            tris.push([a, d, b]);
        }
    }
    for t in &mut tris {
        let [a, b, c] = t.map(|i| vertices[i as usize]);
        if (b - a).cross(c - a).dot(a + b + c) < 0.0 {
            t.swap(1, 2);
        }
    }
    (vertices, tris)
}

/// Half the side of the floor square around the camera (metres) at least: beyond it is sky.
/// The tracer's floor is an infinite plane, whose horizon the square's far edge stands in
/// for, `camera height / extent` radians below it: 1e5 m keeps that gap near 1e-5 rad, a
/// hundredth of a study pixel (at 1 km the whole horizon row showed sky instead of floor).
/// Edge equations are homogeneous, so the far vertices cost no precision. A camera with
/// smaller pixels, or higher above the floor, gets a larger square ([`floor_extent`]).
pub const FLOOR_EXTENT: f64 = 1.0e5;
/// The near plane the floor is clipped to (metres of view depth), unless a ray of the image
/// meets the floor nearer ([`floor_near`]).
pub const NEAR: f64 = 1e-3;
/// The largest gap between the floor square's far edge and the horizon, in pixels.
const HORIZON_GAP_PIXELS: f64 = 0.01;

impl CameraFrame {
    /// The smallest angle a pixel subtends (radians, at the image's widest ray: an upper
    /// bound on its tangent steps).
    fn pixel_angle(&self) -> f64 {
        let (width, height) = self.size;
        let corner =
            self.corner.abs().max((self.corner + self.step * DVec2::new(f64::from(width), f64::from(height))).abs());
        let widest = 1.0 + corner.length_squared();
        self.step.x.abs().min(self.step.y.abs()) / widest
    }
}

/// Half the side of the floor square that puts its far edge within
/// [`HORIZON_GAP_PIXELS`] of the horizon for `camera` (at least [`FLOOR_EXTENT`]).
pub fn floor_extent(camera: &CameraFrame, floor_height: f64) -> f64 {
    let above = (camera.origin.y - floor_height).abs();
    let needed = above / (HORIZON_GAP_PIXELS * camera.pixel_angle());
    if needed.is_finite() { needed.max(FLOOR_EXTENT) } else { FLOOR_EXTENT }
}

/// The near plane for the floor: [`NEAR`], or half the smallest view depth at which a ray
/// through the image's corners meets the floor, so that no floor the tracer sees is clipped
/// (a very tall image looks almost straight down; its bottom rows meet the floor nearer
/// than a millimetre).
pub fn floor_near(camera: &CameraFrame, floor_height: f64) -> f64 {
    let (width, height) = camera.size;
    // The floor in camera space: n . q = d.
    let n = DVec3::new(camera.right.y, camera.up.y, camera.forward.y);
    let d = floor_height - camera.origin.y;
    let mut near = NEAR;
    for (px, py) in [(0, 0), (width, 0), (0, height), (width, height)] {
        let s = camera.sample(DVec2::new(f64::from(px), f64::from(py)));
        let along = n.dot(DVec3::new(s.x, s.y, 1.0));
        let z = d / along;
        if z.is_finite() && z > 0.0 {
            near = near.min(0.5 * z);
        }
    }
    near
}

/// The convex polygon `poly` (camera space) clipped to `w >= near` (Sutherland-Hodgman).
pub fn clip_near(poly: &[DVec3], near: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (a.z - near, b.z - near);
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let u = da / (da - db);
            let mut p = a + (b - a) * u;
            p.z = near;
            out.push(p);
        }
    }
    out
}

/// How the sphere's vertices move within one exposure (each along a straight path, as the
/// paper assumes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexPaths {
    /// Rigidly with the centre, in the pose of shutter open: straight paths are exact for
    /// the rolling's translation, so the silhouette differs from the true sphere's by the
    /// tessellation alone. The rolling's rotation is applied where it shows, in shading,
    /// which projects each shaded point onto the true sphere in its orientation at the
    /// interval's instant (`super::shade`). The rasterizer's geometry.
    Translated,
    /// From their rolled positions at shutter open to those at close: the rotation by the
    /// angle `a = speed x shutter / radius` replaced by chords, which pass `cos(a / 2)` of the
    /// radius from the centre, so the polygon shrinks mid-shutter whatever the tessellation.
    /// Kept to measure that cost (`super::accuracy::tessellation_error`).
    RollingChords,
}

/// The sphere of `scene` seen from `camera`, tessellated with `segments` around its equator,
/// moving between shutter open and close along `paths`.
pub fn sphere_triangles(
    scene: &FrameScene,
    camera: &CameraFrame,
    segments: u32,
    paths: VertexPaths,
) -> Vec<MovingTriangle> {
    let sphere = &scene.sphere;
    let (open, close) = (scene.shutter.open, scene.shutter.end());
    let c_open = sphere.centre_at(open);
    // The centre moves in a straight line within one exposure (no wrap inside a shutter).
    let c_close = c_open + sphere.velocity * scene.shutter.duration();
    let q_open = sphere.orientation_at(open);
    let q_close = match paths {
        VertexPaths::Translated => q_open,
        VertexPaths::RollingChords => sphere.orientation_at(close),
    };
    let (unit, tris) = unit_sphere(segments);
    let at_open: Vec<DVec3> = unit.iter().map(|&v| camera.to_camera(c_open + q_open * (v * sphere.radius))).collect();
    let at_close: Vec<DVec3> = if scene.needs_time_sampling() {
        unit.iter().map(|&v| camera.to_camera(c_close + q_close * (v * sphere.radius))).collect()
    } else {
        at_open.clone()
    };
    tris.iter()
        .map(|t| MovingTriangle {
            open: t.map(|i| at_open[i as usize]),
            close: t.map(|i| at_close[i as usize]),
            surface: SurfaceKind::Sphere,
            two_sided: false,
        })
        .collect()
}

/// The triangles of `scene` seen from `camera`: the sphere tessellated with `segments`
/// around its equator, translating over the shutter ([`VertexPaths::Translated`]), then the
/// floor.
pub fn scene_triangles(scene: &FrameScene, camera: &CameraFrame, segments: u32) -> Vec<MovingTriangle> {
    let mut out = sphere_triangles(scene, camera, segments, VertexPaths::Translated);
    out.extend(floor_triangles(scene, camera));
    out
}

/// The floor of `scene` seen from `camera`, a square of [`floor_extent`] clipped to the
/// [`floor_near`] plane.
pub fn floor_triangles(scene: &FrameScene, camera: &CameraFrame) -> Vec<MovingTriangle> {
    let mut out = Vec::new();
    let h = scene.floor.height;
    let (ox, oz) = (camera.origin.x, camera.origin.z);
    let e = floor_extent(camera, h);
    let quad = [
        DVec3::new(ox - e, h, oz - e),
        DVec3::new(ox - e, h, oz + e),
        DVec3::new(ox + e, h, oz + e),
        DVec3::new(ox + e, h, oz - e),
    ]
    .map(|p| camera.to_camera(p));
    let poly = clip_near(&quad, floor_near(camera, h));
    for i in 1..poly.len().saturating_sub(1) {
        out.push(MovingTriangle::fixed([poly[0], poly[i], poly[i + 1]], SurfaceKind::Floor));
    }
    out
}
