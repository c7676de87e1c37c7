#!/usr/bin/env bash
# Issue 25's item 6 on a machine with a GPU, in one call: how long `blurlab predict` takes on
# each of the thesis's five tests when the GPU renders the references and ColorVideoVDP runs
# on two CPU cores, the issue's "one thesis test from rendered clips in under 10 minutes on
# 2 cores" (on the 2-core VM without a GPU, the tests needing one reference per shutter took
# 721-1522 s of computing, nearly all of it rendering the references: BENCHMARKS.md, "Speed
# and memory").
#
# For each test: the GPU renders its clips (the design's `clip` preset: 640x360 per eye,
# frames 45-74, 4-512 samples per pixel) into a fresh set, timed apart, since the item times
# prediction from rendered clips; then `predict --reference shutter --device gpu` (the frozen
# observer, references rendered in the call at 1024 samples per pixel) is timed with its peak
# memory. Then 5.7.2 `shutter` once more from its cached references and scores (what a second
# forecast or a resumed one costs), and last 5.7.2 with `--reference eye` (a 120-frame
# reference per material and speed, the heaviest forecast).
#
# Every process runs pinned to $CORES (default 0,1: two cores) with RAYON_NUM_THREADS=2; the
# GPU is the machine's. The forecasts' Spearman correlations are printed beside the committed
# CPU ones (analysis/observer/): the GPU tracer's samples are not the CPU's, so they agree
# within the references' noise, not to the bit. Prints one JSON object on stdout and writes it
# to $OUT/observer-gpu.json, each step's line to $OUT/observer-gpu-steps.jsonl as it finishes
# (kept if the call is cut short) and the commands' output to $OUT/observer-gpu.log.
#
# Expected on one H100 or H200: about 6 minutes in all, most of it the metric on two cores
# (about 4 s per mono sequence of 30 frames, 15 s with `eye`'s 120); run it with timeout_s 600.
# QUICK=1 runs the quick preset instead (160x90, 8 frames, 1-16 samples per pixel; under a
# minute on lavapipe on 2 cores), to check the script itself; its Spearman are not the study's.
#
# The binary and the Vulkan loader: as bench/lib/device-prelude.sh says.
#
# Usage: bench/gpu-observer.sh            (from the repository root)
#   on the device machine (carry: bin, .gl):
#   for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig; OUT=$OUT bench/gpu-observer.sh
set -euo pipefail
cd "$(dirname "$0")/.."

script=gpu-observer
. bench/lib/device-prelude.sh
. bench/lib/thesis-tables.sh
set_dir="$work/set"
steps="$out/observer-gpu-steps.jsonl"
logfile="$out/observer-gpu.log"
: >"$steps"
: >"$logfile"

if [ "${QUICK:-0}" = 1 ]; then preset=quick; else preset=clip; fi
cores="${CORES:-0,1}"
export RAYON_NUM_THREADS="${RAYON_NUM_THREADS:-2}"
pin=()
if command -v taskset >/dev/null && [ "$(nproc --all)" -gt 2 ]; then
  if taskset -c "$cores" true 2>/dev/null; then
    pin=(taskset -c "$cores")
  else
    log "taskset -c $cores fails here: running unpinned, with RAYON_NUM_THREADS=$RAYON_NUM_THREADS alone"
  fi
fi
log "binary $bin, preset $preset, pinned to ${pin[*]:-all cores (taskset missing or 2 cores)}, RAYON_NUM_THREADS=$RAYON_NUM_THREADS"

# Runs a command pinned, its output into the log; sets $seconds and $peak_mb (the largest
# resident set of the command, from getrusage of the waited child).
measure() {
  local result status
  result=$(python3 -c '
import resource, subprocess, sys, time
t0 = time.monotonic()
with open(sys.argv[1], "a") as log:
    status = subprocess.call(sys.argv[2:], stdout=log, stderr=log)
peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(f"{time.monotonic() - t0:.3f} {peak_kib / 1024:.1f} {status}")
' "$logfile" "${pin[@]}" "$@")
  read -r seconds peak_mb status <<<"$result"
  return "$status"
}

# The Spearman correlation in a predict.json ("null" where the forecast has none).
spearman() {
  local v
  v=$(grep -o '"spearman": *[-0-9.eE+]*' "$1" 2>/dev/null | head -1 | sed 's/.*: *//')
  echo "${v:-null}"
}

render_clips() { # VIEWS ONLY
  echo "== stimuli render --views $1 --only '$2'" >>"$logfile"
  measure "$bin" stimuli render --preset "$preset" --views "$1" --only "$2" --device gpu --progress lines \
    --resume --out "$set_dir"
}

forecast() { # TABLE REFERENCE [NAME]
  local table=$1 reference=$2 name=${3:-$1-$2} clips_s committed
  local dir=$work/forecasts/$name
  thesis_table "$table"
  render_clips "$table_views" "$table_only"
  clips_s=$seconds
  echo "== predict $name" >>"$logfile"
  measure "$bin" predict "experiments/$table_experiment.toml" --stimuli "$set_dir" --reference "$reference" \
    --votes "analysis/reference/$table_votes.csv" --device gpu --out "$dir"
  committed=null
  if [ "$preset" = clip ]; then committed=$(spearman "analysis/observer/$table-$reference/predict.json"); fi
  local line="{\"step\": \"$name\", \"clips_seconds\": $clips_s, \"predict_seconds\": $seconds, \"predict_peak_mb\": $peak_mb, \"spearman\": $(spearman "$dir/predict.json"), \"spearman_committed_cpu\": $committed}"
  log "$line"
  echo "$line" >>"$steps"
}

for table in $thesis_tables; do
  forecast "$table" shutter
done
# The same forecast again: its references and scores are cached in the set.
forecast 5.7.2 shutter 5.7.2-shutter-cached
# Last, the heaviest: 120 reference frames per material and speed, and the metric on all of them.
forecast 5.7.2 eye

gpu=$(command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name --format=csv,noheader | head -1 || echo unknown)
{
  echo "{"
  echo "  \"script\": \"bench/gpu-observer.sh\","
  echo "  \"preset\": \"$preset\","
  echo "  \"binary\": \"$bin\","
  echo "  \"gpu\": \"$gpu\","
  echo "  \"cpu\": \"$(awk -F': ' '/^model name/ { print $2; exit }' /proc/cpuinfo)\","
  echo "  \"pinned_cores\": \"${pin[*]:-none}\","
  echo "  \"rayon_threads\": $RAYON_NUM_THREADS,"
  echo "  \"steps\": ["
  sed '$!s/$/,/; s/^/    /' "$steps"
  echo "  ]"
  echo "}"
} | tee "$out/observer-gpu.json"
