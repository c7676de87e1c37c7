//! A frame's antialiasing as its scene asks for it (`FrameScene::antialias`, a method level's
//! `antialias`): applied to the rendered frame's display values one eye at a time (a
//! side-by-side frame is never filtered across its seam), on the renderer's GPU where one is
//! open, else by the CPU twin. The radiance of a pixel the filter leaves alone is kept bit
//! for bit; a blended pixel's radiance is the one its new display value shows
//! ([`crate::io::radiance_of_display`]), so the EXR and the PNG of a frame agree. A pixel
//! whose radiance is NaN or infinite is left as it is and blends into no neighbour. Depth
//! edges read the scene's inverse depth at the shutter's centre ([`inverse_depth`]).

use study::scene::{Antialias, FrameScene, MlaaEdges};

use super::mlaa::host::GpuMlaa;
use super::mlaa::{MlaaParams, mlaa_cpu, mlaa_cpu_depth};
use crate::io::{LinearImage, display_value, radiance_of_display};
use crate::method::RenderError;
use crate::methods::post_process::gbuffer::{FloorMotion, pixel_geometry};

/// The inverse view depth (1/m; 0 for the sky) through the centre of each pixel of `camera`
/// at the shutter's centre: the depth buffer MLAA's depth edges read, the post-process
/// filters' G-buffer depth ([`pixel_geometry`]), available for every method's frame
/// because every method renders the same scene.
pub fn inverse_depth(scene: &FrameScene, camera: &study::scene::Camera) -> Vec<f32> {
    use rayon::prelude::*;
    let time = scene.shutter.centre();
    (0..camera.width * camera.height)
        .into_par_iter()
        .map(|i| {
            let g =
                pixel_geometry(scene, camera, (i % camera.width, i / camera.width), time, 0.0, FloorMotion::Surface);
            if g.depth >= crate::methods::post_process::SKY_DEPTH { 0.0 } else { 1.0 / g.depth }
        })
        .collect()
}

/// Antialiases `image` (the composed frame of `scene`) as `scene` asks; nothing when it
/// asks for none.
pub fn antialias_frame(image: &mut LinearImage, scene: &FrameScene, gpu: Option<&GpuMlaa>) -> Result<(), RenderError> {
    let Some(Antialias::Mlaa { threshold, search_distance, edges }) = scene.antialias else { return Ok(()) };
    let params = MlaaParams { threshold: threshold as f32, search_distance };
    let exposure = scene.exposure;
    let mut x0 = 0u32;
    for view in &scene.views {
        let (w, h) = (view.camera.width, view.camera.height);
        if x0 + w > image.width || h != image.height {
            return Err(RenderError::Scene(format!(
                "antialiasing: the frame is {}x{}, its eyes need {}x{h} from x = {x0}",
                image.width, image.height, w
            )));
        }
        // A pixel with a non-finite channel enters as NaN: MLAA finds no edge at it, so it
        // is neither blended nor blended into (its radiance has no display value to share).
        let display: Vec<[f32; 3]> = (0..h)
            .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let c = image.get(x, y);
                if c.iter().all(|v| v.is_finite()) {
                    c.map(|v| display_value(v, &exposure) as f32)
                } else {
                    [f32::NAN; 3]
                }
            })
            .collect();
        let depth = (edges == MlaaEdges::Depth).then(|| inverse_depth(scene, &view.camera));
        let blended = match (gpu, &depth) {
            (Some(g), depth) => g.run_with_depth(w, h, &display, depth.as_deref(), &params).map(|r| r.color),
            (None, None) => mlaa_cpu(w, h, &display, &params),
            (None, Some(depth)) => mlaa_cpu_depth(w, h, &display, depth, &params),
        }
        .map_err(|e| match e {
            super::mlaa::MlaaError::Gpu(e) => RenderError::Gpu(format!("MLAA: {e}")),
            e => RenderError::Settings(format!("MLAA: {e}")),
        })?;
        for (i, (before, after)) in display.iter().zip(&blended).enumerate() {
            if before.map(f32::to_bits) != after.map(f32::to_bits) {
                let (x, y) = (x0 + i as u32 % w, i as u32 / w);
                image.set(x, y, after.map(|d| radiance_of_display(f64::from(d), &exposure)));
            }
        }
        x0 += w;
    }
    Ok(())
}
