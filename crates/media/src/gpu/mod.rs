//! The marcher's host side: [`GpuMarcher`] compiles `march.wgsl`'s two entry points once per
//! device (the validity mask and the march), uploads a medium as a [`GpuVolume`] (density and
//! distance map, 8 bytes a voxel: 16.8 MB for a 128^3 grid), and renders an image through a
//! pinhole camera ([`GpuMarcher::render`]; CPU twin [`crate::march::march_image`]) or along
//! given per-pixel rays that end on surfaces ([`GpuMarcher::render_rays`]; CPU twin
//! [`crate::march::march_surface_ray`]), each timed as one submission.

use gpu::wgpu::util::DeviceExt as _;
use gpu::{GpuContext, GpuError, GpuInfo, TimingSource, wgpu};

use glam::Vec3;

use crate::march::{LightingModel, MarchLight, MarchMedium, MarchSettings, NO_LIMIT, PixelCamera, SurfaceRay};

/// The passes' WGSL.
pub const MARCH_WGSL: &str = include_str!("march.wgsl");

const WORKGROUP: u32 = 8;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    dims: [u32; 3],
    light_count: u32,
    eye: [f32; 3],
    step: f32,
    corner: [f32; 3],
    sigma_t: f32,
    du: [f32; 3],
    albedo: f32,
    dv: [f32; 3],
    threshold: f32,
    alpha_colour: [f32; 3],
    model: u32,
    width: u32,
    height: u32,
    use_mask: u32,
    use_distance: u32,
    shade_empty: u32,
    voxel_length: f32,
    use_rays: u32,
    _pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Light {
    direction: [f32; 4],
    irradiance: [f32; 4],
    world: [f32; 4],
}

/// [`SurfaceRay`] as the WGSL reads it.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuRay {
    origin: [f32; 4],
    direction: [f32; 4],
    point: [f32; 4],
    normal: [f32; 4],
}

impl GpuRay {
    fn new(r: &SurfaceRay) -> Self {
        let (point, normal, wanted) = match &r.surface {
            Some(s) => (s.point, s.normal, 1.0),
            None => (Vec3::ZERO, Vec3::ZERO, 0.0),
        };
        GpuRay {
            origin: r.origin.extend(r.limit.min(NO_LIMIT)).to_array(),
            direction: r.direction.extend(wanted).to_array(),
            point: point.extend(0.0).to_array(),
            normal: normal.extend(0.0).to_array(),
        }
    }
}

/// A medium's grids on the device.
pub struct GpuVolume {
    dims: [u32; 3],
    density: wgpu::Buffer,
    distance: wgpu::Buffer,
    has_distance: bool,
}

impl GpuVolume {
    /// Device memory held, in bytes.
    pub fn bytes(&self) -> u64 {
        self.density.size() + self.distance.size()
    }
}

/// One rendered image.
#[derive(Debug, Clone)]
pub struct GpuMarch {
    /// Per pixel: radiance (RGB) and transmittance.
    pub pixels: Vec<[f32; 4]>,
    /// Per pixel: the validity mask's first segment, -1 for none (all -1 without the mask).
    pub mask: Vec<i32>,
    /// Per pixel of [`GpuMarcher::render_rays`]: the smoke's shadow on the ray's surface
    /// (RGB; 1 without a surface or shadow rays); empty for [`GpuMarcher::render`].
    pub surface_shadow: Vec<[f32; 3]>,
    /// The passes' time.
    pub seconds: f64,
    /// The clock `seconds` read.
    pub timing_source: TimingSource,
}

/// The marcher's pipelines on one device.
pub struct GpuMarcher {
    ctx: GpuContext,
    mask: wgpu::ComputePipeline,
    march: wgpu::ComputePipeline,
}

impl GpuMarcher {
    /// Validates and compiles the two passes on `ctx`'s device.
    pub fn new(ctx: GpuContext) -> Result<Self, GpuError> {
        gpu::validate_wgsl("march.wgsl", MARCH_WGSL)?;
        let device = &ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("march.wgsl"),
            source: wgpu::ShaderSource::Wgsl(MARCH_WGSL.into()),
        });
        // one layout for both entry points, so one bind group serves both passes
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("march"),
            entries: &[
                gpu::uniform_entry(0),
                gpu::storage_entry(1, true),
                gpu::storage_entry(2, true),
                gpu::storage_entry(3, true),
                gpu::storage_entry(4, false),
                gpu::storage_entry(5, false),
                gpu::storage_entry(6, true),
                gpu::storage_entry(7, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("march"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let (mask, march) = (pipeline("validity_mask"), pipeline("march"));
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "march pipelines".into(), message: e.to_string() });
        }
        Ok(Self { ctx, mask, march })
    }

    /// The adapter and device.
    pub fn info(&self) -> &GpuInfo {
        &self.ctx.info
    }

    /// Uploads a medium's density and, where it has one, its distance map (capped at
    /// [`NO_LIMIT`], as the twin caps it).
    pub fn upload(&self, medium: &MarchMedium) -> GpuVolume {
        let device = &self.ctx.device;
        let grid = medium.grid;
        let dims = grid.dims().map(|d| d as u32);
        let density = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("march density"),
            contents: bytemuck::cast_slice(grid.data()),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let distance: Vec<f32> = match medium.distance {
            Some(map) => map.data().iter().map(|d| d.min(NO_LIMIT)).collect(),
            None => vec![0.0],
        };
        let distance_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("march distance map"),
            contents: bytemuck::cast_slice(&distance),
            usage: wgpu::BufferUsages::STORAGE,
        });
        GpuVolume { dims, density, distance: distance_buffer, has_distance: medium.distance.is_some() }
    }

    /// Renders `width x height` pixels of `volume` (uploaded from `medium`, whose optical
    /// properties are read here) through `camera`.
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &self,
        volume: &GpuVolume,
        medium: &MarchMedium,
        lights: &[MarchLight],
        camera: &PixelCamera,
        (width, height): (u32, u32),
        settings: &MarchSettings,
        use_mask: bool,
    ) -> Result<GpuMarch, GpuError> {
        let mut params = Self::params(volume, medium, lights, settings, (width, height), use_mask);
        (params.eye, params.corner, params.du, params.dv) =
            (camera.eye.to_array(), camera.corner.to_array(), camera.du.to_array(), camera.dv.to_array());
        let directions: Vec<Vec3> = lights.iter().map(|l| l.direction).collect();
        self.dispatch(&params, volume, lights, &directions, None)
    }

    /// Marches `rays` (one per pixel of a `width x height` image, row by row) of `volume`
    /// up to their surfaces, with the smoke's shadow on those surfaces; `world_directions[n]`
    /// is light `n`'s direction in the world (for the surfaces' cosine).
    #[allow(clippy::too_many_arguments)]
    pub fn render_rays(
        &self,
        volume: &GpuVolume,
        medium: &MarchMedium,
        lights: &[MarchLight],
        world_directions: &[Vec3],
        rays: &[SurfaceRay],
        (width, height): (u32, u32),
        settings: &MarchSettings,
        use_mask: bool,
    ) -> Result<GpuMarch, GpuError> {
        assert_eq!(rays.len() as u64, u64::from(width) * u64::from(height), "one ray per pixel");
        assert_eq!(world_directions.len(), lights.len(), "one world direction per light");
        let mut params = Self::params(volume, medium, lights, settings, (width, height), use_mask);
        params.use_rays = 1;
        let rays: Vec<GpuRay> = rays.iter().map(GpuRay::new).collect();
        self.dispatch(&params, volume, lights, world_directions, Some(&rays))
    }

    /// The passes' parameters without a camera.
    fn params(
        volume: &GpuVolume,
        medium: &MarchMedium,
        lights: &[MarchLight],
        settings: &MarchSettings,
        (width, height): (u32, u32),
        use_mask: bool,
    ) -> Params {
        Params {
            dims: volume.dims,
            light_count: lights.len() as u32,
            eye: [0.0; 3],
            step: settings.step,
            corner: [0.0; 3],
            sigma_t: medium.sigma_t,
            du: [0.0; 3],
            albedo: medium.albedo,
            dv: [0.0; 3],
            threshold: settings.threshold,
            alpha_colour: medium.alpha_colour.to_array(),
            model: match settings.model {
                LightingModel::AlphaCompositing => 0,
                LightingModel::PrimaryRays => 1,
                LightingModel::PrimaryAndShadowRays => 2,
            },
            width,
            height,
            use_mask: u32::from(use_mask),
            use_distance: u32::from(volume.has_distance),
            shade_empty: u32::from(settings.shade_empty),
            voxel_length: medium.voxel_length,
            use_rays: 0,
            _pad: 0,
        }
    }

    /// Runs the passes of `params` (the mask's only where it asks) and reads the results.
    fn dispatch(
        &self,
        params: &Params,
        volume: &GpuVolume,
        lights: &[MarchLight],
        world_directions: &[Vec3],
        rays: Option<&[GpuRay]>,
    ) -> Result<GpuMarch, GpuError> {
        let device = &self.ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let (width, height, use_mask) = (params.width, params.height, params.use_mask != 0);
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("march params"),
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let mut gpu_lights: Vec<Light> = lights
            .iter()
            .zip(world_directions)
            .map(|(l, w)| Light {
                direction: l.direction.extend(0.0).to_array(),
                irradiance: l.irradiance.extend(0.0).to_array(),
                world: w.extend(0.0).to_array(),
            })
            .collect();
        if gpu_lights.is_empty() {
            gpu_lights.push(Light { direction: [0.0; 4], irradiance: [0.0; 4], world: [0.0; 4] }); // a binding is never empty
        }
        let light_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("march lights"),
            contents: bytemuck::cast_slice(&gpu_lights),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let pixels = u64::from(width) * u64::from(height);
        let mask = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("march mask"),
            contents: bytemuck::cast_slice(&vec![-1i32; pixels as usize]),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
        let output = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("march output"),
            size: pixels * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let zero_ray = [GpuRay { origin: [0.0; 4], direction: [0.0; 4], point: [0.0; 4], normal: [0.0; 4] }];
        let ray_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("march rays"),
            contents: bytemuck::cast_slice(rays.unwrap_or(&zero_ray)),
            usage: wgpu::BufferUsages::STORAGE,
        });
        // written only with rays; a binding is never empty
        let shadow_pixels = if rays.is_some() { pixels } else { 1 };
        let surface = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("march surface shadow"),
            size: shadow_pixels * 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("march"),
            layout: &self.march.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: volume.density.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: volume.distance.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: light_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: mask.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: output.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: ray_buffer.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 7, resource: surface.as_entire_binding() },
            ],
        });
        let (gx, gy) = (width.div_ceil(WORKGROUP), height.div_ceil(WORKGROUP));
        let timing = self.ctx.timer().commands(|encoder| {
            let passes: &[&wgpu::ComputePipeline] = if use_mask { &[&self.mask, &self.march] } else { &[&self.march] };
            for pipeline in passes {
                // a pass boundary between the mask's writes and the march's reads
                let mut pass = encoder
                    .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("march"), timestamp_writes: None });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        })?;
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "march passes".into(), message: e.to_string() });
        }
        let pixels: Vec<[f32; 4]> = self.ctx.read_buffer_as(&output, ..)?;
        let mask: Vec<i32> = self.ctx.read_buffer_as(&mask, ..)?;
        let surface_shadow = match rays {
            Some(_) => self.ctx.read_buffer_as::<[f32; 4]>(&surface, ..)?.iter().map(|p| [p[0], p[1], p[2]]).collect(),
            None => Vec::new(),
        };
        Ok(GpuMarch { pixels, mask, surface_shadow, seconds: timing.seconds, timing_source: timing.source })
    }
}
