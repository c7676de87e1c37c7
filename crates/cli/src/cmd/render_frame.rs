//! `blurlab render-frame`: render one frame of one stimulus to an EXR (linear radiance) or
//! PNG (display image) file.

use std::path::PathBuf;

use super::BadInput;
use super::stimuli::{Frame, FrameArgs};
use anyhow::Context as _;
use clap::ValueEnum;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: FrameArgs,
    /// Rendering method.
    #[arg(long, value_enum, default_value_t = Method::Tracer)]
    method: Method,
    /// Output file: `.exr` for linear radiance, `.png` for the sRGB display image.
    #[arg(long)]
    out: PathBuf,
}

/// Rendering methods.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Method {
    /// The CPU distribution ray tracer (the reference).
    Tracer,
    /// Accumulation buffer.
    Accum,
    /// McGuire et al. 2012 post-process blur.
    Mcguire,
    /// Guertin et al. 2014 post-process blur.
    Guertin,
    /// Gribel et al. 2010 analytic rasterizer.
    Analytic,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    if !matches!(args.method, Method::Tracer) {
        return Err(
            BadInput(format!("--method {:?}: not built yet; use --method tracer", args.method).to_lowercase()).into()
        );
    }
    let extension = args.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let exr = match extension.as_deref() {
        Some("exr") => true,
        Some("png") => false,
        _ => return Err(BadInput(format!("--out {}: the file must end in .exr or .png", args.out.display())).into()),
    };
    let Frame { id, scene, .. } = args.frame.resolve()?;
    let env = render::env::EnvironmentMap::from_lighting(&scene.lighting).map_err(|e| BadInput(e.to_string()))?;
    let started = std::time::Instant::now();
    let (image, nonfinite) = render::set::render_composed(&scene, &env);
    let seconds = started.elapsed().as_secs_f64();
    let bytes = if exr {
        render::io::encode_exr(&image).context("cannot encode the EXR image")?
    } else {
        render::io::encode_png_srgb(&image, &scene.exposure)
    };
    study::fsio::write_atomic(&args.out, &bytes).with_context(|| format!("{}: cannot write", args.out.display()))?;
    eprintln!(
        "{}: {id} frame {} ({}x{}, {} spp) in {seconds:.2} s, {nonfinite} non-finite samples discarded",
        args.out.display(),
        args.frame.frame,
        image.width,
        image.height,
        scene.samples_per_pixel
    );
    Ok(())
}
