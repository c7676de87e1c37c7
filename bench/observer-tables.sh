#!/usr/bin/env bash
# The ColorVideoVDP observer against the thesis's five published vote tables, at the study's
# own settings (issue 25): the full preset's 640x360 frames and 4-512 samples per pixel, over
# one second from the middle of each sequence (the design's `clip` preset, frames 45-74).
#
#   bench/observer-tables.sh mono                # phase 1: the two mono tables, both references
#   bench/observer-tables.sh stereo REFERENCE    # phase 2: the three stereo tables, held out,
#                                                # with the reference phase 1 chose (eye|shutter)
#
# The protocol: the reference (and any setting) is chosen on the mono tables only; the stereo
# tables are then run once with everything frozen. Each step resumes: the clip set verifies
# and skips rendered sequences, and `predict` keeps its references and scores in the set
# (SET/observer/). Results go to analysis/observer/; the command of each is in its predict.md.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BLURLAB:-target/release/blurlab}
SET=${SET:-stimuli/out/clip}
OUT=${OUT:-analysis/observer}
DEVICE=${DEVICE:-auto}
[ -x "$BIN" ] || cargo build --release -p blurlab
render() { # VIEWS ONLY
  "$BIN" stimuli render --preset clip --views "$1" --only "$2" --device "$DEVICE" --resume --out "$SET"
}
predict() { # EXPERIMENT TABLE NAME OBSERVER-ARGS...
  local exp=$1 table=$2 name=$3
  shift 3
  "$BIN" predict "experiments/$exp.toml" --stimuli "$SET" --votes "analysis/reference/$table.csv" \
    --device "$DEVICE" --out "$OUT/$name" "$@"
}
case "${1:-}" in
  mono)
    render mono "M3 S2 T3 *"
    render mono "M2 S2 T3-T5 A3-A5"
    for ref in eye shutter; do
      predict mono-2-sampling-2afc thesis-5.6.3-mono-sampling-2afc "5.6.3-$ref" --reference "$ref"
      predict mono-3-interactions thesis-5.7.2-mono-interactions "5.7.2-$ref" --reference "$ref"
    done
    predict mono-2-sampling-2afc thesis-5.6.3-mono-sampling-2afc 5.6.3-flip --observer flip
    predict mono-3-interactions thesis-5.7.2-mono-interactions 5.7.2-flip --observer flip
    ;;
  stereo)
    ref=${2:?"name the reference chosen on the mono tables: eye or shutter"}
    render stereo "M3 S2 T3 *"
    render stereo "M3 S2 * A5"
    render stereo "M2 S2 T3-T5 A3-A5"
    predict stereo-2-sampling thesis-6.5.2-stereo-sampling "6.5.2-sampling-$ref" --reference "$ref"
    predict stereo-2-shutter thesis-6.5.2-stereo-shutter "6.5.2-shutter-$ref" --reference "$ref"
    predict stereo-3-interactions thesis-6.6.2-stereo-interactions "6.6.2-$ref" --reference "$ref"
    predict stereo-2-sampling thesis-6.5.2-stereo-sampling 6.5.2-sampling-flip --observer flip
    predict stereo-2-shutter thesis-6.5.2-stereo-shutter 6.5.2-shutter-flip --observer flip
    predict stereo-3-interactions thesis-6.6.2-stereo-interactions 6.6.2-flip --observer flip
    ;;
  *)
    sed -n '2,14p' "$0"
    exit 2
    ;;
esac
