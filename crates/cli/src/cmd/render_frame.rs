//! `blurlab render-frame`: render one frame of one stimulus to an EXR (linear radiance) or
//! PNG (display image) file.

use std::path::PathBuf;

use super::BadInput;
use super::stimuli::{DeviceArg, Frame, FrameArgs};
use anyhow::Context as _;
use study::Method;

/// Arguments.
#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    frame: FrameArgs,
    /// Rendering method: tracer, accum, mcguire, guertin, analytic or marcher, with its default
    /// settings (default: the design's method and settings, or the id's method level's).
    #[arg(long, value_parser = parse_method)]
    method: Option<Method>,
    /// Output file: `.exr` for linear radiance, `.png` for the sRGB display image.
    #[arg(long)]
    out: PathBuf,
    /// Rendering device: `auto` (a hardware GPU, else the CPU), `cpu` or `gpu` (hardware,
    /// else software such as lavapipe).
    #[arg(long, value_enum, default_value_t = DeviceArg::Auto)]
    device: DeviceArg,
}

fn parse_method(text: &str) -> Result<Method, String> {
    text.parse()
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let Frame { id, scene, design, .. } = args.frame.resolve()?;
    let spec = design.method_with(&id, args.method).map_err(|e| BadInput(e.to_string()))?;
    let method = spec.kind();
    let extension = args.out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let exr = match extension.as_deref() {
        Some("exr") => true,
        Some("png") => false,
        _ => return Err(BadInput(format!("--out {}: the file must end in .exr or .png", args.out.display())).into()),
    };
    let env = render::env::EnvironmentMap::from_lighting(&scene.lighting).map_err(|e| BadInput(e.to_string()))?;
    let renderer = render::Renderer::open(args.device.into(), &env).map_err(|e| match e {
        render::renderer::DeviceError::NoGpu(_) => anyhow::Error::new(BadInput(e.to_string())),
        e => anyhow::Error::new(e),
    })?;
    let started = std::time::Instant::now();
    let rendered = renderer.render(&spec, &scene).map_err(|e| {
        if e.is_bad_input() { anyhow::Error::new(BadInput(e.to_string())) } else { anyhow::Error::new(e) }
    })?;
    let (image, nonfinite) = (rendered.image, rendered.nonfinite_samples);
    let seconds = started.elapsed().as_secs_f64();
    let bytes = if exr {
        render::io::encode_exr(&image).context("cannot encode the EXR image")?
    } else {
        render::io::encode_png_srgb(&image, &scene.exposure)
    };
    study::fsio::write_atomic(&args.out, &bytes).with_context(|| format!("{}: cannot write", args.out.display()))?;
    eprintln!(
        "{}: {id} frame {} with the {method} on {} ({}x{}, {} spp) in {seconds:.2} s{}, {nonfinite} non-finite samples discarded",
        args.out.display(),
        args.frame.frame,
        renderer.device_name(),
        image.width,
        image.height,
        scene.samples_per_pixel,
        rendered.gpu_seconds.map(|g| format!(" ({g:.3} s on the GPU)")).unwrap_or_default()
    );
    Ok(())
}
