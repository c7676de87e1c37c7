#!/usr/bin/env bash
# The ColorVideoVDP observer against the thesis's five published vote tables, at the study's
# own settings (issue 25): the full preset's 640x360 frames and 4-512 samples per pixel, over
# one second from the middle of each sequence (the design's `clip` preset, frames 45-74).
#
#   bench/observer-tables.sh mono                # phase 1: the two mono tables, each reference
#                                                # in $REFS (default: eye shutter sharp) and FLIP
#   bench/observer-tables.sh choose              # the rule: the reference with the highest mean
#                                                # Spearman over the two mono tables, among those
#                                                # measured (a tie goes to the one listed first:
#                                                # eye, shutter, sharp)
#   bench/observer-tables.sh stereo REFERENCE    # phase 2: the three stereo tables, held out,
#                                                # with the reference phase 1 chose
#   bench/observer-tables.sh all                 # the three steps in a row
#   bench/observer-tables.sh explore [TABLE...]  # post hoc, every table already seen: the `sharp`
#                                                # reference seen by a fixating eye, by a
#                                                # pursuing eye (`pursuit`) and by a population
#                                                # half fixating, half pursuing (`both`);
#                                                # and each pair judged against itself by a
#                                                # pursuing eye (`pursuit-pair`, the `sharp`
#                                                # quality naming the better of the two);
#                                                # TABLE: 5.6.3 5.7.2
#                                                # 6.5.2-sampling 6.5.2-shutter 6.6.2 (default all)
#   bench/observer-tables.sh prereg              # forecasts for a test no one has taken yet
#                                                # (test #3 at the fast speed,
#                                                # experiments/mono-3-interactions-fast.toml): the
#                                                # frozen observer, FLIP and the post hoc pursuit
#                                                # observers, into $OUT/preregistered/
#   bench/observer-tables.sh compare VOTES       # once people have taken it: the same four
#                                                # forecasts against their votes (VOTES: the
#                                                # report's mono-3-interactions-fast-votes.csv),
#                                                # and beside the votes' ceiling (stats ceiling)
#   bench/observer-tables.sh plan                # how many judges the recorded forecasts'
#                                                # test needs, if people at the fast speed
#                                                # prefer as they did at the medium speed
#                                                # (5.7.2): stats ceiling with 21 and 5 judges,
#                                                # into $OUT/preregistered/planning/
#   bench/observer-tables.sh reference-spp [TABLE...]  # the frozen `shutter` forecast of the
#                                                # mono tables (TABLE: 5.6.3 5.7.2, default
#                                                # both) with references of $SPPS samples per
#                                                # pixel (default 2048 4096; the frozen one,
#                                                # 1024, is $OUT/TABLE-shutter), into
#                                                # $OUT/reference-spp/; FLIP again beside them,
#                                                # to check the clips are the committed ones
#   bench/observer-tables.sh ceiling             # what a perfect forecast of the five tables
#                                                # reaches against their own noise (`blurlab
#                                                # stats ceiling`), beside the frozen observer,
#                                                # FLIP and the post hoc pursuit pairs, into
#                                                # $OUT/ceiling/ (seconds: no rendering)
#
# The protocol: the reference (and any setting) is chosen on the mono tables only; the stereo
# tables are then run once with everything frozen. Each step resumes: the clip set verifies
# and skips rendered sequences, and `predict` keeps its references and scores in the set
# (SET/observer/). Results go to analysis/observer/; the command of each is in its predict.md.
# `REFS=sharp bench/observer-tables.sh mono` adds one reference to the others' results.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BLURLAB:-target/release/blurlab}
SET=${SET:-stimuli/out/clip}
OUT=${OUT:-analysis/observer}
DEVICE=${DEVICE:-auto}
[ -x "$BIN" ] || cargo build --release -p blurlab
. bench/lib/thesis-tables.sh
render() { # VIEWS ONLY
  "$BIN" stimuli render --preset clip --views "$1" --only "$2" --device "$DEVICE" --resume --out "$SET"
}
predict() { # EXPERIMENT TABLE NAME OBSERVER-ARGS...
  local exp=$1 table=$2 name=$3
  shift 3
  echo "== predict $name ($(date -u +%H:%M:%S))" >&2
  "$BIN" predict "experiments/$exp.toml" --stimuli "$SET" --votes "analysis/reference/$table.csv" \
    --device "$DEVICE" --out "$OUT/$name" "$@"
}
prereg() { # NAME [VOTES] (the four observers of the recorded forecasts, into $OUT/preregistered/)
  local name=$1 votes=${2:-} dir=$OUT/preregistered/mono-3-interactions-fast
  local -a extra=()
  [ -n "$votes" ] && extra=(--votes "$votes")
  render mono "M2 S3 T3-T5 A3-A5"
  for observer in flip shutter sharp-pursuit sharp-pursuit-pair; do
    case $observer in
      flip) args=(--observer flip) ;;
      shutter) args=(--reference shutter) ;;
      sharp-pursuit) args=(--reference sharp --eye-movement pursuit) ;;
      sharp-pursuit-pair) args=(--reference sharp --eye-movement pursuit --judging pair) ;;
    esac
    echo "== $name $observer ($(date -u +%H:%M:%S))" >&2
    "$BIN" predict experiments/mono-3-interactions-fast.toml --stimuli "$SET" --device "$DEVICE" \
      --out "$dir/$name$observer" "${args[@]}" "${extra[@]}"
  done
}
case "${1:-}" in
  prereg)
    prereg ""
    ;;
  compare)
    votes=${2:?"give the vote table the report of the people's sessions wrote"}
    prereg compared- "$votes"
    # And how far each forecast is from a perfect one, given the measured votes' own noise.
    dir=$OUT/preregistered/mono-3-interactions-fast
    forecasts=()
    for observer in flip shutter sharp-pursuit sharp-pursuit-pair; do
      forecasts+=(--forecast "$dir/compared-$observer/predict.json")
    done
    "$BIN" stats ceiling "$votes" "${forecasts[@]}" --replications 10000 --seed 1 --out "$dir/compared-ceiling"
    ;;
  mono)
    render mono "M3 S2 T3 *"
    render mono "M2 S2 T3-T5 A3-A5"
    for ref in ${REFS:-eye shutter sharp}; do
      predict mono-2-sampling-2afc thesis-5.6.3-mono-sampling-2afc "5.6.3-$ref" --reference "$ref"
      predict mono-3-interactions thesis-5.7.2-mono-interactions "5.7.2-$ref" --reference "$ref"
    done
    predict mono-2-sampling-2afc thesis-5.6.3-mono-sampling-2afc 5.6.3-flip --observer flip
    predict mono-3-interactions thesis-5.7.2-mono-interactions 5.7.2-flip --observer flip
    ;;
  choose)
    python3 - "$OUT" <<'PY'
import json, os, sys
out = sys.argv[1]
def rho(name):
    return json.load(open(f"{out}/{name}/predict.json"))["agreement"]["spearman"]
measured = [r for r in ("eye", "shutter", "sharp")
            if all(os.path.isfile(f"{out}/{t}-{r}/predict.json") for t in ("5.6.3", "5.7.2"))]
if not measured:
    sys.exit(f"{out}: no reference has results on both mono tables; run `mono` first")
mean = {ref: (rho(f"5.6.3-{ref}") + rho(f"5.7.2-{ref}")) / 2 for ref in measured}
for ref, m in mean.items():
    print(f"{ref}: mean Spearman over the mono tables {m:.3f}", file=sys.stderr)
print(max(measured, key=lambda r: (mean[r], -measured.index(r))))
PY
    ;;
  stereo)
    ref=${2:?"name the reference chosen on the mono tables: eye, shutter or sharp"}
    # Table by table, so that an interrupted run leaves whole tables behind.
    render stereo "M3 S2 T3 *"
    predict stereo-2-sampling thesis-6.5.2-stereo-sampling "6.5.2-sampling-$ref" --reference "$ref"
    predict stereo-2-sampling thesis-6.5.2-stereo-sampling 6.5.2-sampling-flip --observer flip
    render stereo "M3 S2 * A5"
    predict stereo-2-shutter thesis-6.5.2-stereo-shutter "6.5.2-shutter-$ref" --reference "$ref"
    predict stereo-2-shutter thesis-6.5.2-stereo-shutter 6.5.2-shutter-flip --observer flip
    render stereo "M2 S2 T3-T5 A3-A5"
    predict stereo-3-interactions thesis-6.6.2-stereo-interactions "6.6.2-$ref" --reference "$ref"
    predict stereo-3-interactions thesis-6.6.2-stereo-interactions 6.6.2-flip --observer flip
    ;;
  explore)
    # Not a held-out test: the model was thought of after all five tables had been seen
    # (BENCHMARKS.md, "Post hoc: eye movements"). Results go to $OUT/explore/.
    shift
    for table in ${*:-$thesis_tables}; do
      thesis_table "$table" || exit 2
      render "$table_views" "$table_only"
      args=("$table_experiment" "$table_votes")
      for eyes in fixation pursuit both; do
        predict "${args[@]}" "explore/$table-sharp-$eyes" --reference sharp --eye-movement "$eyes"
      done
      predict "${args[@]}" "explore/$table-sharp-pursuit-pair" --reference sharp --eye-movement pursuit \
        --judging pair
    done
    ;;
  reference-spp)
    # A sensitivity check, not a new forecast: the references' samples are a setting, and
    # settings are the mono tables' to choose (the stereo tables stay as frozen).
    shift
    for table in ${*:-5.6.3 5.7.2}; do
      thesis_table "$table" || exit 2
      if [ "$table_views" != mono ]; then
        echo "reference-spp: $table is a stereo table, held out (5.6.3 or 5.7.2)" >&2
        exit 2
      fi
      render "$table_views" "$table_only"
      args=("$table_experiment" "$table_votes")
      predict "${args[@]}" "reference-spp/$table-flip" --observer flip
      for spp in ${SPPS:-2048 4096}; do
        predict "${args[@]}" "reference-spp/$table-shutter-$spp" --reference shutter --reference-spp "$spp"
      done
    done
    ;;
  plan)
    dir=$OUT/preregistered/mono-3-interactions-fast
    forecasts=()
    for observer in shutter flip sharp-pursuit sharp-pursuit-pair; do
      forecasts+=(--forecast "$dir/$observer/predict.json")
    done
    for judges in 21 5; do
      "$BIN" stats ceiling analysis/reference/thesis-5.7.2-mono-interactions.csv --judges-planned "$judges" \
        "${forecasts[@]}" --replications 10000 --seed 1 --out "$OUT/preregistered/planning/judges-$judges"
    done
    ;;
  ceiling)
    tables=()
    for t in 5.6.3-mono-sampling-2afc 5.7.2-mono-interactions 6.5.2-stereo-sampling 6.5.2-stereo-shutter \
      6.6.2-stereo-interactions; do
      tables+=("analysis/reference/thesis-$t.csv")
    done
    forecasts=()
    for f in 5.6.3-shutter 5.7.2-shutter 6.5.2-sampling-shutter 6.5.2-shutter-shutter 6.6.2-shutter \
      5.6.3-flip 5.7.2-flip 6.5.2-sampling-flip 6.5.2-shutter-flip 6.6.2-flip \
      explore/5.6.3-sharp-pursuit-pair explore/5.7.2-sharp-pursuit-pair explore/6.5.2-sampling-sharp-pursuit-pair \
      explore/6.5.2-shutter-sharp-pursuit-pair explore/6.6.2-sharp-pursuit-pair; do
      forecasts+=(--forecast "$OUT/$f/predict.json")
    done
    "$BIN" stats ceiling "${tables[@]}" "${forecasts[@]}" --replications 10000 \
      --seed 1 --out "$OUT/ceiling"
    ;;
  all)
    "$0" mono
    ref=$("$0" choose)
    "$0" stereo "$ref"
    ;;
  *)
    sed -n '2,/^set -euo/{/^#/p}' "$0"
    exit 2
    ;;
esac
