#!/usr/bin/env bash
# The GPU measurements in one call: the tracer's benchmark (`bench tracer --device gpu`), the
# post-process filters' (`bench filters --device gpu`: ms per 1280x720 frame at N = 35),
# morphological antialiasing's (`bench mlaa --device gpu`: ms per 1280x720 frame), the
# analytic rasterizer's (`bench analytic --gpu`: its WGSL kernel and the CPU rasterizer on
# the same 640x360 frame at 8 intervals per pixel, 1 and 4 lighting samples), the
# participating-media marcher's (`bench media`: the thesis's Table 2.1 at 512x512), then
# a timed slice of the full study set (all five sample levels of M3-S3-T5, mono and stereo,
# 120 frames each, PNGs written), rendered once independently and once with --nested.
# Then the cost-of-accuracy sweep (`blurlab cost --device gpu`, into $OUT/cost/).
# Prints one JSON object on stdout; progress goes to stderr. Meant for a machine with a real
# GPU (the measurements before the cost sweep take under 8 minutes on one NVIDIA H200); with QUICK=1 it runs the quick preset instead
# (about 4 minutes on lavapipe on 2 cores, Table 2.1 at 64x64, to check the script itself).
#
# The binary and the Vulkan loader: as bench/lib/device-prelude.sh says. Results also go to
# $OUT (or ./results/gpu-full-set).
#
# Usage: bench/gpu-full-set.sh            (from the repository root)
set -euo pipefail
cd "$(dirname "$0")/.."

script=gpu-full-set
. bench/lib/device-prelude.sh

if [ "${QUICK:-0}" = 1 ]; then
  preset=quick; spp=8; cpu_spp=2; rounds=1
  # Table 2.1 at 512x512 takes lavapipe most of an hour a round: the check runs it small.
  media_args=(--size 64 --rounds 1)
else
  preset=full; spp=256; cpu_spp=8; rounds=3
  media_args=(--rounds "$((rounds * 10))")
fi

log "benchmark ($bin, spp $spp)"
"$bin" bench tracer --device gpu --json --spp "$spp" --cpu-spp "$cpu_spp" --rounds "$rounds" >"$out/bench.json"

log "filters (bench filters: McGuire 2012 and Guertin 2014 at 1280x720, N = 35)"
"$bin" bench filters --device gpu --json --rounds "$((rounds * 10))" >"$out/filters.json"

log "MLAA (bench mlaa: three passes on the 1280x720 benchmark frame; the thesis's Part II)"
"$bin" bench mlaa --device gpu --json --rounds "$((rounds * 10))" >"$out/mlaa.json"

log "analytic rasterizer (bench analytic --gpu: 640x360, 8 intervals, 1 and 4 lighting samples; 4 x 4 points per pixel)"
"$bin" bench analytic --gpu --json --lighting-samples 1 --rounds "$rounds" >"$out/analytic-1.json"
"$bin" bench analytic --gpu --json --lighting-samples 4 --rounds "$rounds" >"$out/analytic-4.json"
"$bin" bench analytic --gpu --json --lighting-samples 1 --supersampling 4 --rounds "$rounds" >"$out/analytic-4x4.json"

log "participating media (bench media: Table 2.1 at 512x512 (64x64 with QUICK=1), 16 lights, both data shapes; GPU only, the CPU twin is timed on lavapipe runs)"
"$bin" bench media --device gpu --json --cpu false "${media_args[@]}" >"$out/media.json"

# The slice is one of the design's 45 (material, speed, shutter) cells with all its levels
# and views; M3-S3-T5 is the most expensive cell, so 45 x the slice bounds the full set.
cells=45

slice() { # $1: name, then extra flags; prints the slice's JSON
  local name=$1
  shift
  local t0 t1 seconds frames bytes
  t0=$(now)
  "$bin" stimuli render --preset "$preset" --only "M3 S3 T5 *" --device gpu --progress lines \
    --out "$work/$name" "$@" 2>"$out/$name.log"
  t1=$(now)
  seconds=$(calc "$t1 - $t0")
  frames=$(find "$work/$name" -name 'frame-*.png' | wc -l)
  bytes=$(du -sb "$work/$name" | cut -f1)
  cp "$work/$name/M3-S3-T5-A5/manifest.json" "$out/$name-A5-manifest.json"
  echo "{\"seconds\": $seconds, \"png_frames\": $frames, \"bytes_written\": $bytes, \"full_set_bound_minutes\": $(calc "$seconds * $cells / 60")}"
}

log "slice, independent levels"
independent=$(slice independent)
log "slice, nested levels"
nested=$(slice nested --nested)

cat <<EOF | tee "$out/result.json"
{
  "script": "bench/gpu-full-set.sh",
  "preset": "$preset",
  "binary": "$bin",
  "bench": $(cat "$out/bench.json"),
  "filters": $(cat "$out/filters.json"),
  "mlaa": $(cat "$out/mlaa.json"),
  "analytic_1_lighting_sample": $(cat "$out/analytic-1.json"),
  "analytic_4_lighting_samples": $(cat "$out/analytic-4.json"),
  "analytic_4x4_points_1_lighting_sample": $(cat "$out/analytic-4x4.json"),
  "media_table_2_1": $(cat "$out/media.json"),
  "slice": {
    "sequences": "M3-S3-T5, levels A1-A5, mono and stereo, every frame, PNGs written",
    "note": "full_set_bound_minutes: 45 cells times this one, the most expensive",
    "independent": $independent,
    "nested": $nested
  }
}
EOF

# Last (so a time limit cannot cost the results above): the cost-of-accuracy sweep of
# issue #15 on the GPU, the same request as the committed CPU report
# analysis/cost/full-M2-S2-T5 (quick: as analysis/cost/quick-M2-S2-T5), into $OUT/cost/.
if [ "${QUICK:-0}" = 1 ]; then cost_spp=(--max-spp 16 --reference-spp 4096); else cost_spp=(--max-spp 256 --reference-spp 25600); fi
log "cost of accuracy (blurlab cost --device gpu, M2-S2-T5)"
"$bin" cost --preset "$preset" --id M2-S2-T5 --device gpu "${cost_spp[@]}" --repetitions 3 --quiet \
  --out "$out/cost" >&2 2>"$out/cost.log" || log "cost sweep failed: see $out/cost.log"
