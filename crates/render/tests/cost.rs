//! The cost sweep (`render::measure::cost`) on the study's scene shrunk to 64 x 36 pixels (a `tiny`
//! preset added to the shipped design): the tracer's error falls as 1/sqrt(spp), each
//! method's finest setting approaches the reference or its bias floor, a stopped sweep
//! resumes to the same table, and bad requests are clear errors. CPU only.

#![allow(clippy::unwrap_used, reason = "test helpers fail the test by panicking")]

use std::path::{Path, PathBuf};

use render::env::EnvironmentMap;
use render::measure::cost::{CostError, CostRequest, run_cost};
use render::{DeviceChoice, Renderer};
use study::Method;
use study::cost::CostSweep;
use study::design::Design;

/// The shipped design with a `tiny` preset: 64 x 36 pixels, two frames with the sphere in
/// view (timeline 21 and 22, as the quick preset's frames 4 and 5).
fn tiny_design(dir: &Path) -> Design {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    let text = std::fs::read_to_string(shipped).unwrap()
        + "\n[presets.tiny]\nwidth = 64\nheight = 36\nframes = 2\nfirst_frame = 21\nsamples_per_pixel = [1, 2, 4, 8, 16]\n";
    let path = dir.join("tiny.toml");
    std::fs::write(&path, &text).unwrap();
    Design::load(&path).unwrap()
}

fn env(design: &Design) -> EnvironmentMap {
    let id = design.ids(study::design::Views::Mono)[0];
    let scene = design.frame_scene_with(&design.preset("tiny").unwrap(), &id, 0).unwrap();
    EnvironmentMap::from_lighting(&scene.lighting).unwrap()
}

fn request(out: PathBuf, methods: Vec<Method>, max_spp: u32, repetitions: u32, reference_spp: u32) -> CostRequest {
    CostRequest {
        preset: "tiny".into(),
        cell: "M3-S3-T5".into(),
        frames: vec![0],
        methods,
        reference_spp,
        max_spp,
        repetitions,
        out,
        max_new_points: None,
        mlaa: false,
    }
}

fn sweep(design: &Design, env: &EnvironmentMap, req: &CostRequest) -> CostSweep {
    let renderer = Renderer::open(DeviceChoice::Cpu, env).unwrap();
    let outcome = run_cost(design, &renderer, req, |_| {}).unwrap();
    assert!(outcome.complete);
    outcome.sweep
}

#[test]
fn the_tracer_error_falls_as_one_over_sqrt_spp_and_every_finest_setting_approaches_its_floor() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let env = env(&design);
    let methods = vec![Method::Tracer, Method::Accum, Method::Mcguire, Method::Guertin, Method::Analytic];
    let s = sweep(&design, &env, &request(dir.path().join("out"), methods, 16, 4, 8192));
    let rows = s.rows();
    let tracer: Vec<_> = rows.iter().filter(|r| r.method == Method::Tracer).collect();
    assert_eq!(tracer.iter().map(|r| r.value).collect::<Vec<_>>(), vec![1, 2, 4, 8, 16]);
    // Slope of log(RMSE) against log(spp), least squares over the repetitions' medians, with
    // a tolerance of three standard errors from the repetitions' scatter of log(RMSE) (the
    // median of R values has about 1.57 sigma^2 / R variance). Independent Monte Carlo
    // gives -1/2; the tracer's Owen-scrambled Sobol samples stratify the pixel area and the
    // shutter, so its error must fall at least that fast, and not faster than the -1 of a
    // stratified estimator of a discontinuous integrand (edges, the sphere's silhouette).
    let xs: Vec<f64> = tracer.iter().map(|r| f64::from(r.value).ln()).collect();
    let ys: Vec<f64> = tracer.iter().map(|r| r.rmse.median.ln()).collect();
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let slope = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>() / sxx;
    let log_sd: Vec<f64> = tracer
        .iter()
        .map(|r| {
            let pts: Vec<f64> = s
                .points
                .iter()
                .filter(|p| p.method == Method::Tracer && p.value == r.value)
                .map(|p| p.rmse.ln())
                .collect();
            study::stats::Summary::of(&pts).sample_sd()
        })
        .collect();
    let var_slope = xs.iter().zip(&log_sd).map(|(x, sd)| ((x - mx) / sxx).powi(2) * sd * sd / 4.0 * 1.57).sum::<f64>();
    let tolerance = 3.0 * var_slope.sqrt();
    assert!(slope < -0.5 + tolerance, "slope {slope}, tolerance {tolerance}, sd {log_sd:?}");
    assert!(slope > -1.0 - tolerance, "slope {slope}, tolerance {tolerance}, sd {log_sd:?}");
    // Against the Monte Carlo rate: every doubling lowers the error by at least 1/sqrt(2)
    // (within the tolerance), and the table's own fit reports the same exponent.
    assert!((s.tracer_exponent().unwrap() - slope).abs() < 1e-9);
    // Each doubling of the samples lowers the error.
    assert!(
        tracer.windows(2).all(|w| {
            let expected = (f64::from(w[0].value) / f64::from(w[1].value)).sqrt();
            w[1].rmse.median / w[0].rmse.median < expected * (1.0 + tolerance)
        }),
        "{tracer:?}"
    );
    // The reference is converged: its standard error is below a tenth of the finest error.
    let finest = tracer.last().unwrap();
    assert!(s.reference_standard_error() < 0.1 * finest.rmse.median);
    // FLIP falls with the samples too.
    assert!(finest.flip.median < tracer[0].flip.median);
    // The observer's prediction: every frame judged, none above the metric's maximum (10 JOD
    // for a frame shown as the reference is), and 16 samples closer to the reference than 1.
    let jod = |r: &study::cost::CostRow| r.jod.expect("every point judged").median;
    assert!(rows.iter().all(|r| jod(r) <= 10.0 + 1e-6 && jod(r) > 0.0), "{rows:?}");
    assert!(jod(finest) > jod(tracer[0]), "{} vs {}", jod(finest), jod(tracer[0]));

    // Accumulation buffer (centred instants, 4 spp each): more instants approach the
    // reference; at 16 samples in all it is within 3x the tracer's error at 16 spp (its
    // instants are not stratified across the frame and its time is quantised).
    let accum: Vec<_> = rows.iter().filter(|r| r.method == Method::Accum).collect();
    assert_eq!(accum.iter().map(|r| r.value).collect::<Vec<_>>(), vec![1, 2, 4]);
    assert!(accum.windows(2).all(|w| w[1].rmse.median < w[0].rmse.median), "{accum:?}");
    assert!(accum[2].rmse.median < 3.0 * finest.rmse.median, "{} vs {}", accum[2].rmse.median, finest.rmse.median);
    // Filters: at the highest input level their error is the G-buffer's noise plus a bias
    // floor that more taps do not remove: the finest taps stay within 2x the tracer's error
    // at the same input samples and above 0.5x of it.
    for m in [Method::Mcguire, Method::Guertin] {
        let top: Vec<_> = rows.iter().filter(|r| r.method == m && r.input_spp == 16).collect();
        assert_eq!(top.len(), study::method::SWEEP_TAPS.len());
        let e = top.last().unwrap().rmse.median;
        assert!(e < 2.0 * finest.rmse.median && e > 0.5 * finest.rmse.median, "{m}: {e} vs {}", finest.rmse.median);
    }
    // Analytic rasterizer: its bias floor (tessellation, one shading per interval) is what
    // the largest budget reaches; the budget past 16 intervals changes it by under 5 %.
    let analytic: Vec<_> = rows.iter().filter(|r| r.method == Method::Analytic && r.knob == "intervals").collect();
    assert_eq!(analytic.iter().map(|r| r.value).collect::<Vec<_>>(), study::method::SWEEP_INTERVALS);
    let (a16, a64) = (analytic[4].rmse.median, analytic[6].rmse.median);
    assert!((a64 - a16).abs() < 0.05 * a16, "{a16} vs {a64}");
    assert!(a64 < 5.0 * tracer[0].rmse.median);
    // Supersampled, the same shading work per pixel spread over n x n points: the one
    // point's aliasing goes, so 4 x 4 points beat one at the same budget.
    let mut ss: Vec<_> = rows.iter().filter(|r| r.method == Method::Analytic && r.knob == "supersampling").collect();
    ss.sort_by_key(|r| r.value);
    assert_eq!(ss.iter().map(|r| r.value).collect::<Vec<_>>(), study::method::SWEEP_SUPERSAMPLING);
    eprintln!(
        "analytic 8 intervals: one point {}, 2x2 {}, 4x4 {}",
        analytic[2].rmse.median, ss[0].rmse.median, ss[1].rmse.median
    );
    assert!(ss[1].rmse.median < analytic[2].rmse.median, "{ss:?} vs {:?}", analytic[2]);
    // FLIP maps of each knob's coarsest and finest settings beside the frames.
    let maps = dir.path().join("out/maps");
    assert!(maps.join("tracer-spp16-in16-f0000-r0-flip.png").exists());
    assert!(maps.join("tracer-spp1-in1-f0000-r0.png").exists());
    let names: Vec<String> =
        std::fs::read_dir(&maps).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    for knob_end in
        ["analytic-intervals4-", "analytic-intervals64-", "analytic-supersampling2-", "analytic-supersampling4-"]
    {
        assert!(names.iter().any(|n| n.starts_with(knob_end) && n.ends_with("-flip.png")), "{knob_end}: {names:?}");
    }
}

#[test]
fn a_stopped_sweep_resumes_to_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let env = env(&design);
    let renderer = Renderer::open(DeviceChoice::Cpu, &env).unwrap();
    let methods = vec![Method::Tracer, Method::Accum];
    let whole = sweep(&design, &env, &request(dir.path().join("a"), methods.clone(), 4, 2, 4096));
    let mut req = request(dir.path().join("b"), methods, 4, 2, 4096);
    req.max_new_points = Some(3);
    let part = run_cost(&design, &renderer, &req, |_| {}).unwrap();
    assert_eq!((part.measured, part.complete), (3, false));
    req.max_new_points = None;
    let mut seen = Vec::new();
    let resumed = run_cost(&design, &renderer, &req, |p| seen.push(p)).unwrap();
    assert!(resumed.complete);
    assert_eq!(resumed.kept, 3);
    assert_eq!(resumed.measured + 3, whole.points.len());
    assert_eq!(seen.last().unwrap().done, whole.points.len());
    // The points kept are the first run's, times included.
    for p in &part.sweep.points {
        assert!(resumed.sweep.points.contains(p), "{p:?}");
    }
    // The errors are the uninterrupted sweep's, point by point (the same seeds).
    let errors = |s: &CostSweep| -> Vec<(String, f64, f64, f64, Option<f64>)> {
        s.points.iter().map(|p| (p.key(), p.rmse, p.rmse_linear, p.flip, p.jod)).collect()
    };
    assert_eq!(errors(&resumed.sweep), errors(&whole));
    // Once complete, a rerun measures nothing and gives the same table.
    let again = run_cost(&design, &renderer, &req, |_| {}).unwrap();
    assert_eq!((again.measured, again.kept), (0, whole.points.len()));
    assert_eq!(again.sweep.csv(), resumed.sweep.csv());
    // A budget of no new points still reports every kept point (redrawing a report).
    req.max_new_points = Some(0);
    let redrawn = run_cost(&design, &renderer, &req, |_| {}).unwrap();
    assert_eq!((redrawn.measured, redrawn.kept, redrawn.complete), (0, whole.points.len(), true));
    assert_eq!(redrawn.sweep.csv(), resumed.sweep.csv());
    // With a point missing it stops short of measuring it, keeping the others.
    let missing = dir.path().join("b/points").join(format!("{}.json", whole.points[0].key()));
    std::fs::remove_file(&missing).unwrap();
    let short = run_cost(&design, &renderer, &req, |_| {}).unwrap();
    assert_eq!((short.measured, short.kept, short.complete), (0, whole.points.len() - 1, false));
    req.max_new_points = None;
    // Another request in the same folder is refused, naming what differs.
    req.reference_spp = 8192;
    let e = run_cost(&design, &renderer, &req, |_| {}).unwrap_err();
    assert!(e.is_bad_input() && e.to_string().contains("--reference-spp"), "{e}");
}

#[test]
fn bad_requests_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let design = tiny_design(dir.path());
    let env = env(&design);
    let renderer = Renderer::open(DeviceChoice::Cpu, &env).unwrap();
    let check = |req: CostRequest, needle: &str| {
        let e: CostError = run_cost(&design, &renderer, &req, |_| {}).unwrap_err();
        assert!(e.is_bad_input() && e.to_string().contains(needle), "{e}");
    };
    let base = || request(dir.path().join("x"), vec![Method::Tracer], 4, 1, 4096);
    check(CostRequest { cell: "M9-S3-T5".into(), ..base() }, "M9 is not a level of the design (it has M1..M3)");
    check(CostRequest { cell: "M3-S3".into(), ..base() }, "--id `M3-S3`");
    check(CostRequest { frames: vec![5], ..base() }, "frame 5 is outside the sequence");
    check(CostRequest { preset: "huge".into(), ..base() }, "huge");
    check(CostRequest { repetitions: 0, ..base() }, "--repetitions");
    // A 16-spp reference judging 4 spp: its noise is half the error it judges (refused
    // before rendering).
    check(
        CostRequest { reference_spp: 16, out: dir.path().join("y"), ..base() },
        "the reference is not converged enough for this sweep: a 16-spp reference's standard error is about 0.50",
    );
    // A filter alone (no tracer samples to compare before rendering) at a 1-spp input,
    // judged by a 2-spp reference: the measured standard error, on its finest setting, is
    // refused.
    let filters = CostRequest {
        methods: vec![Method::Mcguire],
        max_spp: 1,
        reference_spp: 2,
        out: dir.path().join("z"),
        ..base()
    };
    check(filters, "the reference is not converged enough: its standard error");
    check(CostRequest { methods: vec![Method::Accum], mlaa: true, ..base() }, "add tracer to --methods");
}

/// MLAA's curve (`--mlaa`) on the checker's still frame at the quick preset's 160 x 90
/// pixels: every setting is measured on the same centre-sampled input, the filter lowers
/// its error, and the settings that coincide give the same bytes.
#[test]
fn mlaa_sweeps_one_centre_sampled_input_and_lowers_its_error() {
    use study::method::antialias::{
        SWEEP_KNOB_SEARCH_DISTANCE, SWEEP_KNOB_THRESHOLD, SWEEP_MLAA_SEARCH_DISTANCES, SWEEP_MLAA_THRESHOLDS_PERCENT,
    };
    let dir = tempfile::tempdir().unwrap();
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    let text = std::fs::read_to_string(shipped).unwrap()
        + "\n[presets.small]\nwidth = 160\nheight = 90\nframes = 1\nfirst_frame = 17\nsamples_per_pixel = [1, 4, 8, 12, 16]\n";
    let path = dir.path().join("small.toml");
    std::fs::write(&path, &text).unwrap();
    let design = Design::load(&path).unwrap();
    let id = design.ids(study::design::Views::Mono)[0];
    let probe = design.frame_scene_with(&design.preset("small").unwrap(), &id, 0).unwrap();
    let env = EnvironmentMap::from_lighting(&probe.lighting).unwrap();
    let req = CostRequest {
        preset: "small".into(),
        cell: "M2-S1-T1".into(),
        mlaa: true,
        ..request(dir.path().join("out"), vec![Method::Tracer], 16, 1, 2048)
    };
    let s = sweep(&design, &env, &req);
    let rows = s.rows();
    let along = |knob: &str| -> Vec<_> { rows.iter().filter(|r| r.knob == knob).collect() };
    let (distances, thresholds) = (along(SWEEP_KNOB_SEARCH_DISTANCE), along(SWEEP_KNOB_THRESHOLD));
    assert_eq!(distances.iter().map(|r| r.value).collect::<Vec<_>>(), SWEEP_MLAA_SEARCH_DISTANCES);
    assert_eq!(thresholds.iter().map(|r| r.value).collect::<Vec<_>>(), SWEEP_MLAA_THRESHOLDS_PERCENT);
    // The top level's samples, through the pixel centres, whatever the filter.
    assert!(distances.iter().chain(&thresholds).all(|r| r.input_spp == 16 && r.work_units == 16.0 * 160.0 * 90.0));
    let unfiltered = distances[0].rmse.median;
    let mlaa = distances.iter().find(|r| r.value == 12).unwrap();
    eprintln!(
        "centre-sampled 16 spp: RMSE {unfiltered:.5}, + MLAA {:.5}; jittered 16 spp {:.5}",
        mlaa.rmse.median,
        rows.iter().find(|r| r.knob == "spp" && r.value == 16).unwrap().rmse.median
    );
    assert!(mlaa.rmse.median < unfiltered, "{} vs {unfiltered}", mlaa.rmse.median);
    // Threshold 0.1 at distance 12 is the default setting of the other curve: one input, one
    // filter, the same error to the last bit.
    let default_threshold = thresholds.iter().find(|r| r.value == 10).unwrap();
    assert_eq!(default_threshold.rmse.median.to_bits(), mlaa.rmse.median.to_bits());
    // A higher threshold finds fewer edges: at 0.4 the frame is closer to the unfiltered one.
    let high = thresholds.last().unwrap().rmse.median;
    assert!((high - unfiltered).abs() < (mlaa.rmse.median - unfiltered).abs(), "{high}");
    assert_eq!(s.rows().iter().filter(|r| r.knob == "spp").count(), 6);
    assert!(dir.path().join("out/maps/tracer-mlaa_search_distance12-in16-f0000-r0-flip.png").exists());
}
