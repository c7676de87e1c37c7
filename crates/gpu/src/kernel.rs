//! One-shot compute kernels over storage buffers: the shape of every twin test (and of small
//! GPU jobs), a WGSL entry point reading `@group(0) @binding(0)` (read-only storage) and
//! writing `@group(0) @binding(1)` (read-write storage), run once and read back.

use wgpu::util::DeviceExt as _;

use crate::{GpuContext, GpuError};

impl GpuContext {
    /// Validates `wgsl` (naga, on the CPU), runs `entry` over `workgroups` workgroups with
    /// `input` bound at binding 0 and an `output_len`-element output at binding 1, and returns
    /// the output. Validation failures of the pipeline come back as [`GpuError::Validation`].
    pub fn run_kernel<In: bytemuck::Pod, Out: bytemuck::Pod>(
        &self,
        file: &str,
        wgsl: &str,
        entry: &str,
        input: &[In],
        output_len: usize,
        workgroups: u32,
    ) -> Result<Vec<Out>, GpuError> {
        crate::validate_wgsl(file, wgsl)?;
        let device = &self.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(file),
            source: wgpu::ShaderSource::Wgsl(wgsl.into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(file),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
        // A zero-sized binding is invalid: keep at least one element.
        let input_bytes: &[u8] = bytemuck::cast_slice(input);
        let padded;
        let contents = if input_bytes.is_empty() {
            padded = [0u8; 4];
            &padded[..]
        } else {
            input_bytes
        };
        let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("kernel input"),
            contents,
            usage: wgpu::BufferUsages::STORAGE,
        });
        let output_size = (std::mem::size_of::<Out>() * output_len.max(1)) as u64;
        let output = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("kernel output"),
            size: output_size.next_multiple_of(4),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kernel"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: output.as_entire_binding() },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(workgroups, 1, 1);
        }
        self.queue.submit([encoder.finish()]);
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Validation { what: format!("kernel `{entry}` of {file}"), message: e.to_string() });
        }
        let mut out: Vec<Out> = self.read_buffer_as(&output, ..)?;
        out.truncate(output_len);
        Ok(out)
    }
}
