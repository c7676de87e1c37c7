//! The gpu crate on a real device (lavapipe on CI): acquisition, buffer and texture
//! readback, refusals of bad readbacks, and the timer's clocks. Each test follows the one
//! rule: without an adapter it prints `SKIPPED: no GPU adapter ...`, and with
//! `BLURLAB_REQUIRE_GPU=1` it fails instead.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use gpu::wgpu;
use gpu::{AdapterChoice, DeviceRequest, GpuContext, GpuError, TimingSource, WgslAssembler};
use wgpu::util::DeviceExt;

#[test]
fn acquired_device_is_described_and_limits_are_clamped_to_the_adapter() {
    // Ask for more storage-buffer binding than any adapter offers: the device gets the most.
    let request = DeviceRequest {
        limits: wgpu::Limits { max_storage_buffer_binding_size: u64::MAX, ..Default::default() },
        ..Default::default()
    };
    let name = "acquired_device_is_described_and_limits_are_clamped_to_the_adapter";
    let Some(ctx) = gpu::test_context_with(name, AdapterChoice::HardwareThenSoftware, &request) else { return };
    assert!(!ctx.info.name.is_empty());
    assert_eq!(ctx.info.limits.max_storage_buffer_binding_size, ctx.device.limits().max_storage_buffer_binding_size);
    assert!(ctx.info.limits.max_storage_buffer_binding_size < u64::MAX);
    // The timestamp features come together with their dependencies or not at all.
    let f = ctx.info.features;
    if f.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES) {
        assert!(f.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS));
    }
    if f.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS) {
        assert!(f.contains(wgpu::Features::TIMESTAMP_QUERY));
    }
    // The adapter acquire picked is the first one in the order it tries.
    let first = gpu::adapter_infos().into_iter().next().expect("an adapter was acquired, so one is listed");
    assert_eq!((first.name.as_str(), first.backend), (ctx.info.name.as_str(), ctx.info.backend));
    let text = ctx.info.to_string();
    assert!(text.starts_with(&ctx.info.name), "{text}");
    assert!(text.contains(if ctx.info.is_software { "software" } else { "hardware" }), "{text}");
    assert_eq!(ctx.info.short(), format!("{} ({:?})", ctx.info.name, ctx.info.backend));
}

#[test]
fn hardware_only_never_returns_a_software_adapter() {
    match gpu::acquire(AdapterChoice::HardwareOnly, &DeviceRequest::default()) {
        Ok(ctx) => assert!(!ctx.info.is_software, "{}", ctx.info),
        Err(GpuError::NoAdapter { wanted, seen, .. }) => {
            assert_eq!(wanted, AdapterChoice::HardwareOnly);
            // Every adapter seen was passed over for a reason.
            assert!(seen.iter().all(|s| s.contains(": ")), "{seen:?}");
        }
        Err(e) => panic!("{e}"),
    }
}

fn storage(ctx: &GpuContext, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some("test"), contents: bytes, usage })
}

#[test]
fn buffers_read_back_whole_in_part_and_typed_and_bad_ranges_are_refused() {
    let Some(ctx) = gpu::test_context("buffers_read_back_whole_in_part_and_typed_and_bad_ranges_are_refused") else {
        return;
    };
    let values: Vec<u32> = (0..1000u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
    let buffer =
        storage(&ctx, bytemuck::cast_slice(&values), wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    assert_eq!(ctx.read_buffer_as::<u32>(&buffer, ..).unwrap(), values);
    assert_eq!(ctx.read_buffer(&buffer, 8..16).unwrap(), bytemuck::cast_slice::<u32, u8>(&values[2..4]));
    assert_eq!(ctx.read_buffer_as::<u32>(&buffer, 3996..).unwrap(), [values[999]]);
    assert_eq!(ctx.read_buffer_as::<u32>(&buffer, 40..=43).unwrap(), [values[10]]);
    assert!(ctx.read_buffer(&buffer, 16..16).unwrap().is_empty());
    let refused = |r: Result<Vec<u8>, GpuError>| match r {
        Err(GpuError::Readback { message, .. }) => message,
        other => panic!("expected a refusal, got {other:?}"),
    };
    assert!(refused(ctx.read_buffer(&buffer, 3990..4004)).contains("not within the buffer's 4000 bytes"));
    assert!(refused(ctx.read_buffer(&buffer, 2..8)).contains("multiples of 4"));
    assert!(refused(ctx.read_buffer(&buffer, 0..6)).contains("multiples of 4"));
    let no_copy = storage(&ctx, &[0; 16], wgpu::BufferUsages::STORAGE);
    assert!(refused(ctx.read_buffer(&no_copy, ..)).contains("lacks COPY_SRC"));
    match ctx.read_buffer_as::<[u32; 3]>(&buffer, 0..16) {
        Err(GpuError::Readback { message, .. }) => assert!(message.contains("whole number of 12-byte"), "{message}"),
        other => panic!("{other:?}"),
    }
}

/// A texture of `format` holding `bytes` (tightly packed rows), readable back.
fn texture(
    ctx: &GpuContext,
    format: wgpu::TextureFormat,
    (w, h, layers): (u32, u32, u32),
    bytes: &[u8],
) -> wgpu::Texture {
    ctx.device.create_texture_with_data(
        &ctx.queue,
        &wgpu::TextureDescriptor {
            label: Some("test"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: layers },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytes,
    )
}

#[test]
fn textures_of_any_texel_size_read_back_without_row_padding() {
    let Some(ctx) = gpu::test_context("textures_of_any_texel_size_read_back_without_row_padding") else { return };
    // Widths whose rows are not multiples of 256 bytes, texels of 1 to 16 bytes, and layers.
    for (format, texel) in [
        (wgpu::TextureFormat::R8Unorm, 1u32),
        (wgpu::TextureFormat::Rg16Float, 4),
        (wgpu::TextureFormat::Rgba8Unorm, 4),
        (wgpu::TextureFormat::Rgba16Float, 8),
        (wgpu::TextureFormat::Rgba32Float, 16),
    ] {
        for (w, h, layers) in [(1, 1, 1), (7, 5, 1), (67, 3, 2), (64, 2, 1)] {
            let n = (texel * w * h * layers) as usize;
            // Float formats get finite halves and floats (no NaN patterns that might be canonicalised).
            let bytes: Vec<u8> = match texel {
                8 | 4 if format != wgpu::TextureFormat::Rgba8Unorm => {
                    (0..n / 2).flat_map(|i| (0x3000u16 + (i as u16 % 0x0c00)).to_le_bytes()).collect()
                }
                16 => (0..n / 4).flat_map(|i| (i as f32 * 0.37 - 11.0).to_le_bytes()).collect(),
                _ => (0..n).map(|i| (i * 31 + 7) as u8).collect(),
            };
            let t = texture(&ctx, format, (w, h, layers), &bytes);
            assert_eq!(ctx.read_texture(&t).unwrap(), bytes, "{format:?} {w}x{h}x{layers}");
        }
    }
    // A texture that cannot be copied from is refused, not panicked on.
    let target = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: None,
        size: wgpu::Extent3d { width: 4, height: 4, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    assert!(ctx.read_texture(&target).unwrap_err().to_string().contains("lacks COPY_SRC"));
}

/// A compute shader long enough for any clock to see: `N` invocations of `ITERATIONS` steps.
fn busy_pipeline(ctx: &GpuContext) -> (wgpu::ComputePipeline, wgpu::BindGroup, wgpu::Buffer) {
    let mut assembler = WgslAssembler::new();
    assembler.constant_u32("ITERATIONS", 20_000);
    let wgsl = assembler
        .assemble(
            "busy.wgsl",
            "@group(0) @binding(0) var<storage, read_write> out: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    var x = f32(id.x) * 1e-3;
    for (var i = 0u; i < ITERATIONS; i++) { x = fract(x * 1.618034 + 0.1); }
    out[id.x] = x;
}
",
        )
        .unwrap();
    gpu::validate_wgsl("busy.wgsl", &wgsl).unwrap();
    let module = ctx.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("busy"),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    let pipeline = ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("busy"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let out = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("busy out"),
        size: 4 * 4096,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: out.as_entire_binding() }],
    });
    (pipeline, bind, out)
}

fn check_timings(ctx: &GpuContext, expect_timestamps: [bool; 3]) {
    let (pipeline, bind, out) = busy_pipeline(ctx);
    let timer = ctx.timer();
    let expected = expect_timestamps.map(|t| if t { TimingSource::Timestamps } else { TimingSource::WallClock });
    assert_eq!([timer.pass_source(), timer.commands_source(), timer.inside_pass_source()], expected);
    let dispatch = |pass: &mut wgpu::ComputePass<'_>| {
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(4096 / 64, 1, 1);
    };
    let timings = [
        timer.compute_pass("busy", dispatch).unwrap(),
        timer
            .commands(|encoder| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
                dispatch(&mut pass);
            })
            .unwrap(),
        timer
            .inside_compute_pass(
                "busy inside",
                |pass| {
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                },
                |pass| pass.dispatch_workgroups(4096 / 64, 1, 1),
            )
            .unwrap(),
    ];
    for (timing, source) in timings.iter().zip(expected) {
        eprintln!("{timing:?}");
        assert_eq!(timing.source, source);
        assert!(timing.seconds.is_finite() && timing.seconds > 0.0, "{timing:?}");
        // 4096 x 20,000 steps take well under a minute anywhere.
        assert!(timing.seconds < 60.0, "{timing:?}");
    }
    // The work was done.
    let x: Vec<f32> = ctx.read_buffer_as(&out, ..).unwrap();
    assert!(x.iter().all(|v| (0.0..1.0).contains(v)) && x.iter().any(|v| *v != x[0]), "{:?}", &x[..8]);
}

#[test]
fn timer_uses_timestamps_where_the_device_has_them() {
    let Some(ctx) = gpu::test_context("timer_uses_timestamps_where_the_device_has_them") else { return };
    let f = ctx.info.features;
    eprintln!("timestamp features of {}: {:?}", ctx.info.name, f & gpu::TIMESTAMP_FEATURES);
    check_timings(
        &ctx,
        [
            f.contains(wgpu::Features::TIMESTAMP_QUERY),
            f.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS),
            f.contains(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES),
        ],
    );
}

#[test]
fn timer_falls_back_to_the_wall_clock_without_timestamp_features() {
    let request = DeviceRequest { optional_features: wgpu::Features::empty(), ..Default::default() };
    let name = "timer_falls_back_to_the_wall_clock_without_timestamp_features";
    let Some(ctx) = gpu::test_context_with(name, AdapterChoice::HardwareThenSoftware, &request) else { return };
    assert!(!ctx.info.features.intersects(gpu::TIMESTAMP_FEATURES));
    check_timings(&ctx, [false; 3]);
}
