//! `blurlab render-frame`: render one frame of one stimulus to an EXR (linear radiance) or
//! PNG (display image) file.

use std::path::PathBuf;

use super::BadInput;
use super::stimuli::{Frame, FrameArgs};
use anyhow::Context as _;
use study::Method;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: FrameArgs,
    /// Rendering method: tracer, accum, mcguire, guertin or analytic (default: the design's).
    #[arg(long, value_parser = parse_method)]
    method: Option<Method>,
    /// Output file: `.exr` for linear radiance, `.png` for the sRGB display image.
    #[arg(long)]
    out: PathBuf,
}

fn parse_method(text: &str) -> Result<Method, String> {
    text.parse()
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let Frame { id, scene, design, .. } = args.frame.resolve()?;
    let method = args.method.unwrap_or_else(|| design.method());
    if !render::method::is_available(method) {
        return Err(BadInput(format!("--method {method}: {}", render::RenderError::NotAvailable(method))).into());
    }
    let extension = args.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let exr = match extension.as_deref() {
        Some("exr") => true,
        Some("png") => false,
        _ => return Err(BadInput(format!("--out {}: the file must end in .exr or .png", args.out.display())).into()),
    };
    let env = render::env::EnvironmentMap::from_lighting(&scene.lighting).map_err(|e| BadInput(e.to_string()))?;
    let started = std::time::Instant::now();
    let rendered = render::render_frame(method, &scene, &env).map_err(|e| BadInput(e.to_string()))?;
    let (image, nonfinite) = (rendered.image, rendered.nonfinite_samples);
    let seconds = started.elapsed().as_secs_f64();
    let bytes = if exr {
        render::io::encode_exr(&image).context("cannot encode the EXR image")?
    } else {
        render::io::encode_png_srgb(&image, &scene.exposure)
    };
    study::fsio::write_atomic(&args.out, &bytes).with_context(|| format!("{}: cannot write", args.out.display()))?;
    eprintln!(
        "{}: {id} frame {} with the {method} ({}x{}, {} spp) in {seconds:.2} s, {nonfinite} non-finite samples discarded",
        args.out.display(),
        args.frame.frame,
        image.width,
        image.height,
        scene.samples_per_pixel
    );
    Ok(())
}
