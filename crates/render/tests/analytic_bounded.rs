//! The CPU analytic method's work is bounded at any bounce count (issue 31, defect 4): a
//! sphere point it shades from the back (a midpoint off its triangle) used to bounce inside
//! the sphere to `max_bounces` (its throughput sticks at the smallest subnormal, never 0).

use std::time::Instant;

use render::env::EnvironmentMap;
use render::methods::analytic::{AnalyticParams, render_frame};
use study::design::Design;

#[test]
fn the_analytic_method_finishes_at_a_huge_bounce_count_with_the_shutter_open() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../stimuli/navarro2011.toml");
    let design = Design::load(&path).unwrap();
    let mut preset = design.preset("quick").unwrap();
    (preset.width, preset.height) = (64, 36);
    let mut scene = design.frame_scene_with(&preset, &"M3-S3-T5-A3".parse().unwrap(), 3).unwrap();
    let env = EnvironmentMap::from_lighting(&scene.lighting).unwrap();
    let params = AnalyticParams::default();
    let reference = render_frame(&scene, &env, &params).unwrap();
    scene.integrator.max_bounces = 100_000_000;
    scene.integrator.russian_roulette_from = 100_000_000;
    let started = Instant::now();
    let frame = render_frame(&scene, &env, &params).unwrap();
    let seconds = started.elapsed().as_secs_f64();
    assert!(seconds < 20.0, "{seconds} s");
    assert!(frame.eyes[0].pixels.iter().flatten().all(|c| c.is_finite() && *c >= 0.0));
    assert_eq!(frame.eyes[0].pixels.len(), reference.eyes[0].pixels.len());
}
