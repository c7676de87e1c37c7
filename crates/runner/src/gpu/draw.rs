//! Drawing a stimulus frame into the window: the pipelines of `stimulus.wgsl` (an opaque
//! copy, or the stereo composition at draw time) and the egui paint callback that runs them.

use eframe::egui_wgpu;
use eframe::wgpu;
use study::experiment::DisplayMode;

use super::stimulus_wgsl;
use super::upload::FrameUploader;
use crate::RunnerError;
use crate::stimuli::Decoded;

/// How a frame texture becomes the pixels in its rectangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draw {
    /// The texture is the display image.
    Copy,
    /// The texture is a side-by-side stereo frame; the red-cyan anaglyph is drawn.
    Anaglyph,
    /// The texture is a side-by-side stereo frame; each eye is drawn squeezed to half width.
    SbsHalf,
    /// The texture is a side-by-side stereo frame; the eyes are drawn top and bottom, each
    /// squeezed to half height.
    TopBottom,
    /// The texture is a side-by-side stereo frame; each screen line shows one eye, chosen by
    /// the line's parity in the framebuffer (even: left), scaled to the drawn size.
    RowInterleaved,
}

impl Draw {
    /// The compositions of `fs_compose` in `stimulus.wgsl`, in the order of its `MODE`
    /// constant (1, 2, 3).
    const COMPOSED: [Draw; 3] = [Draw::SbsHalf, Draw::TopBottom, Draw::RowInterleaved];
}

impl Draw {
    /// How frames decoded as `decoded` are drawn.
    pub fn of(decoded: &Decoded) -> Result<Draw, RunnerError> {
        match decoded.gpu_transform {
            None => Ok(Draw::Copy),
            Some(DisplayMode::Anaglyph) => Ok(Draw::Anaglyph),
            Some(DisplayMode::SbsHalf) => Ok(Draw::SbsHalf),
            Some(DisplayMode::TopBottom) => Ok(Draw::TopBottom),
            Some(DisplayMode::RowInterleaved) => Ok(Draw::RowInterleaved),
            Some(other) => Err(RunnerError::Input {
                what: format!("stimulus {}", decoded.id),
                message: format!("display mode {other} is not composed on the GPU"),
            }),
        }
    }
}

/// The render pipelines that draw stimulus frames into a target of one format, with their
/// samplers. Kept in egui-wgpu's callback resources for [`StimulusCallback`].
pub struct StimulusPipelines {
    copy: wgpu::RenderPipeline,
    anaglyph: wgpu::RenderPipeline,
    /// `fs_compose` per [`Draw::COMPOSED`] mode, with a nearest sampler and with a filtering one.
    composed: [[wgpu::RenderPipeline; 2]; 3],
    layout: wgpu::BindGroupLayout,
    nearest: wgpu::Sampler,
    linear: wgpu::Sampler,
    target_is_srgb: bool,
}

impl StimulusPipelines {
    /// Pipelines drawing into targets of `format` (egui's framebuffer format in the window).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        // The source and the constants are fixed at compile time (finite matrices, known
        // includes); `stimulus_wgsl_assembles_and_validates` checks that this cannot fail.
        let wgsl = stimulus_wgsl().expect("stimulus.wgsl assembles (checked by its test)");
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("stimulus"),
            source: wgpu::ShaderSource::Wgsl(wgsl.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stimulus"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stimulus"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let target_is_srgb = format.is_srgb();
        let pipeline = |entry: &str, constants: &[(&str, f64)]| {
            let compilation_options = wgpu::PipelineCompilationOptions { constants, ..Default::default() };
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options,
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let copy = pipeline("fs_copy", &[]);
        let anaglyph = pipeline(if target_is_srgb { "fs_anaglyph_linear" } else { "fs_anaglyph_encode" }, &[]);
        let srgb = f64::from(u8::from(target_is_srgb));
        let composed = std::array::from_fn(|mode| {
            std::array::from_fn(|filtered| {
                let constants = [("MODE", mode as f64 + 1.0), ("FILTERED", filtered as f64), ("SRGB_TARGET", srgb)];
                pipeline("fs_compose", &constants)
            })
        });
        let sampler = |filter| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("stimulus"),
                mag_filter: filter,
                min_filter: filter,
                ..Default::default()
            })
        };
        let (nearest, linear) = (sampler(wgpu::FilterMode::Nearest), sampler(wgpu::FilterMode::Linear));
        StimulusPipelines { copy, anaglyph, composed, layout, nearest, linear, target_is_srgb }
    }

    /// The bind group drawing `texture` (from [`FrameUploader::upload`]) as `draw` with
    /// `filter`. A copy into an sRGB target reads through an sRGB view (decoded to linear
    /// light, which the target encodes again); otherwise the shader gets the codes.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        texture: &wgpu::Texture,
        draw: Draw,
        filter: wgpu::FilterMode,
    ) -> wgpu::BindGroup {
        let srgb_view = draw == Draw::Copy && self.target_is_srgb;
        let format = if srgb_view { wgpu::TextureFormat::Rgba8UnormSrgb } else { wgpu::TextureFormat::Rgba8Unorm };
        let view = texture.create_view(&wgpu::TextureViewDescriptor { format: Some(format), ..Default::default() });
        let sampler = if filter == wgpu::FilterMode::Nearest { &self.nearest } else { &self.linear };
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("stimulus frame"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(sampler) },
            ],
        })
    }

    /// Draws a frame bound by [`StimulusPipelines::bind`] with the same `draw` and `filter`
    /// over the pass's viewport.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, bind: &wgpu::BindGroup, draw: Draw, filter: wgpu::FilterMode) {
        pass.set_pipeline(match draw {
            Draw::Copy => &self.copy,
            Draw::Anaglyph => &self.anaglyph,
            Draw::SbsHalf | Draw::TopBottom | Draw::RowInterleaved => {
                let mode = Draw::COMPOSED.iter().position(|d| *d == draw).expect("a composed mode");
                &self.composed[mode][usize::from(filter != wgpu::FilterMode::Nearest)]
            }
        });
        pass.set_bind_group(0, bind, &[]);
        pass.draw(0..3, 0..1);
    }

    /// Draws a frame into a new texture of `width x height` in the pipelines' format, cleared
    /// to opaque black, over its viewport `[x, y, w, h]` (pixels, as egui-wgpu sets it for a
    /// paint callback; `None`: the whole texture), and reads the whole texture back as
    /// tightly packed RGBA8 rows (tests and checks).
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &self,
        gpu: &FrameUploader,
        bind: &wgpu::BindGroup,
        draw: Draw,
        filter: wgpu::FilterMode,
        format: wgpu::TextureFormat,
        (width, height): (u32, u32),
        viewport: Option<[u32; 4]>,
    ) -> Result<Vec<u8>, RunnerError> {
        let viewport = viewport.unwrap_or([0, 0, width, height]);
        let [vx, vy, vw, vh] = viewport;
        if vw == 0 || vh == 0 || vx + vw > width || vy + vh > height {
            return Err(RunnerError::Input {
                what: "stimulus render".into(),
                message: format!("viewport {viewport:?} is empty or outside the {width}x{height} target"),
            });
        }
        let target = gpu.device().create_texture(&wgpu::TextureDescriptor {
            label: Some("stimulus render"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = target.create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder = gpu.device().create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("stimulus render"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_viewport(vx as f32, vy as f32, vw as f32, vh as f32, 0.0, 1.0);
            self.draw(&mut pass, bind, draw, filter);
        }
        gpu.queue().submit([encoder.finish()]);
        gpu::read_texture(gpu.device(), gpu.queue(), &target).map_err(RunnerError::from)
    }
}

/// A paint callback drawing one frame with the `Arc<StimulusPipelines>` in egui-wgpu's
/// callback resources (nothing is drawn when they are missing).
pub struct StimulusCallback {
    /// The frame, bound by [`StimulusPipelines::bind`].
    pub bind: wgpu::BindGroup,
    /// How it is drawn.
    pub draw: Draw,
    /// The sampler's filter it was bound with.
    pub filter: wgpu::FilterMode,
}

impl egui_wgpu::CallbackTrait for StimulusCallback {
    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        if let Some(p) = resources.get::<std::sync::Arc<StimulusPipelines>>() {
            p.draw(render_pass, &self.bind, self.draw, self.filter);
        }
    }
}
