//! The filters' host side: [`GpuFilters`] compiles `tiles.wgsl` and the filters' `gather.wgsl`
//! once per device and runs a filter as one compute pass of dispatches (encode, TileMax rows,
//! TileMax columns, NeighborMax, the variance where asked for, the gather) over buffers
//! created for the image, timed with [`gpu::GpuTimer`].

use gpu::wgpu::util::DeviceExt as _;
use gpu::{GpuContext, GpuError, GpuInfo, TimingSource, WgslAssembler, wgpu};

use super::common::PassParams;
use super::tiles::Tiles;
use super::{FilterError, GBuffer, check_gbuffer};
use crate::methods::guertin::GuertinParams;
use crate::methods::mcguire::McGuireParams;

/// The filters' WGSL include: `//! include filters_common`.
pub const COMMON_WGSL: &str = include_str!("common.wgsl");
/// The passes before the gather.
pub const TILES_WGSL: &str = include_str!("tiles.wgsl");
/// McGuire et al. 2012's gather.
pub const MCGUIRE_WGSL: &str = include_str!("../mcguire/gather.wgsl");
/// Guertin et al. 2014's gather.
pub const GUERTIN_WGSL: &str = include_str!("../guertin/gather.wgsl");

/// Workgroups are 8 x 8 invocations.
const WORKGROUP: u32 = 8;
/// Storage bindings of the shared layout, in binding order after the uniform (binding 0),
/// with whether the passes only read them.
const STORAGE: [(&str, bool); 8] = [
    ("color", true),
    ("depth", true),
    ("velocity", false),
    ("rows", false),
    ("tile_max", false),
    ("neighbor_max_tiles", false),
    ("variance", false),
    ("out_color", false),
];

/// The assembled source of one of the filters' WGSL files (`file`, one of the constants
/// above), `filters_common` included.
pub fn assemble(file: &str, source: &str) -> Result<String, GpuError> {
    WgslAssembler::new().with_include("filters_common", COMMON_WGSL).assemble(file, source)
}

/// A filtered image and what it cost.
#[derive(Clone, Debug)]
pub struct FilteredImage {
    /// Linear radiance, row-major.
    pub color: Vec<[f32; 3]>,
    /// GPU time of all the passes from timestamp queries; `None` where the device has none
    /// (then [`FilteredImage::seconds`] is the wall clock).
    pub gpu_seconds: Option<f64>,
    /// The clock [`FilteredImage::seconds`] read.
    pub timing_source: TimingSource,
    /// The passes' time on that clock (the wall clock: from submission to completion).
    pub seconds: f64,
}

/// The filters' pipelines on one device, created once; [`GpuFilters::new`] takes the
/// context by value (clone a [`GpuContext`] to share its device: the handles are
/// reference-counted).
pub struct GpuFilters {
    ctx: GpuContext,
    layout: wgpu::BindGroupLayout,
    pipelines: Pipelines,
}

struct Pipelines {
    encode_velocity: wgpu::ComputePipeline,
    tile_max_x: wgpu::ComputePipeline,
    tile_max_y: wgpu::ComputePipeline,
    neighbor_max: wgpu::ComputePipeline,
    neighbor_max_culled: wgpu::ComputePipeline,
    tile_variance: wgpu::ComputePipeline,
    mcguire_gather: wgpu::ComputePipeline,
    guertin_gather: wgpu::ComputePipeline,
}

/// Which filter a run is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Filter {
    McGuire,
    Guertin,
}

impl GpuFilters {
    /// Validates and compiles the filters' WGSL on `ctx`'s device.
    pub fn new(ctx: GpuContext) -> Result<Self, FilterError> {
        let device = &ctx.device;
        // naga on the CPU first: a WGSL error comes back with its diagnostic.
        let mut sources = Vec::new();
        for (file, source) in
            [("tiles.wgsl", TILES_WGSL), ("mcguire.wgsl", MCGUIRE_WGSL), ("guertin.wgsl", GUERTIN_WGSL)]
        {
            let wgsl = assemble(file, source)?;
            gpu::validate_wgsl(file, &wgsl)?;
            sources.push((file, wgsl));
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut entries = vec![gpu::uniform_entry(0)];
        for (i, (_, read_only)) in STORAGE.iter().enumerate() {
            entries.push(gpu::storage_entry(i as u32 + 1, *read_only));
        }
        let layout = device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("filters"), entries: &entries });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("filters"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let modules: Vec<wgpu::ShaderModule> = sources
            .into_iter()
            .map(|(file, wgsl)| {
                device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(file),
                    source: wgpu::ShaderSource::Wgsl(wgsl.into()),
                })
            })
            .collect();
        let [tiles, mcguire, guertin] = &modules[..] else { unreachable!("three files") };
        let pipeline = |module: &wgpu::ShaderModule, entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipelines = Pipelines {
            encode_velocity: pipeline(tiles, "encode_velocity"),
            tile_max_x: pipeline(tiles, "tile_max_x"),
            tile_max_y: pipeline(tiles, "tile_max_y"),
            neighbor_max: pipeline(tiles, "neighbor_max"),
            neighbor_max_culled: pipeline(tiles, "neighbor_max_culled"),
            tile_variance: pipeline(tiles, "tile_variance"),
            mcguire_gather: pipeline(mcguire, "mcguire_gather"),
            guertin_gather: pipeline(guertin, "guertin_gather"),
        };
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(
                GpuError::Validation { what: "motion blur filter pipelines".into(), message: e.to_string() }.into()
            );
        }
        Ok(GpuFilters { ctx, layout, pipelines })
    }

    /// The adapter and device.
    pub fn info(&self) -> &GpuInfo {
        &self.ctx.info
    }

    /// McGuire et al. 2012 on the GPU.
    pub fn mcguire(&self, g: &GBuffer, params: &McGuireParams) -> Result<FilteredImage, FilterError> {
        params.check()?;
        self.run(g, &params.pass_params(g), Filter::McGuire)
    }

    /// Guertin et al. 2014 on the GPU.
    pub fn guertin(&self, g: &GBuffer, params: &GuertinParams) -> Result<FilteredImage, FilterError> {
        params.check()?;
        self.run(g, &params.pass_params(g), Filter::Guertin)
    }

    fn limit(&self, what: String) -> FilterError {
        FilterError::Limit { adapter: self.ctx.info.short(), what }
    }

    /// Runs McGuire et al.'s passes (`guertin` false) or Guertin et al.'s with the pass
    /// parameters `p` as given, and reads back every intermediate buffer too: what the twin
    /// tests compare pass by pass with [`super::tiles::run`].
    pub fn run_passes(
        &self,
        g: &GBuffer,
        p: &PassParams,
        guertin: bool,
    ) -> Result<(FilteredImage, Tiles), FilterError> {
        let filter = if guertin { Filter::Guertin } else { Filter::McGuire };
        match self.run_with(g, p, filter, true)? {
            (image, Some(tiles)) => Ok((image, tiles)),
            (_, None) => unreachable!("run_with reads the intermediates back when asked"),
        }
    }

    fn run(&self, g: &GBuffer, p: &PassParams, filter: Filter) -> Result<FilteredImage, FilterError> {
        Ok(self.run_with(g, p, filter, false)?.0)
    }

    fn run_with(
        &self,
        g: &GBuffer,
        p: &PassParams,
        filter: Filter,
        intermediates: bool,
    ) -> Result<(FilteredImage, Option<Tiles>), FilterError> {
        check_gbuffer(g)?;
        let tiled = p.tile > 0 && p.tiles_x == g.width.div_ceil(p.tile) && p.tiles_y == g.height.div_ceil(p.tile);
        let sized = p.width == g.width && p.height == g.height && p.tile <= super::MAX_TILE;
        if !tiled || !sized || p.samples == 0 || p.samples > super::MAX_SAMPLES {
            return Err(FilterError::BadParam {
                name: "pass parameters",
                value: format!("{p:?}"),
                why: "must have the G-buffer's size and tiles, a tile size and a sample count in 1..=1024",
            });
        }
        let device = &self.ctx.device;
        let limits = &self.ctx.info.limits;
        let pixels = p.pixels() as u64;
        let largest = pixels * 12;
        if largest > limits.max_storage_buffer_binding_size || largest > limits.max_buffer_size {
            return Err(self.limit(format!(
                "a {}x{} image needs {largest}-byte buffers, more than the device's {}-byte storage binding limit",
                p.width, p.height, limits.max_storage_buffer_binding_size
            )));
        }
        let groups = |w: u32, h: u32| (w.div_ceil(WORKGROUP), h.div_ceil(WORKGROUP));
        let image_groups = groups(p.width, p.height);
        let max_groups = limits.max_compute_workgroups_per_dimension;
        if image_groups.0 > max_groups || image_groups.1 > max_groups {
            return Err(self.limit(format!(
                "a {}x{} image needs {}x{} workgroups, more than the {max_groups} per dimension allowed",
                p.width, p.height, image_groups.0, image_groups.1
            )));
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            // A zero-sized binding is invalid; every buffer here has at least one element.
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let scratch = |label: &str, bytes: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(4),
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let tiles = p.tiles() as u64;
        let uniform = init("filter params", bytemuck::bytes_of(p), wgpu::BufferUsages::UNIFORM);
        let buffers = [
            init("color", bytemuck::cast_slice(&g.color), wgpu::BufferUsages::STORAGE),
            init("depth", bytemuck::cast_slice(&g.depth), wgpu::BufferUsages::STORAGE),
            init(
                "velocity",
                bytemuck::cast_slice(&g.velocity),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            ),
            scratch("rows", u64::from(p.tiles_x) * u64::from(p.height) * 8, wgpu::BufferUsages::COPY_SRC),
            scratch("tile_max", tiles * 8, wgpu::BufferUsages::COPY_SRC),
            scratch("neighbor_max_tiles", tiles * 8, wgpu::BufferUsages::COPY_SRC),
            scratch("variance", tiles * 4, wgpu::BufferUsages::COPY_SRC),
            scratch("out_color", pixels * 12, wgpu::BufferUsages::COPY_SRC),
        ];
        let mut entries = vec![wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }];
        for (i, b) in buffers.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry { binding: i as u32 + 1, resource: b.as_entire_binding() });
        }
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("filters"),
            layout: &self.layout,
            entries: &entries,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(
                GpuError::Validation { what: "motion blur filter buffers".into(), message: e.to_string() }.into()
            );
        }
        let ps = &self.pipelines;
        let tile_groups = groups(p.tiles_x, p.tiles_y);
        let rows_groups = groups(p.tiles_x, p.height);
        let mut passes: Vec<(&wgpu::ComputePipeline, (u32, u32))> =
            vec![(&ps.encode_velocity, image_groups), (&ps.tile_max_x, rows_groups), (&ps.tile_max_y, tile_groups)];
        match filter {
            Filter::McGuire => {
                passes.push((&ps.neighbor_max, tile_groups));
                passes.push((&ps.mcguire_gather, image_groups));
            }
            Filter::Guertin => {
                passes.push((&ps.neighbor_max_culled, tile_groups));
                if p.variance != 0 {
                    passes.push((&ps.tile_variance, tile_groups));
                }
                passes.push((&ps.guertin_gather, image_groups));
            }
        }
        let timer = self.ctx.timer();
        // One pass: wgpu orders the dispatches' storage accesses (a barrier between each).
        let timing = timer.compute_pass("motion blur filter", |pass| {
            pass.set_bind_group(0, &bind, &[]);
            for (pipeline, (x, y)) in &passes {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(*x, *y, 1);
            }
        })?;
        let out: Vec<f32> = self.ctx.read_buffer_as(&buffers[7], ..pixels * 12)?;
        let color = out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let gpu_seconds = (timing.source == TimingSource::Timestamps).then_some(timing.seconds);
        let image = FilteredImage { color, gpu_seconds, timing_source: timing.source, seconds: timing.seconds };
        if !intermediates {
            return Ok((image, None));
        }
        let pairs = |b: &wgpu::Buffer, n: u64| -> Result<Vec<[f32; 2]>, GpuError> {
            let v: Vec<f32> = self.ctx.read_buffer_as(b, ..n * 8)?;
            Ok(v.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
        };
        let tiles = Tiles {
            velocity: pairs(&buffers[2], pixels)?,
            rows: pairs(&buffers[3], u64::from(p.tiles_x) * u64::from(p.height))?,
            tile_max: pairs(&buffers[4], tiles)?,
            neighbor_max: pairs(&buffers[5], tiles)?,
            variance: self.ctx.read_buffer_as(&buffers[6], ..tiles * 4)?,
        };
        Ok((image, Some(tiles)))
    }
}
