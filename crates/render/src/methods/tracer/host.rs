//! The GPU tracer's host side: [`GpuTracer`] compiles `trace_batch.wgsl` once per
//! [`Specialisation`] (pipeline override constants), uploads an environment once
//! ([`GpuEnvironment`]) and renders a frame's eyes as batches of samples, one dispatch
//! each, accumulated in a storage buffer.
//!
//! A frame is submitted ([`GpuTracer::submit`]) and collected later ([`PendingFrame::finish`]),
//! so a caller can submit the next frame before reading this one back: the GPU then works
//! while the CPU reads, encodes and writes (what `render_set` does). A batch holds at most
//! [`SAMPLES_PER_DISPATCH`] camera samples on a hardware adapter (a 640 x 360 eye at 512
//! samples is 4 dispatches of about 2 ms each at 20 G samples/s, 70 ms at 0.5 G/s: far from
//! any driver watchdog's 2 s) and [`SAMPLES_PER_DISPATCH_SOFTWARE`] on a software one (29
//! dispatches, a few seconds each on lavapipe); each is its own submission. The dispatch
//! grid is checked against the device's workgroup limit and the buffers against its
//! storage binding limit.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::Instant;

use gpu::wgpu::util::DeviceExt as _;
use gpu::{GpuContext, GpuError, GpuInfo, wgpu};
use study::scene::FrameScene;

use crate::env::EnvironmentMap;
use crate::io::LinearImage;
use crate::shading::gpu::params::{Accum, Batch, EnvTables, FrameParams, ParamsError, Specialisation};

/// Camera samples one dispatch traces at most on a hardware adapter: 2^25.
pub const SAMPLES_PER_DISPATCH: u64 = 1 << 25;
/// Camera samples one dispatch traces at most on a software adapter: 2^22.
pub const SAMPLES_PER_DISPATCH_SOFTWARE: u64 = 1 << 22;

const WORKGROUP: u32 = 8;

/// Errors of the GPU tracer.
#[derive(Debug, thiserror::Error)]
pub enum GpuTracerError {
    /// The device failed or rejected the work.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The frame cannot be expressed in the kernel's parameters.
    #[error("GPU tracer: {0}")]
    Params(#[from] ParamsError),
    /// The frame or map needs more than the device allows.
    #[error("GPU tracer on {adapter}: {what}")]
    Limit {
        /// The adapter.
        adapter: String,
        /// The limit and the need.
        what: String,
    },
}

/// An environment map's tables on the device.
pub struct GpuEnvironment {
    buffer: wgpu::Buffer,
    tables: EnvTables,
}

impl GpuEnvironment {
    /// The tables as uploaded (what the CPU twin reads).
    pub fn tables(&self) -> &EnvTables {
        &self.tables
    }

    /// The tables' buffer (what kernels bind).
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}

/// A rendered frame of the GPU tracer.
#[derive(Clone, Debug)]
pub struct GpuFrame {
    /// One linear image per view of the scene, in order.
    pub eyes: Vec<LinearImage>,
    /// Samples whose radiance was NaN or infinite (discarded).
    pub nonfinite_samples: u64,
    /// Camera samples traced.
    pub camera_samples: u64,
    /// GPU time of all the frame's dispatches (timestamp queries), when the device has them.
    pub gpu_seconds: Option<f64>,
    /// Wall time from submission to the readback's end.
    pub wall_seconds: f64,
    /// Dispatches (batches x eyes).
    pub dispatches: u32,
    /// The frame at each earlier checkpoint of [`GpuTracer::submit_nested`] (prefixes of the
    /// same sample stream), fewest samples first; empty for a plain frame.
    pub prefixes: Vec<GpuPrefix>,
}

/// A frame read out after the first `samples_per_pixel` samples of a longer stream.
#[derive(Clone, Debug)]
pub struct GpuPrefix {
    /// Samples per pixel so far.
    pub samples_per_pixel: u32,
    /// One linear image per view: the mean of those samples.
    pub eyes: Vec<LinearImage>,
    /// Discarded samples among them.
    pub nonfinite_samples: u64,
    /// Camera samples traced so far (all eyes).
    pub camera_samples: u64,
    /// GPU time from the first dispatch to the end of this prefix's last one, when the
    /// device has timestamps: the cost of rendering this sample count alone.
    pub gpu_seconds: Option<f64>,
}

struct PendingEye {
    width: u32,
    height: u32,
    /// One readback buffer per checkpoint.
    staging: Vec<wgpu::Buffer>,
    /// Timestamps: the first dispatch's start, then each checkpoint's end.
    timestamps: Option<wgpu::Buffer>,
}

/// A submitted frame; [`PendingFrame::finish`] waits for it and reads it back.
pub struct PendingFrame<'a> {
    tracer: &'a GpuTracer,
    eyes: Vec<PendingEye>,
    checkpoints: Vec<u32>,
    dispatches: u32,
    submitted: Instant,
}

/// The GPU distribution ray tracer on one device.
pub struct GpuTracer {
    ctx: GpuContext,
    module: wgpu::ShaderModule,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: Mutex<HashMap<Specialisation, wgpu::ComputePipeline>>,
    timestamps: bool,
    samples_per_dispatch: u64,
}

/// The device the tracer asks for: the default request (timestamps where offered) with the
/// storage-binding and buffer-size limits raised to whatever the adapter offers, so images
/// larger than wgpu's default 128 MiB binding render where the hardware allows them.
pub fn device_request() -> gpu::DeviceRequest {
    let mut request = gpu::DeviceRequest { label: "blurlab tracer", ..gpu::DeviceRequest::default() };
    // Clamped to the adapter's own limits by `gpu::acquire`.
    request.limits.max_storage_buffer_binding_size = u64::MAX;
    request.limits.max_buffer_size = u64::MAX;
    request
}

/// The assembled kernel source (sampler included, sampling dimensions declared).
pub fn kernel_source() -> Result<String, GpuError> {
    crate::shading::gpu::assembler::assembler().assemble("trace_batch.wgsl", include_str!("trace_batch.wgsl"))
}

impl GpuTracer {
    /// Compiles the kernel for `ctx`'s device.
    pub fn new(ctx: GpuContext) -> Result<Self, GpuError> {
        let source = kernel_source()?;
        gpu::validate_wgsl("trace_batch.wgsl", &source)?;
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("trace_batch.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tracer"),
            entries: &[
                gpu::storage_entry(0, true),
                gpu::storage_entry(1, true),
                gpu::storage_entry(2, false),
                gpu::uniform_entry(3),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("tracer"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let timestamps = ctx.info.features.contains(wgpu::Features::TIMESTAMP_QUERY);
        let samples_per_dispatch =
            if ctx.info.is_software { SAMPLES_PER_DISPATCH_SOFTWARE } else { SAMPLES_PER_DISPATCH };
        Ok(GpuTracer {
            ctx,
            module,
            layout,
            pipeline_layout,
            pipelines: Mutex::new(HashMap::new()),
            timestamps,
            samples_per_dispatch,
        })
    }

    /// The same tracer with at most `samples` camera samples per dispatch (at least one
    /// sample per pixel is always dispatched).
    pub fn with_samples_per_dispatch(mut self, samples: u64) -> Self {
        self.samples_per_dispatch = samples;
        self
    }

    /// The adapter and device.
    pub fn info(&self) -> &GpuInfo {
        &self.ctx.info
    }

    /// Uploads `env`'s tables.
    pub fn environment(&self, env: &EnvironmentMap) -> Result<GpuEnvironment, GpuTracerError> {
        let tables = EnvTables::new(env);
        let limit = self.ctx.info.limits.max_storage_buffer_binding_size;
        if tables.byte_len() > limit {
            return Err(self.limit(format!(
                "the environment map's tables need {} bytes, more than the {limit}-byte storage binding limit",
                tables.byte_len()
            )));
        }
        let buffer = self.ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("environment"),
            contents: bytemuck::cast_slice(&tables.words),
            usage: wgpu::BufferUsages::STORAGE,
        });
        Ok(GpuEnvironment { buffer, tables })
    }

    fn limit(&self, what: String) -> GpuTracerError {
        GpuTracerError::Limit { adapter: self.ctx.info.short(), what }
    }

    /// The pipeline of `spec`, compiled on first use.
    pub fn pipeline(&self, spec: Specialisation) -> Result<wgpu::ComputePipeline, GpuError> {
        let mut pipelines = self.pipelines.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(p) = pipelines.get(&spec) {
            return Ok(p.clone());
        }
        let scope = self.ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let constants = spec.constants();
        let pipeline = self.ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("trace_batch"),
            layout: Some(&self.pipeline_layout),
            module: &self.module,
            entry_point: Some("trace_batch"),
            compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: format!("tracer pipeline {spec:?}"), message: e.to_string() });
        }
        pipelines.insert(spec, pipeline.clone());
        Ok(pipeline)
    }

    /// Renders `scene` with its cheapest specialisation and waits for it.
    pub fn render_frame(&self, scene: &FrameScene, env: &GpuEnvironment) -> Result<GpuFrame, GpuTracerError> {
        self.submit(scene, env)?.finish()
    }

    /// Renders `scene` with the kernel specialised as `spec` (which must cover the scene:
    /// time sampling on where the scene moves during an open shutter, its material) and waits.
    pub fn render_frame_with(
        &self,
        scene: &FrameScene,
        env: &GpuEnvironment,
        spec: Specialisation,
    ) -> Result<GpuFrame, GpuTracerError> {
        self.submit_with(scene, env, spec, &[scene.samples_per_pixel])?.finish()
    }

    /// Submits `scene` with its cheapest specialisation without waiting.
    pub fn submit(&self, scene: &FrameScene, env: &GpuEnvironment) -> Result<PendingFrame<'_>, GpuTracerError> {
        self.submit_with(scene, env, Specialisation::of(scene), &[scene.samples_per_pixel])
    }

    /// Submits `scene` and also reads it out after the first `k` samples per pixel for every
    /// `k` of `checkpoints` (increasing, each below `scene.samples_per_pixel`): the frame at
    /// several sample counts from one stream ([`GpuFrame::prefixes`]).
    pub fn submit_nested(
        &self,
        scene: &FrameScene,
        env: &GpuEnvironment,
        checkpoints: &[u32],
    ) -> Result<PendingFrame<'_>, GpuTracerError> {
        let spp = scene.samples_per_pixel;
        let mut all: Vec<u32> = checkpoints.iter().copied().filter(|&k| k > 0 && k < spp).collect();
        all.sort_unstable();
        all.dedup();
        all.push(spp);
        self.submit_with(scene, env, Specialisation::of(scene), &all)
    }

    /// `checkpoints`: increasing sample counts, the last `scene.samples_per_pixel`.
    fn submit_with(
        &self,
        scene: &FrameScene,
        env: &GpuEnvironment,
        spec: Specialisation,
        checkpoints: &[u32],
    ) -> Result<PendingFrame<'_>, GpuTracerError> {
        let device = &self.ctx.device;
        let pipeline = self.pipeline(spec)?;
        let submitted = Instant::now();
        debug_assert_eq!(checkpoints.last(), Some(&scene.samples_per_pixel));
        let limits = &self.ctx.info.limits;
        let mut eyes = Vec::with_capacity(scene.views.len());
        let mut dispatches = 0u32;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        for view in &scene.views {
            let params = FrameParams::new(scene, view, &env.tables)?;
            let (w, h) = (params.width, params.height);
            let groups = (w.div_ceil(WORKGROUP), h.div_ceil(WORKGROUP));
            let max_groups = limits.max_compute_workgroups_per_dimension;
            if groups.0 > max_groups || groups.1 > max_groups {
                return Err(self.limit(format!(
                    "an image {w}x{h} needs {}x{} workgroups, more than the {max_groups} per dimension allowed",
                    groups.0, groups.1
                )));
            }
            let pixels = u64::from(w) * u64::from(h);
            let accum_bytes = pixels * std::mem::size_of::<Accum>() as u64;
            if accum_bytes > limits.max_storage_buffer_binding_size {
                return Err(self.limit(format!(
                    "an image {w}x{h} needs a {accum_bytes}-byte accumulator, more than the {}-byte storage binding limit",
                    limits.max_storage_buffer_binding_size
                )));
            }
            let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("frame params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::STORAGE,
            });
            // wgpu zero-initialises new buffers.
            let accum = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("accumulator"),
                size: accum_bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let staging: Vec<wgpu::Buffer> = checkpoints
                .iter()
                .map(|_| {
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("accumulator readback"),
                        size: accum_bytes,
                        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    })
                })
                .collect();
            // Batches of at most `per_batch` samples, split at every checkpoint; `ends[j]` is
            // the batch that completes checkpoint j.
            let per_batch = (self.samples_per_dispatch / pixels).clamp(1, u64::from(u32::MAX)) as u32;
            let mut batches = Vec::new();
            let mut ends = Vec::new();
            let mut first = 0u32;
            for &checkpoint in checkpoints {
                while first < checkpoint {
                    let count = per_batch.min(checkpoint - first);
                    batches.push(Batch { first_sample: first, count, pad: [0; 2] });
                    first += count;
                }
                ends.push(batches.len().checked_sub(1));
            }
            let stamps = 1 + checkpoints.len() as u32;
            let queries = (self.timestamps && !batches.is_empty()).then(|| {
                let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("tracer timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: stamps,
                });
                let bytes = 8 * u64::from(stamps);
                let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamp resolve"),
                    size: bytes,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let read = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamp readback"),
                    size: bytes,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                (set, resolve, read, bytes)
            });
            // Checkpoints with no samples of their own (only a 0-sample frame) are copied first.
            let mut encoder = device.create_command_encoder(&Default::default());
            for (j, end) in ends.iter().enumerate() {
                if end.is_none() {
                    encoder.copy_buffer_to_buffer(&accum, 0, &staging[j], 0, accum_bytes);
                }
            }
            self.ctx.queue.submit([encoder.finish()]);
            let last = batches.len().saturating_sub(1);
            for (i, batch) in batches.iter().enumerate() {
                let batch_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("batch"),
                    contents: bytemuck::bytes_of(batch),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("tracer"),
                    layout: &self.layout,
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: params_buffer.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: env.buffer.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 2, resource: accum.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 3, resource: batch_buffer.as_entire_binding() },
                    ],
                });
                let mut encoder =
                    device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("batch") });
                let completes = ends.iter().position(|e| *e == Some(i));
                {
                    // Only the first pass and those that complete a checkpoint write timestamps
                    // (a pass may not name an empty pair).
                    let marked = i == 0 || completes.is_some();
                    let timestamp_writes =
                        queries.as_ref().filter(|_| marked).map(|(set, ..)| wgpu::ComputePassTimestampWrites {
                            query_set: set,
                            beginning_of_pass_write_index: (i == 0).then_some(0),
                            end_of_pass_write_index: completes.map(|j| 1 + j as u32),
                        });
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("trace_batch"),
                        timestamp_writes,
                    });
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(groups.0, groups.1, 1);
                }
                if let Some(j) = completes {
                    encoder.copy_buffer_to_buffer(&accum, 0, &staging[j], 0, accum_bytes);
                }
                if i == last
                    && let Some((set, resolve, read, bytes)) = &queries
                {
                    encoder.resolve_query_set(set, 0..stamps, resolve, 0);
                    encoder.copy_buffer_to_buffer(resolve, 0, read, 0, *bytes);
                }
                self.ctx.queue.submit([encoder.finish()]);
                dispatches += 1;
            }
            eyes.push(PendingEye { width: w, height: h, staging, timestamps: queries.map(|(_, _, read, _)| read) });
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "tracer dispatch".into(), message: e.to_string() }.into());
        }
        Ok(PendingFrame { tracer: self, eyes, checkpoints: checkpoints.to_vec(), dispatches, submitted })
    }
}

fn map_read(ctx: &GpuContext, buffer: &wgpu::Buffer, what: &str) -> Result<Vec<u8>, GpuError> {
    let slice = buffer.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        // The receiver waits below; a closed channel means it gave up already.
        let _ = tx.send(r);
    });
    ctx.device
        .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
        .map_err(|source| GpuError::Poll { what: what.to_owned(), source })?;
    match rx.recv() {
        Ok(Ok(())) => {}
        Ok(Err(source)) => return Err(GpuError::Map { what: what.to_owned(), source }),
        Err(_) => {
            return Err(GpuError::Readback { what: what.to_owned(), message: "the map callback never ran".into() });
        }
    }
    let bytes = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Readback { what: what.to_owned(), message: e.to_string() })?
        .to_vec();
    buffer.unmap();
    Ok(bytes)
}

impl PendingFrame<'_> {
    /// Waits for the frame and reads it back.
    pub fn finish(self) -> Result<GpuFrame, GpuTracerError> {
        let ctx = &self.tracer.ctx;
        let spp = *self.checkpoints.last().unwrap_or(&0);
        let n = self.checkpoints.len();
        let mut levels: Vec<GpuPrefix> = self
            .checkpoints
            .iter()
            .map(|&k| GpuPrefix {
                samples_per_pixel: k,
                eyes: Vec::with_capacity(self.eyes.len()),
                nonfinite_samples: 0,
                camera_samples: 0,
                gpu_seconds: self.tracer.timestamps.then_some(0.0),
            })
            .collect();
        let period_ns = f64::from(ctx.queue.get_timestamp_period());
        for eye in &self.eyes {
            let pixels = u64::from(eye.width) * u64::from(eye.height);
            let ticks: Option<Vec<u64>> = match &eye.timestamps {
                Some(read) => Some(bytemuck::pod_collect_to_vec(&map_read(ctx, read, "timestamps")?)),
                None => None,
            };
            for (j, level) in levels.iter_mut().enumerate() {
                let bytes = map_read(ctx, &eye.staging[j], "the tracer's accumulator")?;
                let accum: &[Accum] = bytemuck::cast_slice(&bytes);
                // The kernel adds samples divided by the full count: a prefix is rescaled.
                let scale = if level.samples_per_pixel > 0 { spp as f32 / level.samples_per_pixel as f32 } else { 0.0 };
                let mut img = LinearImage::new(eye.width, eye.height);
                for (dst, a) in img.pixels.iter_mut().zip(accum) {
                    *dst = if j + 1 == n { a.sum } else { a.sum.map(|c| c * scale) };
                    level.nonfinite_samples += u64::from(a.nonfinite);
                }
                level.eyes.push(img);
                level.camera_samples += pixels * u64::from(level.samples_per_pixel);
                level.gpu_seconds = match (level.gpu_seconds, &ticks) {
                    (Some(total), Some(t)) if level.samples_per_pixel > 0 => {
                        Some(total + t[1 + j].wrapping_sub(t[0]) as f64 * period_ns * 1e-9)
                    }
                    (Some(total), _) if level.samples_per_pixel == 0 => Some(total),
                    _ => None,
                };
            }
        }
        let full = levels.pop().unwrap_or(GpuPrefix {
            samples_per_pixel: 0,
            eyes: Vec::new(),
            nonfinite_samples: 0,
            camera_samples: 0,
            gpu_seconds: None,
        });
        Ok(GpuFrame {
            eyes: full.eyes,
            nonfinite_samples: full.nonfinite_samples,
            camera_samples: full.camera_samples,
            gpu_seconds: full.gpu_seconds,
            wall_seconds: self.submitted.elapsed().as_secs_f64(),
            dispatches: self.dispatches,
            prefixes: levels,
        })
    }
}
