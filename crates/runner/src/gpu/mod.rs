//! Stimulus frames on the GPU: every frame is uploaded as its own `Rgba8Unorm` texture
//! holding sRGB codes (the format egui-wgpu samples, with an sRGB view format), and drawn into
//! the window by a paint callback with a pipeline of its own ([`StimulusPipelines`],
//! `stimulus.wgsl`): an opaque copy of the display image, or, for the stereo modes that
//! compute new pixels (red-cyan anaglyph, side by side at half width, top-bottom) or depend
//! on where the pixels land on the screen (row-interleaved), the composition of the
//! side-by-side frame at draw time. Those modes are thus never computed on the CPU in the
//! window; their CPU twins are [`crate::display::transform`] and, for row-interleaving,
//! [`crate::display::row_interleave_on_screen`] (the eye of each screen line), and tests
//! render both and compare them. `mono` (the left eye, a crop) stays on the CPU.
//!
//! Row-interleaving on the GPU picks the eye by the fragment's framebuffer row (physical
//! pixels from the top of the window's framebuffer: even lines left, odd right), so it is
//! right at any scale and any position of the stimulus. The window's top line must be the
//! monitor's first (left-eye) line or another even one: run full screen on a passive
//! polarised monitor.
//!
//! The window uploads with a [`FrameUploader`] on its loader thread with eframe's device;
//! `blurlab bench playback` uses the same uploader on a headless device from the gpu crate
//! ([`gpu::acquire`]), so the benchmark times the window's path. `stimulus.wgsl` is assembled
//! by the gpu crate's [`gpu::WgslAssembler`] (the shared sRGB include, the Dubois matrices as
//! typed constants); read-back for tests is [`gpu::read_texture`].

mod draw;
mod upload;

pub use draw::{Draw, StimulusCallback, StimulusPipelines};
pub use upload::FrameUploader;

use crate::display::{DUBOIS_LEFT, DUBOIS_RIGHT};

/// The WGSL source of the stimulus pipelines: `stimulus.wgsl` with the shared sRGB include
/// and the Dubois matrices declared as typed constants (`DUBOIS_LEFT`, `DUBOIS_RIGHT`).
pub fn stimulus_wgsl() -> Result<String, gpu::GpuError> {
    let mut assembler = gpu::WgslAssembler::new();
    assembler.constant_mat3x3("DUBOIS_LEFT", DUBOIS_LEFT).constant_mat3x3("DUBOIS_RIGHT", DUBOIS_RIGHT);
    assembler.assemble("stimulus.wgsl", include_str!("stimulus.wgsl"))
}

#[cfg(test)]
mod tests {
    use eframe::wgpu;
    use rand::{Rng, SeedableRng};
    use study::View;
    use study::experiment::DisplayMode;

    use super::*;
    use crate::display::{Rgba8, line_eye, linear_to_srgb8, row_interleave_on_screen, srgb8_to_linear, transform};
    use crate::stimuli::Decoded;

    /// An uploader on a test device for `test`, or `None` after the gpu crate's
    /// `SKIPPED: no GPU adapter` line (a panic with BLURLAB_REQUIRE_GPU=1).
    fn device(test: &str) -> Option<FrameUploader> {
        gpu::test_context(&format!("runner::gpu::tests::{test}")).map(|ctx| FrameUploader::new(ctx.device, ctx.queue))
    }

    fn read_back(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        texture: &wgpu::Texture,
    ) -> Result<Vec<u8>, gpu::GpuError> {
        gpu::read_texture(device, queue, texture)
    }

    #[test]
    fn stimulus_wgsl_assembles_and_validates() {
        let wgsl = stimulus_wgsl().unwrap();
        // No placeholder is left, the sRGB curve comes from the include (once) and the
        // matrices are declared as typed constants with their exact values.
        assert!(!wgsl.contains("/*"), "{wgsl}");
        assert_eq!(wgsl.matches("fn srgb_decode3(").count(), 1);
        assert_eq!(wgsl.matches("pow(").count(), 4, "only srgb.wgsl's four pow calls");
        assert!(
            wgsl.contains("const DUBOIS_LEFT: mat3x3<f32> = mat3x3<f32>(vec3<f32>(0.437f, -0.062f, -0.048f), "),
            "{wgsl}"
        );
        gpu::validate_wgsl("stimulus.wgsl", &wgsl).unwrap();
    }

    /// The target formats the twin tests draw into: two that store the codes given (egui's
    /// gamma framebuffers), one that encodes linear values (sRGB).
    const FORMATS: [wgpu::TextureFormat; 3] =
        [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Bgra8Unorm, wgpu::TextureFormat::Rgba8UnormSrgb];

    /// The filters and drawn sizes the twin tests draw eyes of `eye x h` at: integer scales 1,
    /// 2 and 3 with a nearest sampler (each image pixel becomes s x s pixels), and 1.5 with a
    /// filtering one.
    fn drawn_sizes(eye: u32, h: u32) -> [(wgpu::FilterMode, (u32, u32)); 4] {
        let (nearest, linear) = (wgpu::FilterMode::Nearest, wgpu::FilterMode::Linear);
        [
            (nearest, (eye, h)),
            (nearest, (2 * eye, 2 * h)),
            (nearest, (3 * eye, 3 * h)),
            (linear, (3 * eye / 2, 3 * h / 2)),
        ]
    }

    /// Pixels read back from a target of `format` as RGBA (a BGRA target's channels swapped).
    fn rgba(mut pixels: Vec<u8>, format: wgpu::TextureFormat) -> Vec<u8> {
        if format == wgpu::TextureFormat::Bgra8Unorm {
            pixels.chunks_mut(4).for_each(|p| p.swap(0, 2));
        }
        pixels
    }

    /// Stereo frames of `eye x h` per eye: random pixels, with greys and primaries (where
    /// clamping and the linear toe of the sRGB curve meet) in the first row.
    fn stereo_frames(eye: u32, h: u32, n: usize, seed: u64) -> Vec<Rgba8> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let mut f = Rgba8::filled(2 * eye, h, [0, 0, 0, 255]);
                for y in 0..h {
                    for x in 0..2 * eye {
                        let v = rng.next_u32().to_le_bytes();
                        f.set(x, y, [v[0], v[1], v[2], 255]);
                    }
                }
                for (x, v) in [0u8, 1, 2, 5, 10, 11, 12, 50, 128, 200, 254, 255].into_iter().enumerate() {
                    let x = 2 * x as u32;
                    f.set(x, 0, [v, v, v, 255]);
                    f.set(eye + x, 0, [v, v, v, 255]);
                    f.set(x + 1, 0, [v, 0, 0, 255]);
                    f.set(eye + x + 1, 0, [0, v, v, 255]);
                }
                f
            })
            .collect()
    }

    fn decoded(frames: &[Rgba8], gpu_transform: Option<DisplayMode>) -> Decoded {
        let image =
            |f: &Rgba8| egui::ColorImage::from_rgba_premultiplied([f.width as usize, f.height as usize], &f.pixels);
        Decoded {
            id: "M2-S2-T3-A5-stereo".parse().unwrap(),
            fps: 30.0,
            eye_width: frames[0].width / 2,
            frames: frames.iter().map(image).collect(),
            gpu_transform,
        }
    }

    #[test]
    fn anaglyph_pipeline_agrees_with_its_cpu_twin_within_one_code() {
        let Some(gpu) = device("anaglyph_pipeline_agrees_with_its_cpu_twin_within_one_code") else { return };
        // An odd eye width and height: the draw covers the whole target, nothing more.
        let (eye, h) = (101, 37);
        let frames = stereo_frames(eye, h, 2, 11);
        let textures = gpu.upload(&decoded(&frames, Some(DisplayMode::Anaglyph))).unwrap();
        assert_eq!(textures.len(), frames.len());
        assert_eq!((textures[0].width(), textures[0].height()), (2 * eye, h));
        // Both ways out: encoded by the shader (egui's gamma framebuffers) and by the target.
        for format in FORMATS {
            let pipelines = StimulusPipelines::new(gpu.device(), format);
            let (mut channels, mut exact) = (0usize, 0usize);
            for (frame, texture) in frames.iter().zip(&textures) {
                let bind = pipelines.bind(gpu.device(), texture, Draw::Anaglyph, wgpu::FilterMode::Nearest);
                let nearest = wgpu::FilterMode::Nearest;
                let got = rgba(
                    pipelines.render(&gpu, &bind, Draw::Anaglyph, nearest, format, (eye, h), None).unwrap(),
                    format,
                );
                let want = transform(DisplayMode::Anaglyph, View::Stereo, frame.clone());
                for (i, (g, w)) in got.chunks(4).zip(want.pixels.chunks(4)).enumerate() {
                    let (x, y) = (i as u32 % eye, i as u32 / eye);
                    for c in 0..3 {
                        assert!(
                            g[c].abs_diff(w[c]) <= 1,
                            "{format:?} pixel ({x},{y}) channel {c}: GPU {} vs CPU {} (left {:?}, right {:?})",
                            g[c],
                            w[c],
                            frame.get(x, y),
                            frame.get(eye + x, y)
                        );
                        exact += usize::from(g[c] == w[c]);
                        channels += 1;
                    }
                    assert_eq!(g[3], 255);
                }
            }
            eprintln!("{format:?}: {exact} of {channels} channels equal to the CPU's");
            // The shader's encoding rounds like the CPU (on lavapipe every channel was equal);
            // an sRGB target's own encoding is an approximation (93.7% equal on lavapipe).
            let share = if format.is_srgb() { 0.9 } else { 0.99 };
            assert!(exact as f64 > share * channels as f64, "{format:?}: {exact} of {channels} channels equal");
        }
    }

    #[test]
    fn frames_shown_unchanged_are_uploaded_and_drawn_byte_for_byte() {
        let Some(gpu) = device("frames_shown_unchanged_are_uploaded_and_drawn_byte_for_byte") else { return };
        let frames = stereo_frames(7, 5, 3, 3);
        let textures = gpu.upload(&decoded(&frames, None)).unwrap();
        for format in [wgpu::TextureFormat::Rgba8Unorm, wgpu::TextureFormat::Rgba8UnormSrgb] {
            let pipelines = StimulusPipelines::new(gpu.device(), format);
            for (frame, texture) in frames.iter().zip(&textures) {
                assert_eq!((texture.width(), texture.height()), (14, 5));
                assert_eq!(read_back(gpu.device(), gpu.queue(), texture).unwrap(), frame.pixels);
                // Drawn at twice the size with a nearest sampler: each texel becomes 2x2 pixels.
                let bind = pipelines.bind(gpu.device(), texture, Draw::Copy, wgpu::FilterMode::Nearest);
                let nearest = wgpu::FilterMode::Nearest;
                let got = pipelines.render(&gpu, &bind, Draw::Copy, nearest, format, (28, 10), None).unwrap();
                for y in 0..10u32 {
                    for x in 0..28u32 {
                        let i = 4 * (y * 28 + x) as usize;
                        assert_eq!(got[i..i + 4], frame.get(x / 2, y / 2), "{format:?} ({x},{y})");
                    }
                }
            }
        }
        // A mode the GPU does not compose is refused with a message.
        let e = gpu.upload(&decoded(&frames, Some(DisplayMode::SbsFull))).unwrap_err().to_string();
        assert!(e.contains("sbs-full is not composed on the GPU"), "{e}");
    }

    /// The window's CPU path at a scale that is not an integer: the display image drawn with a
    /// filtering sampler, i.e. at render pixel (x, y) of `size` the bilinear mix (clamped at the
    /// edges) of the image's four pixels around the pixel's centre, of their codes for targets
    /// that store codes, of their linear values for sRGB targets; computed in f64.
    /// Also returns, per channel, the range of the four pixels' codes.
    fn bilinear(image: &Rgba8, size: (u32, u32), (x, y): (u32, u32), srgb: bool) -> ([f64; 3], [f64; 3]) {
        let at = |i: f64, n: u32| {
            let p = i - 0.5;
            let i0 = p.floor();
            let clamp = |v: f64| v.clamp(0.0, f64::from(n - 1)) as u32;
            (clamp(i0), clamp(i0 + 1.0), p - i0)
        };
        let (x0, x1, fx) = at((f64::from(x) + 0.5) / f64::from(size.0) * f64::from(image.width), image.width);
        let (y0, y1, fy) = at((f64::from(y) + 0.5) / f64::from(size.1) * f64::from(image.height), image.height);
        let range = std::array::from_fn(|c| {
            let codes = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| image.get(x, y)[c]);
            f64::from(codes.iter().max().unwrap() - codes.iter().min().unwrap())
        });
        let mixed = std::array::from_fn(|c| {
            let v = |x, y| {
                let code = image.get(x, y)[c];
                if srgb { f64::from(srgb8_to_linear(code)) } else { f64::from(code) }
            };
            let top = v(x0, y0) * (1.0 - fx) + v(x1, y0) * fx;
            let bottom = v(x0, y1) * (1.0 - fx) + v(x1, y1) * fx;
            let mixed = top * (1.0 - fy) + bottom * fy;
            if srgb { f64::from(linear_to_srgb8(mixed as f32)) } else { mixed }
        });
        (mixed, range)
    }

    /// Row-interleaving drawn into a viewport whose top is on screen line `top` (even and
    /// odd), at scales 1, 2 and 3 (nearest) and 1.5 (filtering), against
    /// [`row_interleave_on_screen`] (nearest) or the bilinear mix of the line's eye (filtering):
    /// every screen line must show the eye of its parity, whatever the scale and the top.
    #[test]
    fn row_interleave_pipeline_takes_each_screen_line_from_its_eye() {
        let Some(gpu) = device("row_interleave_pipeline_takes_each_screen_line_from_its_eye") else { return };
        let (eye, h) = (101, 37);
        let frames = stereo_frames(eye, h, 2, 9);
        let decoded = decoded(&frames, Some(DisplayMode::RowInterleaved));
        let draw = Draw::of(&decoded).unwrap();
        assert_eq!(draw, Draw::RowInterleaved);
        let textures = gpu.upload(&decoded).unwrap();
        assert_eq!((textures[0].width(), textures[0].height()), (2 * eye, h));
        let nearest = wgpu::FilterMode::Nearest;
        for format in FORMATS {
            let pipelines = StimulusPipelines::new(gpu.device(), format);
            for (filter, size) in drawn_sizes(eye, h) {
                for top in [0u32, 1, 2, 5] {
                    let left = 3;
                    let target = (size.0 + left + 2, size.1 + top + 2);
                    let (mut channels, mut exact) = (0usize, 0usize);
                    for (frame, texture) in frames.iter().zip(&textures) {
                        let bind = pipelines.bind(gpu.device(), texture, draw, filter);
                        let viewport = [left, top, size.0, size.1];
                        let got = rgba(
                            pipelines.render(&gpu, &bind, draw, filter, format, target, Some(viewport)).unwrap(),
                            format,
                        );
                        let got = Rgba8 { width: target.0, height: target.1, pixels: got };
                        // Nothing is drawn outside the viewport.
                        assert_eq!(got.get(left - 1, top), [0, 0, 0, 255], "{format:?} left of the viewport");
                        assert_eq!(got.get(left, top + size.1), [0, 0, 0, 255], "{format:?} below the viewport");
                        let got = got.crop(left, top, size.0, size.1);
                        let sharp = row_interleave_on_screen(frame, size, top);
                        let eyes = [frame.crop(0, 0, eye, h), frame.crop(eye, 0, eye, h)];
                        for y in 0..size.1 {
                            for x in 0..size.0 {
                                let image = if filter == nearest { &sharp } else { &eyes[line_eye(top + y)] };
                                let (w, tolerance) = expected(image, filter, size, (x, y), format.is_srgb());
                                let (equal, _) = compare(got.get(x, y), w, tolerance, || {
                                    format!(
                                        "{format:?} {filter:?} at {size:?}, top on line {top}: pixel ({x},{y}) (this line's eye {:?}, the other eye {:?} there)",
                                        row_interleave_on_screen(frame, size, top).get(x, y),
                                        row_interleave_on_screen(frame, size, top + 1).get(x, y),
                                    )
                                });
                                exact += equal;
                                channels += 3;
                            }
                        }
                    }
                    eprintln!("row-interleaved {format:?} {filter:?} {size:?} top {top}: {exact} of {channels} equal");
                    // Sharp into a target that stores codes, the codes are only moved: all equal.
                    if filter == nearest && !format.is_srgb() {
                        assert_eq!(exact, channels, "{format:?} {size:?} top {top}");
                    }
                }
            }
        }
    }

    /// What a twin test expects at pixel (x, y) of a render of `size` drawn from `image` with
    /// `filter`, and the tolerance per channel. Sharp: the image pixel under the pixel's
    /// centre, within 1 code. Filtered: the bilinear mix ([`bilinear`]) within 1 code plus the
    /// weights' precision (the rasterizer's 1/256 pixel puts the position up to 1/256 texel
    /// off, moving the mix by as much of the range of the four pixels mixed).
    fn expected(
        image: &Rgba8,
        filter: wgpu::FilterMode,
        size: (u32, u32),
        (x, y): (u32, u32),
        srgb: bool,
    ) -> ([f64; 3], [f64; 3]) {
        if filter == wgpu::FilterMode::Nearest {
            let under =
                |i: u32, n: u32, image: u32| ((2 * u64::from(i) + 1) * u64::from(image) / (2 * u64::from(n))) as u32;
            let p = image.get(under(x, size.0, image.width), under(y, size.1, image.height));
            (std::array::from_fn(|c| f64::from(p[c])), [1.0; 3])
        } else {
            let (w, range) = bilinear(image, size, (x, y), srgb);
            (w, range.map(|r| 1.0 + r / 256.0))
        }
    }

    /// Asserts that the GPU's pixel `g` is opaque and within `tolerance` of `w` in each colour
    /// channel (`what` names the pixel in the message). Returns how many channels equal `w`
    /// rounded and how many are more than 1 code off.
    fn compare(g: [u8; 4], w: [f64; 3], tolerance: [f64; 3], what: impl Fn() -> String) -> (usize, usize) {
        let (mut equal, mut beyond_one) = (0, 0);
        for c in 0..3 {
            let d = (f64::from(g[c]) - w[c]).abs();
            assert!(
                d <= tolerance[c],
                "{}: channel {c}: GPU {} vs CPU {} (tolerance {})",
                what(),
                g[c],
                w[c],
                tolerance[c]
            );
            equal += usize::from(f64::from(g[c]) == w[c].round());
            beyond_one += usize::from(d > 1.0);
        }
        assert_eq!(g[3], 255, "{}: alpha", what());
        (equal, beyond_one)
    }

    #[test]
    fn composed_pipelines_agree_with_their_cpu_twin_within_one_code() {
        let Some(gpu) = device("composed_pipelines_agree_with_their_cpu_twin_within_one_code") else { return };
        // An odd eye width and height: the squeezes leave a black last column or row.
        let (eye, h) = (101, 37);
        let frames = stereo_frames(eye, h, 2, 5);
        for mode in [DisplayMode::SbsHalf, DisplayMode::TopBottom] {
            let decoded = decoded(&frames, Some(mode));
            let draw = Draw::of(&decoded).unwrap();
            let textures = gpu.upload(&decoded).unwrap();
            assert_eq!((textures[0].width(), textures[0].height()), (2 * eye, h));
            for format in FORMATS {
                let pipelines = StimulusPipelines::new(gpu.device(), format);
                for (filter, size) in drawn_sizes(eye, h) {
                    let (mut channels, mut exact, mut beyond_one) = (0usize, 0usize, 0usize);
                    for (frame, texture) in frames.iter().zip(&textures) {
                        let bind = pipelines.bind(gpu.device(), texture, draw, filter);
                        let got =
                            rgba(pipelines.render(&gpu, &bind, draw, filter, format, size, None).unwrap(), format);
                        let want = transform(mode, View::Stereo, frame.clone());
                        for (i, g) in got.as_chunks::<4>().0.iter().enumerate() {
                            let (x, y) = (i as u32 % size.0, i as u32 / size.0);
                            let (w, tolerance) = expected(&want, filter, size, (x, y), format.is_srgb());
                            let (equal, off) = compare(*g, w, tolerance, || {
                                format!("{mode} {format:?} {filter:?} at {size:?}: pixel ({x},{y})")
                            });
                            exact += equal;
                            beyond_one += off;
                            channels += 3;
                        }
                    }
                    eprintln!(
                        "{mode} {format:?} {filter:?} {size:?}: {exact} of {channels} channels equal, {beyond_one} more than 1 code off"
                    );
                    // At most one channel in a thousand is off by more than a code.
                    assert!(beyond_one * 1000 <= channels, "{mode} {format:?} {filter:?}: {beyond_one} of {channels}");
                    // An sRGB target's own encoding is an approximation (as for the anaglyph).
                    let share = if format.is_srgb() { 0.9 } else { 0.99 };
                    assert!(
                        exact as f64 > share * channels as f64,
                        "{mode} {format:?} {filter:?}: {exact} of {channels}"
                    );
                }
            }
        }
    }
}
