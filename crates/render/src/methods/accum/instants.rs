//! The accumulation buffer (Haeberli and Akeley 1990; thesis chapter 4): the brute-force
//! motion blur of rasterisers, K instantaneous renders at times spread over the open shutter,
//! averaged with equal weights (the box shutter). Here each instant is a tracer render with an
//! instantaneous shutter, so its only error against the tracer is the temporal aliasing of
//! K fixed times (strobed copies of the sphere) in place of a continuous time integral.
//!
//! Instants sit at the centres of K equal sub-intervals, or (`jitter`) at one random time in
//! each, from a seed derived from the eye's seed. Each instant has its own sample seeds. A
//! frame without motion during an open shutter needs no instants: it is one render with all
//! the samples, bit for bit the tracer's frame.

use study::method::AccumSettings;
use study::scene::FrameScene;
use study::seed::{mix, splitmix64};

use crate::io::LinearImage;

/// The time of instant `k` of `count` in the shutter `[open, close]`: the centre of its
/// sub-interval, or a point in it drawn from `jitter_seed`.
pub fn instant_time(open: f64, close: f64, k: u32, count: u32, jitter_seed: Option<u64>) -> f64 {
    let u = match jitter_seed {
        // The top 53 bits of a mixed 64-bit value: uniform in [0, 1).
        Some(seed) => (mix(seed, &[u64::from(k)]) >> 11) as f64 / (1u64 << 53) as f64,
        None => 0.5,
    };
    open + (close - open) * ((f64::from(k) + u) / f64::from(count))
}

/// The instantaneous scenes whose mean is the accumulation buffer's frame of `scene`.
pub fn instant_scenes(scene: &FrameScene, spec: &AccumSettings) -> Vec<FrameScene> {
    if !scene.needs_time_sampling() {
        return vec![scene.clone()];
    }
    let count = spec.instant_count();
    let spp = spec.samples_per_instant(scene.samples_per_pixel);
    let (open, close) = (scene.shutter.open, scene.shutter.close);
    // The jitter is one sequence per frame, shared by the eyes, so a stereo pair sees the
    // sphere at the same instants.
    let jitter_seed = spec.jittered().then(|| splitmix64(scene.views.first().map_or(0, |v| v.seed)));
    (0..count)
        .map(|k| {
            let mut instant = scene.at_instant(instant_time(open, close, k, count, jitter_seed));
            instant.samples_per_pixel = spp;
            for view in &mut instant.views {
                view.seed = mix(view.seed, &[u64::from(k), 0xACC]);
            }
            instant
        })
        .collect()
}

/// The mean of the instants' images, eye by eye (`instants[k][eye]`).
pub fn average(instants: &[Vec<LinearImage>]) -> Vec<LinearImage> {
    let Some(first) = instants.first() else { return Vec::new() };
    (0..first.len()).map(|eye| LinearImage::mean(&instants.iter().map(|i| &i[eye]).collect::<Vec<_>>())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instants_cover_the_shutter_evenly_or_one_per_stratum() {
        let even: Vec<f64> = (0..4).map(|k| instant_time(1.0, 2.0, k, 4, None)).collect();
        assert_eq!(even, vec![1.125, 1.375, 1.625, 1.875]);
        for k in 0..64 {
            let t = instant_time(1.0, 2.0, k, 64, Some(99));
            assert!(t >= 1.0 + f64::from(k) / 64.0 && t < 1.0 + f64::from(k + 1) / 64.0, "{k}: {t}");
        }
        assert_ne!(instant_time(1.0, 2.0, 3, 8, Some(1)), instant_time(1.0, 2.0, 3, 8, Some(2)));
    }

    #[test]
    fn samples_are_shared_among_instants_unless_set() {
        let spec = AccumSettings { instants: Some(8), ..AccumSettings::default() };
        assert_eq!(spec.samples_per_instant(512), 64);
        assert_eq!(spec.samples_per_instant(4), 1);
        assert_eq!(spec.samples_per_instant(129), 17);
        let spec = AccumSettings { samples_per_instant: Some(3), ..spec };
        assert_eq!(spec.samples_per_instant(512), 3);
    }
}
