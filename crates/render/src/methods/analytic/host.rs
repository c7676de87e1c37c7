//! The host of the analytic kernel: [`GpuAnalytic`] compiles `analytic_pixel.wgsl` (which
//! includes the tracer's kernel for its integrator) once per specialisation and renders a
//! frame's views. The per-pixel interval lists live in one storage buffer of `budget + 1`
//! entries per pixel, beside each pixel's resumable state; an image whose lists would exceed
//! [`LIST_BYTES`] (or the device's storage binding limit) is rendered in bands of rows that
//! reuse them. A hardware adapter renders a band in one dispatch. A software adapter
//! (llvmpipe, whose loops stop silently after 65535 iterations per invocation group) renders
//! it in passes of at most [`SOFTWARE_STEPS`] steps per pixel, repeated until every pixel is
//! done; a pass whose group still met the limit (the kernel detects it) is thrown away and
//! the band begins again with half the steps per pass. Either way the image is the same bits:
//! the steps are the twin's operations in the twin's order.

use std::collections::HashMap;
use std::sync::Mutex;

use gpu::wgpu::util::DeviceExt as _;
use gpu::{GpuContext, GpuError, GpuInfo, TimingSource, wgpu};
use study::scene::FrameScene;

use super::prepare::{ANALYTIC_STREAM, GpuInterval, PixelStats, Prepared};
use crate::io::LinearImage;
use crate::methods::analytic::frame::RasterStats;
use crate::methods::analytic::{AnalyticError, AnalyticFrame, AnalyticParams, supersample};
use crate::methods::tracer::GpuEnvironment;
use crate::shading::gpu::assembler::assembler;
use crate::shading::gpu::params::{ParamsError, Specialisation};

/// The most bytes of interval lists one band uses (64 MiB: a 640-pixel row at a budget of 8
/// is 184 KiB, so the study's frames are one band up to a budget of 11).
pub const LIST_BYTES: u64 = 64 << 20;
const WORKGROUP: u32 = 8;
/// Bytes of a pixel's `Resume` state in the kernel.
const RESUME_BYTES: u64 = 160;
/// Steps per pixel a pass takes at first on a software adapter (halved while a pass meets
/// the device's loop limit): llvmpipe ends an invocation group's loops after 65535
/// iterations in all, and a step runs at most a few hundred.
pub const SOFTWARE_STEPS: u32 = 64;

/// Errors of the GPU rasterizer.
#[derive(Debug, thiserror::Error)]
pub enum GpuAnalyticError {
    /// The device failed or rejected the work.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The frame cannot be expressed in the kernel's parameters.
    #[error("GPU analytic rasterizer: {0}")]
    Params(#[from] ParamsError),
    /// Settings outside their ranges.
    #[error(transparent)]
    Settings(#[from] AnalyticError),
    /// The frame needs more than the device allows.
    #[error("GPU analytic rasterizer on {adapter}: {what}")]
    Limit {
        /// The adapter.
        adapter: String,
        /// The limit and the need.
        what: String,
    },
}

/// One view rendered by the kernel, with what the tests compare.
#[derive(Clone, Debug)]
pub struct GpuView {
    /// Linear radiance (or coverage colours when not shading).
    pub image: LinearImage,
    /// The fraction of the shutter covered, per pixel.
    pub coverage: Vec<f32>,
    /// Counts per pixel.
    pub stats: Vec<PixelStats>,
    /// GPU time of the dispatches (timestamps where the device has them, else wall time).
    pub seconds: f64,
    /// Which clock `seconds` is.
    pub timing_source: TimingSource,
}

/// The analytic rasterizer's kernel on one device.
pub struct GpuAnalytic {
    ctx: GpuContext,
    module: wgpu::ShaderModule,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: Mutex<HashMap<(Specialisation, bool), wgpu::ComputePipeline>>,
}

/// The assembled kernel: `analytic_pixel.wgsl` with the shading layer (`radiance.wgsl`) and the sampler included.
pub fn kernel_source() -> Result<String, GpuError> {
    let mut a = assembler();
    a.constant_u32("ANALYTIC_STREAM", ANALYTIC_STREAM).constant_u32("ANALYTIC_TILE", super::prepare::TILE);
    a.assemble("analytic_pixel.wgsl", include_str!("analytic_pixel.wgsl"))
}

/// Sums the per-pixel counts into the CPU rasterizer's [`RasterStats`].
pub fn raster_stats(stats: &[PixelStats]) -> RasterStats {
    let mut out = RasterStats::default();
    for s in stats {
        out.pixels += 1;
        out.intervals += u64::from(s.offered);
        out.max_intervals = out.max_intervals.max(s.offered);
        out.shaded += u64::from(s.kept);
        out.merges += u64::from(s.merges);
        out.nonfinite += u64::from(s.nonfinite);
    }
    out
}

impl GpuAnalytic {
    /// Validates and compiles the kernel on `ctx`'s device.
    pub fn new(ctx: GpuContext) -> Result<Self, GpuError> {
        let source = kernel_source()?;
        gpu::validate_wgsl("analytic_pixel.wgsl", &source)?;
        let module = ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("analytic_pixel.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        // Explicit, so the coverage specialisation (which reads no environment) binds the same.
        let layout = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("analytic"),
            entries: &[
                gpu::storage_entry(0, true),
                gpu::storage_entry(1, true),
                gpu::uniform_entry(4),
                gpu::storage_entry(5, true),
                gpu::storage_entry(6, true),
                gpu::storage_entry(7, false),
                gpu::storage_entry(8, false),
                gpu::storage_entry(10, false),
                gpu::storage_entry(11, false),
            ],
        });
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("analytic"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        Ok(GpuAnalytic { ctx, module, layout, pipeline_layout, pipelines: Mutex::new(HashMap::new()) })
    }

    /// The adapter and device.
    pub fn info(&self) -> &GpuInfo {
        &self.ctx.info
    }

    fn limit(&self, what: String) -> GpuAnalyticError {
        GpuAnalyticError::Limit { adapter: self.ctx.info.short(), what }
    }

    fn pipeline(&self, spec: Specialisation, shade: bool) -> Result<wgpu::ComputePipeline, GpuError> {
        let mut pipelines = self.pipelines.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(p) = pipelines.get(&(spec, shade)) {
            return Ok(p.clone());
        }
        let scope = self.ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let [a, b, c] = spec.constants();
        let constants = [a, b, c, ("SHADE", if shade { 1.0 } else { 0.0 })];
        let pipeline = self.ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("analytic_pixel"),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some("analytic_pixel"),
            compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: format!("analytic pipeline {spec:?}"), message: e.to_string() });
        }
        pipelines.insert((spec, shade), pipeline.clone());
        Ok(pipeline)
    }

    /// Renders every view of `scene` lit by `env` (uploaded by the tracer on this device).
    pub fn render_frame(
        &self,
        scene: &FrameScene,
        env: &GpuEnvironment,
        params: &AnalyticParams,
    ) -> Result<AnalyticFrame, GpuAnalyticError> {
        params.check()?;
        crate::methods::analytic::check_motion(scene)?;
        let spec = Specialisation::of(scene);
        let mut eyes = Vec::with_capacity(scene.views.len());
        let mut stats = RasterStats::default();
        let mut gpu_seconds = Some(0.0);
        let n = params.supersampling;
        let scaled = supersample::scaled(scene, n);
        for view in &scaled.views {
            let prepared = Prepared::new(&scaled, view, env.tables(), params)?;
            let v = self.render_view(&prepared, env, spec, true)?;
            stats.add(&raster_stats(&v.stats));
            gpu_seconds = gpu_seconds.filter(|_| v.timing_source == TimingSource::Timestamps).map(|t| t + v.seconds);
            eyes.push(supersample::downsample(&v.image, n));
        }
        let lighting = u64::from(params.lighting_samples.unwrap_or(scene.samples_per_pixel).max(1));
        Ok(AnalyticFrame { eyes, lighting_samples: stats.shaded * lighting, stats, gpu_seconds })
    }

    /// Runs the kernel over one prepared view, specialised as `spec` (which must cover the
    /// scene), shading (`shade`) or writing coverage.
    pub fn render_view(
        &self,
        prepared: &Prepared,
        env: &GpuEnvironment,
        spec: Specialisation,
        shade: bool,
    ) -> Result<GpuView, GpuAnalyticError> {
        let device = &self.ctx.device;
        let limits = &self.ctx.info.limits;
        let pipeline = self.pipeline(spec, shade)?;
        let raster = prepared.raster;
        let (w, h) = (raster.width, raster.height);
        let pixels = u64::from(w) * u64::from(h);
        let list_row = u64::from(w) * (u64::from(raster.budget) + 1) * std::mem::size_of::<GpuInterval>() as u64;
        let resume_row = u64::from(w) * RESUME_BYTES;
        let list_limit = LIST_BYTES.min(limits.max_storage_buffer_binding_size).min(limits.max_buffer_size);
        if list_row.max(resume_row) > list_limit {
            return Err(self.limit(format!(
                "one row of {w} pixels needs {} bytes of interval lists, more than the {list_limit} allowed",
                list_row.max(resume_row)
            )));
        }
        let band = ((list_limit / list_row.max(resume_row)).min(u64::from(h)) as u32).max(1);
        let max_groups = limits.max_compute_workgroups_per_dimension;
        if w.div_ceil(WORKGROUP) > max_groups || band.div_ceil(WORKGROUP) > max_groups {
            return Err(self.limit(format!("an image {w}x{h} needs more than {max_groups} workgroups per dimension")));
        }
        let out_bytes = pixels * 32;
        if out_bytes > limits.max_storage_buffer_binding_size {
            return Err(self.limit(format!(
                "an image {w}x{h} needs {out_bytes}-byte outputs, more than the {}-byte storage binding limit",
                limits.max_storage_buffer_binding_size
            )));
        }
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let init = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
        };
        let storage = |label: &str, bytes: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes.max(16),
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let frame = init("frame params", bytemuck::bytes_of(&prepared.frame), wgpu::BufferUsages::STORAGE);
        // A binding may not be empty: a frame with no triangle still binds one (unread).
        let placeholder = [super::prepare::GpuTriangle::default()];
        let tris: &[super::prepare::GpuTriangle] =
            if prepared.triangles.is_empty() { &placeholder } else { &prepared.triangles };
        let triangles = init("triangles", bytemuck::cast_slice(tris), wgpu::BufferUsages::STORAGE);
        let bins = init("tile bins", bytemuck::cast_slice(&prepared.bins), wgpu::BufferUsages::STORAGE);
        let lists = storage("interval lists", list_row * u64::from(band), wgpu::BufferUsages::empty());
        let resume = storage("resume", resume_row * u64::from(band), wgpu::BufferUsages::empty());
        let progress = storage("progress", 8, wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
        let out_pixels = storage("analytic pixels", out_bytes, wgpu::BufferUsages::COPY_SRC);
        let uniform = init(
            "raster params",
            bytemuck::bytes_of(&raster),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let entries = [
            wgpu::BindGroupEntry { binding: 0, resource: frame.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: env.buffer().as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: uniform.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 5, resource: triangles.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 6, resource: bins.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 7, resource: lists.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 8, resource: out_pixels.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 10, resource: resume.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 11, resource: progress.as_entire_binding() },
        ];
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("analytic"),
            layout: &self.layout,
            entries: &entries,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "analytic buffers".into(), message: e.to_string() }.into());
        }
        // A hardware adapter does each band in one pass; a software one in passes of bounded
        // steps (the kernel's "resumable steps"), fewer per pass while one meets the limit.
        let software = self.ctx.info.is_software;
        let mut steps = if software { SOFTWARE_STEPS } else { 0 };
        let mut light_chunk = u32::from(software);
        let timer = self.ctx.timer();
        let mut seconds = 0.0;
        let mut timing_source = None;
        for first_row in (0..h).step_by(band as usize) {
            let rows = band.min(h - first_row);
            let mut pass_index = 0;
            loop {
                let p = super::prepare::RasterParams {
                    first_row,
                    band_rows: rows,
                    pass_index,
                    steps,
                    light_chunk,
                    ..raster
                };
                self.ctx.queue.write_buffer(&uniform, 0, bytemuck::bytes_of(&p));
                self.ctx.queue.write_buffer(&progress, 0, &[0; 8]);
                let timing = timer.compute_pass("analytic rasterizer", |pass| {
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(w.div_ceil(WORKGROUP), rows.div_ceil(WORKGROUP), 1);
                })?;
                seconds += timing.seconds;
                timing_source.get_or_insert(timing.source);
                let [pending, cut]: [u32; 2] = match self.ctx.read_buffer_as::<u32>(&progress, ..8)?[..] {
                    [a, b] => [a, b],
                    _ => {
                        return Err(GpuError::Validation {
                            what: "analytic progress".into(),
                            message: "short read".into(),
                        }
                        .into());
                    }
                };
                if cut > 0 {
                    if steps == 1 {
                        return Err(self.limit(format!(
                            "{cut} pixels of rows {first_row}..{} need more loop iterations in one step than the device allows",
                            first_row + rows
                        )));
                    }
                    // Start the band again with half the steps per pass.
                    steps = if steps == 0 { SOFTWARE_STEPS } else { steps / 2 };
                    light_chunk = 1;
                    pass_index = 0;
                    continue;
                }
                if pending == 0 {
                    break;
                }
                pass_index += 1;
            }
        }
        let out: Vec<[u32; 8]> = self.ctx.read_buffer_as(&out_pixels, ..out_bytes)?;
        let colour: Vec<[f32; 4]> = out.iter().map(|o| [0, 1, 2, 3].map(|i| f32::from_bits(o[i]))).collect();
        let stats: Vec<PixelStats> =
            out.iter().map(|o| PixelStats { offered: o[4], kept: o[5], merges: o[6], nonfinite: o[7] }).collect();
        let mut image = LinearImage::new(w, h);
        for (dst, c) in image.pixels.iter_mut().zip(&colour) {
            *dst = [c[0], c[1], c[2]];
        }
        Ok(GpuView {
            image,
            coverage: colour.iter().map(|c| c[3]).collect(),
            stats,
            seconds,
            timing_source: timing_source.unwrap_or(TimingSource::WallClock),
        })
    }
}
