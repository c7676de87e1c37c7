//! Uploading decoded frames as textures, in submissions of bounded size, on the loader
//! thread (the window) or a headless device (`blurlab bench playback`).

use eframe::wgpu;

use super::draw::Draw;
use crate::RunnerError;
use crate::stimuli::Decoded;

/// Bytes of frames written before the writes are submitted: the device copies them into
/// their textures while the next ones are staged, and their staging memory is freed sooner.
const SUBMIT_BYTES: u64 = 16 << 20;

/// Uploads decoded sequences as textures.
pub struct FrameUploader {
    device: wgpu::Device,
    queue: wgpu::Queue,
}

impl FrameUploader {
    /// An uploader on `device`.
    pub fn new(device: wgpu::Device, queue: wgpu::Queue) -> Self {
        FrameUploader { device, queue }
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Puts every frame of `decoded` on the GPU, each as its own texture, and waits until the
    /// queue has finished. The textures are `Rgba8Unorm` with an `Rgba8UnormSrgb` view format,
    /// can be sampled and copied from, and are drawn as [`Draw::of`] says.
    pub fn upload(&self, decoded: &Decoded) -> Result<Vec<wgpu::Texture>, RunnerError> {
        Draw::of(decoded)?;
        let Some(first) = decoded.frames.first() else { return Ok(Vec::new()) };
        let (width, height) = (first.size[0] as u32, first.size[1] as u32);
        let bad = |message: String| RunnerError::Input { what: format!("stimulus {}", decoded.id), message };
        let max = self.device.limits().max_texture_dimension_2d;
        if width > max || height > max {
            return Err(bad(format!("frames of {width}x{height} exceed the GPU's texture limit of {max} pixels")));
        }
        if let Some(f) = decoded.frames.iter().find(|f| f.size != first.size) {
            return Err(bad(format!("frames differ in size ({width}x{height} and {}x{})", f.size[0], f.size[1])));
        }
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
        let frame_bytes = 4 * u64::from(width) * u64::from(height);
        let per_submit = SUBMIT_BYTES.div_ceil(frame_bytes).max(1) as usize;
        let textures: Vec<wgpu::Texture> = decoded
            .frames
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let t = self.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("frame"),
                    size,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba8Unorm,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING
                        | wgpu::TextureUsages::COPY_DST
                        | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[wgpu::TextureFormat::Rgba8UnormSrgb],
                });
                self.queue.write_texture(
                    t.as_image_copy(),
                    f.as_raw(),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(4 * width),
                        rows_per_image: Some(height),
                    },
                    size,
                );
                if (i + 1) % per_submit == 0 {
                    self.queue.submit([]);
                }
                t
            })
            .collect();
        self.queue.submit([]);
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RunnerError::Input { what: "GPU upload".into(), message: e.to_string() })?;
        Ok(textures)
    }
}
