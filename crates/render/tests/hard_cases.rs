//! The standing hard-case matrix (issue 31): designs pushed to hard but legal values, each
//! rendered by every method on the CPU and, where an adapter exists, on the GPU, at a small
//! size. Every frame must be finite and non-negative; each method's GPU frame must agree
//! with its CPU frame in block means (the devices' noise differs, their expectations do
//! not); and each method must agree with the CPU tracer within the bound stated for it in
//! [`BOUNDS`], which is the method's measured error on ordinary frames with a margin, not a
//! fit to these cases.
//!
//! `BLURLAB_HARD_CASES_FULL=1` renders the same matrix at 64 x 36 and four times the samples
//! and prints its table (the run recorded in BENCHMARKS.md, "Hard cases"); without it the
//! matrix runs at CI's size. Without a GPU adapter the GPU half says SKIPPED (and fails under
//! `BLURLAB_REQUIRE_GPU=1`).

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::collections::HashMap;
use std::path::Path;

use render::env::EnvironmentMap;
use render::io::LinearImage;
use render::renderer::DeviceChoice;
use render::{RenderError, Renderer};
use study::Method;
use study::design::Design;
use study::ids::StimulusId;
use study::method::MethodSpec;

/// One hard design: edits to the shipped design (dotted key, TOML value), the stimulus and
/// the frame of the `hard` preset rendered.
struct Case {
    name: &'static str,
    edits: &'static [(&'static str, &'static str)],
    id: &'static str,
    frame: u32,
}

const CASES: &[Case] = &[
    Case { name: "shipped design", edits: &[], id: "M3-S3-T5-A5", frame: 3 },
    Case { name: "instantaneous shutter", edits: &[], id: "M2-S3-T1-A5", frame: 3 },
    Case {
        name: "sphere at rest",
        edits: &[("factors.speed.0.degrees_per_second", "0.0")],
        id: "M2-S1-T5-A5",
        frame: 3,
    },
    Case {
        name: "extreme speed (2.5 m a frame)",
        edits: &[("factors.speed.2.degrees_per_second", "500.0")],
        id: "M1-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "far along the path (t = 3333 s)",
        edits: &[("sequence.frames", "100000"), ("presets.hard.first_frame", "99990")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "grazing camera (1 cm above the floor)",
        edits: &[("camera.height", "0.01")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "near camera (sphere 0.4 m away)",
        edits: &[("camera.distance", "0.4"), ("camera.height", "0.12")],
        id: "M2-S1-T5-A5",
        frame: 3,
    },
    Case {
        name: "far camera (1e5 m, focal length scaled)",
        edits: &[("camera.distance", "1.0e5"), ("camera.focal_length", "1666.6666666666667")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "far camera (1e7 m, focal length scaled)",
        edits: &[("camera.distance", "1.0e7"), ("camera.focal_length", "166666.66666666666")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "one pixel",
        edits: &[
            ("presets.hard.width", "1"),
            ("presets.hard.height", "1"),
            // One pixel is one block: enough samples that its mean is not noise.
            ("presets.hard.samples_per_pixel", "[1, 2, 4, 8, 1024]"),
        ],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "one column, 64 tall",
        edits: &[("presets.hard.width", "1"), ("presets.hard.height", "64")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "one column, 4096 tall (looks straight down)",
        edits: &[("presets.hard.width", "1"), ("presets.hard.height", "4096")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "one row, 64 wide",
        edits: &[("presets.hard.width", "64"), ("presets.hard.height", "1")],
        id: "M2-S2-T5-A5",
        frame: 3,
    },
    Case {
        name: "very bright sky (1e30)",
        edits: &[("lighting.environment", "{ kind = \"uniform\", radiance = [1e30, 1e30, 1e30] }")],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "brightest legal sky (3e32)",
        edits: &[("lighting.environment", "{ kind = \"uniform\", radiance = [3e32, 3e32, 3e32] }")],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "most bounces (10000, no Russian roulette)",
        edits: &[("integrator.max_bounces", "10000"), ("integrator.russian_roulette_from", "10000")],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "black sky",
        edits: &[("lighting.environment", "{ kind = \"uniform\", radiance = [0.0, 0.0, 0.0] }")],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "stereo, 1 m between the eyes",
        edits: &[("stereo.interocular", "1.0")],
        id: "M3-S3-T5-A5-stereo",
        frame: 3,
    },
    Case {
        name: "analytic at its smallest budget and tessellation",
        edits: &[("method.kind", "\"analytic\""), ("method.intervals", "4"), ("method.tessellation", "3")],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "guertin at extreme weights",
        edits: &[
            ("method.kind", "\"guertin\""),
            ("method.gamma", "100.0"),
            ("method.kappa", "100.0"),
            ("method.taps", "3"),
        ],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
    Case {
        name: "MLAA on every method, longest search, smallest threshold, stereo",
        edits: &[
            ("method.antialias", "\"mlaa\""),
            ("method.mlaa_threshold", "0.0001"),
            ("method.mlaa_search_distance", "64"),
        ],
        id: "M2-S3-T1-A5-stereo",
        frame: 3,
    },
    Case {
        name: "MLAA on depth edges, grazing camera",
        edits: &[("method.antialias", "\"mlaa\""), ("method.mlaa_edges", "\"depth\""), ("camera.height", "0.01")],
        id: "M2-S2-T3-A5",
        frame: 3,
    },
    Case {
        name: "accumulation buffer, 2 instants",
        edits: &[("method.kind", "\"accum\""), ("method.instants", "2")],
        id: "M3-S3-T5-A5",
        frame: 3,
    },
];

/// Per method, the largest block-mean difference from the CPU tracer (relative to the
/// tracer's mean over the frame) and why that much.
const BOUNDS: &[(Method, f64, &str)] = &[
    (Method::Tracer, 0.0, "the reference"),
    (Method::Accum, 0.2, "K instants strobe where the tracer smears (0.09 on the shipped frame)"),
    (Method::Mcguire, 0.15, "post-process blur of the tracer's mid-shutter frame"),
    (Method::Guertin, 0.15, "post-process blur of the tracer's mid-shutter frame"),
    (Method::Analytic, 0.15, "one shading per interval: the contact shadow stays sharp (0.04 on the shipped frame)"),
];

/// Block-mean difference allowed between a method's CPU and GPU frames, relative to the
/// CPU frame's mean: the devices draw different samples.
const DEVICE_BOUND: f64 = 0.2;

struct Scale {
    width: u32,
    height: u32,
    samples: [u32; 5],
}

fn scale() -> Scale {
    if std::env::var_os("BLURLAB_HARD_CASES_FULL").is_some() {
        Scale { width: 64, height: 36, samples: [4, 8, 16, 32, 64] }
    } else {
        Scale { width: 32, height: 18, samples: [1, 2, 4, 8, 16] }
    }
}

fn set(table: &mut toml::Table, path: &str, value: toml::Value) {
    let keys: Vec<&str> = path.split('.').collect();
    let mut at = table;
    for k in &keys[..keys.len() - 1] {
        let next = at.entry((*k).to_owned()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        at = match next {
            toml::Value::Table(t) => t,
            other => panic!("{path}: {k} is {other:?}, not a table"),
        };
    }
    at.insert(keys[keys.len() - 1].to_owned(), value);
}

/// The shipped design with a `hard` preset and `edits` applied.
fn design(edits: &[(&str, &str)], scale: &Scale) -> Design {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    let preset = format!(
        "width = {}\nheight = {}\nframes = 8\nfirst_frame = 17\nsamples_per_pixel = {:?}",
        scale.width, scale.height, scale.samples
    );
    set(&mut table, "presets.hard", toml::Value::Table(toml::from_str(&preset).unwrap()));
    for (key, value) in edits {
        let v: toml::Table = toml::from_str(&format!("v = {value}")).unwrap();
        let v = v["v"].clone();
        let parts: Vec<&str> = key.split('.').collect();
        if let [a, b, index, field] = parts[..]
            && let Ok(i) = index.parse::<usize>()
        {
            // factors.KIND.INDEX.KEY: a field of one level.
            let level = table[a][b].as_array_mut().unwrap()[i].as_table_mut().unwrap();
            level.insert(field.to_owned(), v);
        } else {
            set(&mut table, key, v);
        }
    }
    let text = toml::to_string(&table).unwrap();
    Design::parse(&path, &text, "hard-case").unwrap_or_else(|e| panic!("the hard design must be legal: {e}"))
}

/// Means over blocks of 64 pixels (8 x 8, or taller or wider where the image is narrower
/// than 8), summed over channels, in f64.
fn block_means(img: &LinearImage) -> Vec<f64> {
    let bw = 8.min(img.width).max(64 / img.height.clamp(1, 8)).min(img.width);
    let bh = (64 / bw).min(img.height);
    let mut out = Vec::new();
    for by in (0..img.height).step_by(bh as usize) {
        for bx in (0..img.width).step_by(bw as usize) {
            let (mut sum, mut n) = (0.0, 0.0);
            for y in by..(by + bh).min(img.height) {
                for x in bx..(bx + bw).min(img.width) {
                    let p = img.pixels[(y * img.width + x) as usize];
                    sum += p.iter().map(|&c| f64::from(c)).sum::<f64>();
                    n += 1.0;
                }
            }
            out.push(sum / n);
        }
    }
    out
}

/// The largest block-mean difference between `a` and `b`, relative to `b`'s mean over the
/// frame (absolute where that mean is zero).
fn block_difference(a: &LinearImage, b: &LinearImage) -> f64 {
    let (ma, mb) = (block_means(a), block_means(b));
    let scale = mb.iter().sum::<f64>() / mb.len() as f64;
    let worst = ma.iter().zip(&mb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    if scale > 0.0 { worst / scale } else { worst }
}

/// Where `img` has a non-finite or negative channel, the first such pixel.
fn check_finite(img: &LinearImage, what: &str, failures: &mut Vec<String>) {
    if let Some((i, p)) = img.pixels.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite() && *c >= 0.0)) {
        failures.push(format!("{what}: pixel {i} ({}, {}) is {p:?}", i as u32 % img.width, i as u32 / img.width));
    }
}

fn spec_for(design: &Design, method: Method) -> MethodSpec {
    if design.method() == method { design.method_spec() } else { MethodSpec::of(method) }
}

#[test]
fn every_method_renders_every_hard_case_finite_and_close_to_the_tracer_on_every_device() {
    let scale = scale();
    let full = std::env::var_os("BLURLAB_HARD_CASES_FULL").is_some();
    let mut gpu_missing = None;
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    // One GPU renderer per environment: opening one compiles its kernels.
    let mut envs: Vec<(String, EnvironmentMap)> = Vec::new();
    let designs: Vec<Design> = CASES.iter().map(|c| design(c.edits, &scale)).collect();
    for d in &designs {
        let key = format!("{:?}", d.lighting);
        if !envs.iter().any(|(k, _)| *k == key) {
            envs.push((key, EnvironmentMap::from_lighting(&d.lighting).unwrap()));
        }
    }
    let mut gpus: HashMap<String, Renderer<'_>> = HashMap::new();
    for (key, env) in &envs {
        match Renderer::open(DeviceChoice::Gpu, env) {
            Ok(r) => {
                gpus.insert(key.clone(), r);
            }
            Err(e) => gpu_missing = Some(e.to_string()),
        }
    }
    if let Some(reason) = &gpu_missing {
        gpu::skip_or_fail(
            "every_method_renders_every_hard_case_finite_and_close_to_the_tracer_on_every_device",
            reason,
        );
    }
    for (case, d) in CASES.iter().zip(&designs) {
        let key = format!("{:?}", d.lighting);
        let env = &envs.iter().find(|(k, _)| *k == key).unwrap().1;
        let preset = d.preset("hard").unwrap();
        let id: StimulusId = case.id.parse().unwrap();
        let scene = d.frame_scene_with(&preset, &id, case.frame).unwrap();
        let cpu = Renderer::cpu(env);
        let reference = cpu.render(&MethodSpec::of(Method::Tracer), &scene).unwrap().image;
        check_finite(&reference, &format!("{}: tracer on the CPU", case.name), &mut failures);
        for &(method, bound, why) in BOUNDS {
            let spec = spec_for(d, method);
            let what = format!("{}: {method}", case.name);
            let on_cpu = match cpu.render(&spec, &scene) {
                Ok(f) => f.image,
                Err(e) => {
                    failures.push(format!("{what} on the CPU: {e}"));
                    continue;
                }
            };
            check_finite(&on_cpu, &format!("{what} on the CPU"), &mut failures);
            let to_tracer = block_difference(&on_cpu, &reference);
            if method != Method::Tracer && to_tracer > bound {
                failures.push(format!("{what} on the CPU: {to_tracer:.3} from the tracer, bound {bound} ({why})"));
            }
            let mut between = None;
            if let Some(gpu) = gpus.get(&key) {
                match gpu.render(&spec, &scene) {
                    Ok(f) => {
                        check_finite(&f.image, &format!("{what} on the GPU"), &mut failures);
                        let diff = block_difference(&f.image, &on_cpu);
                        if diff > DEVICE_BOUND {
                            failures.push(format!("{what}: GPU {diff:.3} from the CPU in block means"));
                        }
                        between = Some(diff);
                    }
                    Err(RenderError::Settings(e)) => failures.push(format!("{what}: refused on the GPU only: {e}")),
                    Err(e) => failures.push(format!("{what} on the GPU: {e}")),
                }
            }
            rows.push(format!(
                "| {} | {method} | {to_tracer:.3} | {} |",
                case.name,
                between.map_or("-".to_owned(), |b| format!("{b:.3}"))
            ));
        }
    }
    if full {
        println!("| case | method | to the CPU tracer | GPU to CPU |\n| --- | --- | --- | --- |");
        for r in &rows {
            println!("{r}");
        }
    } else {
        for r in &rows {
            eprintln!("{r}");
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}
