//! MLAA's host side: [`GpuMlaa`] compiles `edges.wgsl`, `weights.wgsl` and `blend.wgsl`
//! once per device, uploads the area texture once, and runs the three passes on one eye's
//! display values, timed as one submission.
//!
//! Memory per image of `n` pixels: the input and output colours (16 bytes a pixel each,
//! RGBA f32 for alignment), the edges texture (RGBA8, 4 bytes a texel of the padded image)
//! and the weights (16 bytes a pixel): 52 bytes a pixel (56 with depth edges' f32 inverse
//! depth), 3.25x an RGBA f32 back buffer or
//! 13x an RGBA8 one, plus the area texture's 541 kB once. The thesis's 1.5x counts 8-bit
//! render targets; blurlab keeps f32 so the kernels and their twins agree to rounding.

use gpu::wgpu::util::DeviceExt as _;
use gpu::{GpuContext, GpuError, GpuInfo, TimingSource, WgslAssembler, wgpu};

use super::area::{SIDE, WIDTH, area_texture};
use super::weights::Weights;
use super::{MlaaError, MlaaParams};

/// The passes' shared WGSL: `//! include mlaa_common`.
pub const COMMON_WGSL: &str = include_str!("common.wgsl");
/// Pass 1.
pub const EDGES_WGSL: &str = include_str!("edges.wgsl");
/// Pass 2.
pub const WEIGHTS_WGSL: &str = include_str!("weights.wgsl");
/// Pass 3.
pub const BLEND_WGSL: &str = include_str!("blend.wgsl");

const WORKGROUP: u32 = 8;

/// The assembled source of one pass (`file`, `source`: one of the constants above).
pub fn assemble(file: &str, source: &str) -> Result<String, GpuError> {
    let mut a = WgslAssembler::new().with_include("mlaa_common", COMMON_WGSL);
    a.constant_u32("AREA_SIDE", SIDE as u32).constant_u32("AREA_WIDTH", WIDTH as u32);
    a.assemble(file, source)
}

/// What one run gives: the image and, for the twin tests, every intermediate.
#[derive(Clone, Debug)]
pub struct MlaaRun {
    /// The antialiased display values.
    pub color: Vec<[f32; 3]>,
    /// The padded edges texture, `[west, north]` per texel.
    pub edges: Vec<[f32; 2]>,
    /// The blending weights per pixel.
    pub weights: Vec<Weights>,
    /// The passes' time, and its clock.
    pub seconds: f64,
    /// The clock `seconds` read.
    pub timing_source: TimingSource,
}

/// MLAA's pipelines and area texture on one device.
pub struct GpuMlaa {
    ctx: GpuContext,
    edges: wgpu::ComputePipeline,
    depth_edges: wgpu::ComputePipeline,
    weights: wgpu::ComputePipeline,
    blend: wgpu::ComputePipeline,
    sampler: wgpu::Sampler,
    area: wgpu::Buffer,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    width: u32,
    height: u32,
    threshold: f32,
    search_distance: u32,
}

impl GpuMlaa {
    /// Validates and compiles the passes on `ctx`'s device and uploads the area texture.
    pub fn new(ctx: GpuContext) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let mut modules = Vec::new();
        for (file, source) in [("edges.wgsl", EDGES_WGSL), ("weights.wgsl", WEIGHTS_WGSL), ("blend.wgsl", BLEND_WGSL)] {
            let wgsl = assemble(file, source)?;
            gpu::validate_wgsl(file, &wgsl)?;
            modules.push((file, wgsl));
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipeline = |(file, wgsl): &(&str, String), entry: &str| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(file),
                source: wgpu::ShaderSource::Wgsl(wgsl.as_str().into()),
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let edges = pipeline(&modules[0], "detect_edges");
        let depth_edges = pipeline(&modules[0], "detect_depth_edges");
        let weights = pipeline(&modules[1], "blending_weights");
        let blend = pipeline(&modules[2], "blend");
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("mlaa edges"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let area = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mlaa area"),
            contents: bytemuck::cast_slice(area_texture()),
            usage: wgpu::BufferUsages::STORAGE,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "MLAA pipelines".into(), message: e.to_string() });
        }
        Ok(GpuMlaa { ctx, edges, depth_edges, weights, blend, sampler, area })
    }

    /// The adapter and device.
    pub fn info(&self) -> &GpuInfo {
        &self.ctx.info
    }

    /// MLAA on one eye's display values (`width x height`, row-major).
    pub fn run(&self, width: u32, height: u32, color: &[[f32; 3]], params: &MlaaParams) -> Result<MlaaRun, MlaaError> {
        self.run_with_depth(width, height, color, None, params)
    }

    /// MLAA on one eye's display values, its edges found in `inverse_depth` (1/m, one per
    /// pixel) where given, else in the luminance.
    pub fn run_with_depth(
        &self,
        width: u32,
        height: u32,
        color: &[[f32; 3]],
        inverse_depth: Option<&[f32]>,
        params: &MlaaParams,
    ) -> Result<MlaaRun, MlaaError> {
        params.check()?;
        let n = width as usize * height as usize;
        if color.len() != n || inverse_depth.is_some_and(|d| d.len() != n) || width == 0 || height == 0 {
            return Err(MlaaError::Size { width, height, got: color.len() });
        }
        self.run_checked(width, height, color, inverse_depth, params).map_err(MlaaError::Gpu)
    }

    fn run_checked(
        &self,
        width: u32,
        height: u32,
        color: &[[f32; 3]],
        inverse_depth: Option<&[f32]>,
        params: &MlaaParams,
    ) -> Result<MlaaRun, GpuError> {
        let device = &self.ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let p = Params { width, height, threshold: params.threshold, search_distance: params.search_distance };
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mlaa params"),
            contents: bytemuck::bytes_of(&p),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let rgba: Vec<[f32; 4]> = color.iter().map(|c| [c[0], c[1], c[2], 1.0]).collect();
        let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mlaa input"),
            contents: bytemuck::cast_slice(&rgba),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let pixels = u64::from(width) * u64::from(height);
        let storage = |label: &str| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: pixels * 16,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let weights = storage("mlaa weights");
        let output = storage("mlaa output");
        let (pw, ph) = (width + 2, height + 2);
        let edges = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("mlaa edges"),
            size: wgpu::Extent3d { width: pw, height: ph, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = edges.create_view(&wgpu::TextureViewDescriptor::default());
        let bind = |pipeline: &wgpu::ComputePipeline, resources: &[wgpu::BindingResource<'_>]| {
            let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
                .iter()
                .enumerate()
                .map(|(i, r)| wgpu::BindGroupEntry { binding: i as u32, resource: r.clone() })
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            })
        };
        let depth = inverse_depth.map(|d| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("mlaa inverse depth"),
                contents: bytemuck::cast_slice(d),
                usage: wgpu::BufferUsages::STORAGE,
            })
        });
        let (edges_pipeline, edges_group) = match &depth {
            None => (
                &self.edges,
                bind(
                    &self.edges,
                    &[
                        uniform.as_entire_binding(),
                        input.as_entire_binding(),
                        wgpu::BindingResource::TextureView(&view),
                    ],
                ),
            ),
            // The depth entry point reads bindings 0, 2 and 3, not the colour.
            Some(depth) => (
                &self.depth_edges,
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: None,
                    layout: &self.depth_edges.get_bind_group_layout(0),
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&view) },
                        wgpu::BindGroupEntry { binding: 3, resource: depth.as_entire_binding() },
                    ],
                }),
            ),
        };
        let weights_group = bind(
            &self.weights,
            &[
                uniform.as_entire_binding(),
                wgpu::BindingResource::TextureView(&view),
                wgpu::BindingResource::Sampler(&self.sampler),
                self.area.as_entire_binding(),
                weights.as_entire_binding(),
            ],
        );
        let blend_group = bind(
            &self.blend,
            &[
                uniform.as_entire_binding(),
                input.as_entire_binding(),
                weights.as_entire_binding(),
                output.as_entire_binding(),
            ],
        );
        let groups = |w: u32, h: u32| (w.div_ceil(WORKGROUP), h.div_ceil(WORKGROUP));
        let timing = self.ctx.timer().commands(|encoder| {
            let passes: [(&wgpu::ComputePipeline, &wgpu::BindGroup, (u32, u32)); 3] = [
                (edges_pipeline, &edges_group, groups(pw, ph)),
                (&self.weights, &weights_group, groups(width, height)),
                (&self.blend, &blend_group, groups(width, height)),
            ];
            for (pipeline, group, (gx, gy)) in passes {
                // One pass each: the storage texture written by the first is sampled by the
                // second, which needs a pass boundary.
                let mut pass = encoder
                    .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("mlaa"), timestamp_writes: None });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, group, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            }
        })?;
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "MLAA passes".into(), message: e.to_string() });
        }
        let out: Vec<[f32; 4]> = self.ctx.read_buffer_as(&output, ..)?;
        let w: Vec<Weights> = self.ctx.read_buffer_as(&weights, ..)?;
        let bytes = self.ctx.read_texture(&edges)?;
        let e = bytes.chunks_exact(4).map(|t| [f32::from(t[0]) / 255.0, f32::from(t[1]) / 255.0]).collect();
        Ok(MlaaRun {
            color: out.iter().map(|c| [c[0], c[1], c[2]]).collect(),
            edges: e,
            weights: w,
            seconds: timing.seconds,
            timing_source: timing.source,
        })
    }
}
