//! GPU time of recorded work: from timestamp queries where the device has the feature each
//! kind of measurement needs, from the wall clock (submit to completion) otherwise.
//!
//! | measurement | timestamps from | feature |
//! | --- | --- | --- |
//! | [`GpuTimer::compute_pass`], [`GpuTimer::render_pass`] | the pass's timestamp writes | `TIMESTAMP_QUERY` |
//! | [`GpuTimer::commands`] | `write_timestamp` on the encoder | `TIMESTAMP_QUERY_INSIDE_ENCODERS` |
//! | [`GpuTimer::inside_compute_pass`] | `write_timestamp` inside the pass | `TIMESTAMP_QUERY_INSIDE_PASSES` |
//!
//! Ticks are scaled by [`wgpu::Queue::get_timestamp_period`] (nanoseconds per tick). The wall
//! clock includes the submission's overhead and, for [`GpuTimer::inside_compute_pass`], the
//! untimed part of the pass: each [`GpuTiming`] says which clock it read.

use std::time::Instant;

use crate::GpuError;

/// Which clock a [`GpuTiming`] read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimingSource {
    /// GPU timestamp queries around the work.
    Timestamps,
    /// The CPU's clock from submitting the work until the device reported it complete.
    WallClock,
}

/// A measured duration and the clock it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuTiming {
    /// Seconds.
    pub seconds: f64,
    /// The clock.
    pub source: TimingSource,
}

/// Measures recorded work on one device; reusable, one measurement at a time.
pub struct GpuTimer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Two timestamp slots (start, end) and the buffer they resolve into, where the device
    /// has `TIMESTAMP_QUERY`.
    queries: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

impl GpuTimer {
    /// A timer on `device` (cloned handles; the device keeps its resources alive).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> GpuTimer {
        let queries = device.features().contains(wgpu::Features::TIMESTAMP_QUERY).then(|| {
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("GpuTimer"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("GpuTimer resolve"),
                size: 2 * u64::from(wgpu::QUERY_SIZE),
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve)
        });
        GpuTimer { device: device.clone(), queue: queue.clone(), queries }
    }

    fn has(&self, feature: wgpu::Features) -> bool {
        self.queries.is_some() && self.device.features().contains(feature)
    }

    /// The clock [`GpuTimer::compute_pass`] and [`GpuTimer::render_pass`] read.
    pub fn pass_source(&self) -> TimingSource {
        if self.has(wgpu::Features::TIMESTAMP_QUERY) { TimingSource::Timestamps } else { TimingSource::WallClock }
    }

    /// The clock [`GpuTimer::commands`] reads.
    pub fn commands_source(&self) -> TimingSource {
        if self.has(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
            TimingSource::Timestamps
        } else {
            TimingSource::WallClock
        }
    }

    /// The clock [`GpuTimer::inside_compute_pass`] reads.
    pub fn inside_pass_source(&self) -> TimingSource {
        if self.has(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES) {
            TimingSource::Timestamps
        } else {
            TimingSource::WallClock
        }
    }

    /// The query set, where `source` says timestamps are used.
    fn set_for(&self, source: TimingSource) -> Option<&wgpu::QuerySet> {
        match source {
            TimingSource::Timestamps => self.queries.as_ref().map(|(set, _)| set),
            TimingSource::WallClock => None,
        }
    }

    /// The GPU time of one compute pass whose commands `record` records.
    pub fn compute_pass(
        &self,
        label: &str,
        record: impl FnOnce(&mut wgpu::ComputePass<'_>),
    ) -> Result<GpuTiming, GpuError> {
        let set = self.set_for(self.pass_source());
        self.measure(set.is_some(), |encoder| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: set.map(|query_set| wgpu::ComputePassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            record(&mut pass);
        })
    }

    /// The GPU time of one render pass described by `descriptor` (its own `timestamp_writes`
    /// are replaced) whose commands `record` records.
    pub fn render_pass(
        &self,
        descriptor: &wgpu::RenderPassDescriptor<'_>,
        record: impl FnOnce(&mut wgpu::RenderPass<'_>),
    ) -> Result<GpuTiming, GpuError> {
        let set = self.set_for(self.pass_source());
        self.measure(set.is_some(), |encoder| {
            let descriptor = wgpu::RenderPassDescriptor {
                timestamp_writes: set.map(|query_set| wgpu::RenderPassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
                ..descriptor.clone()
            };
            let mut pass = encoder.begin_render_pass(&descriptor);
            record(&mut pass);
        })
    }

    /// The GPU time of everything `record` records on the encoder (several passes, copies).
    pub fn commands(&self, record: impl FnOnce(&mut wgpu::CommandEncoder)) -> Result<GpuTiming, GpuError> {
        let set = self.set_for(self.commands_source());
        self.measure(set.is_some(), |encoder| {
            if let Some(set) = set {
                encoder.write_timestamp(set, 0);
            }
            record(encoder);
            if let Some(set) = set {
                encoder.write_timestamp(set, 1);
            }
        })
    }

    /// The GPU time of the commands `timed` records inside a compute pass, after `setup`
    /// (pipelines, bind groups: not timed where inside-pass timestamps exist; on the wall
    /// clock the whole submission is).
    pub fn inside_compute_pass(
        &self,
        label: &str,
        setup: impl FnOnce(&mut wgpu::ComputePass<'_>),
        timed: impl FnOnce(&mut wgpu::ComputePass<'_>),
    ) -> Result<GpuTiming, GpuError> {
        let set = self.set_for(self.inside_pass_source());
        self.measure(set.is_some(), |encoder| {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
            setup(&mut pass);
            if let Some(set) = set {
                pass.write_timestamp(set, 0);
            }
            timed(&mut pass);
            if let Some(set) = set {
                pass.write_timestamp(set, 1);
            }
        })
    }

    /// Records with `record`, resolves the timestamps (when `marked`: `record` wrote slots 0
    /// and 1), submits, waits and reads the clock.
    fn measure(&self, marked: bool, record: impl FnOnce(&mut wgpu::CommandEncoder)) -> Result<GpuTiming, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("GpuTimer") });
        record(&mut encoder);
        let resolve = match (marked, &self.queries) {
            (true, Some((set, resolve))) => {
                encoder.resolve_query_set(set, 0..2, resolve, 0);
                Some(resolve)
            }
            _ => None,
        };
        let start = Instant::now();
        let submission = self.queue.submit([encoder.finish()]);
        let waited = self
            .device
            .poll(wgpu::PollType::Wait { submission_index: Some(submission), timeout: None })
            .map_err(|source| GpuError::Poll { what: "timed work".into(), source });
        let wall = start.elapsed().as_secs_f64();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: "timed work".into(), message: e.to_string() });
        }
        waited?;
        let Some(resolve) = resolve else {
            return Ok(GpuTiming { seconds: wall, source: TimingSource::WallClock });
        };
        let ticks: Vec<u64> = crate::read_buffer_as(&self.device, &self.queue, resolve, ..)?;
        let [begin, end] = ticks[..] else {
            return Err(GpuError::Readback {
                what: "timestamps".into(),
                message: format!("{} values, not 2", ticks.len()),
            });
        };
        let elapsed = end.wrapping_sub(begin);
        let period_ns = f64::from(self.queue.get_timestamp_period());
        Ok(GpuTiming { seconds: elapsed as f64 * period_ns * 1e-9, source: TimingSource::Timestamps })
    }
}
