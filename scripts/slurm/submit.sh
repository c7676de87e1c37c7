#!/usr/bin/env bash
# Submits a blurlab set render to Slurm: a job array of N shards and a merge job that runs
# once every shard succeeded (--dependency=afterok). Prints the two job ids.
#
#   scripts/slurm/submit.sh [--gpu] [--partition P] [--time T] N [sbatch options...]
#
# --gpu asks each task for one GPU (--gres=gpu:1) and renders with --device gpu. The
# BLURLAB_* settings of render-array.sbatch are read from the environment, e.g.
#   BLURLAB_BIN=$PWD/blurlab BLURLAB_OUT=/scratch/$USER/sets/full BLURLAB_PRESET=full \
#     scripts/slurm/submit.sh --partition cpu --time 12:00:00 32
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
opts=()
gpu=0
while [ $# -gt 0 ]; do
  case "$1" in
    --gpu) gpu=1; shift ;;
    --partition) opts+=("--partition=$2"); shift 2 ;;
    --time) opts+=("--time=$2"); shift 2 ;;
    *) break ;;
  esac
done
n="${1:?usage: submit.sh [--gpu] [--partition P] [--time T] N [sbatch options...]}"
shift
if ! [[ "$n" =~ ^[0-9]+$ ]] || [ "$n" -lt 1 ]; then
  echo "submit.sh: N must be a whole number of at least 1, not '$n'" >&2
  exit 2
fi
: "${BLURLAB_OUT:?set BLURLAB_OUT to the set folder}"
export BLURLAB_SHARDS="$n"
render_opts=("${opts[@]}" "$@" "--array=0-$((n - 1))")
if [ "$gpu" = 1 ]; then
  render_opts+=("--gres=gpu:1")
  export BLURLAB_DEVICE=gpu
fi
array=$(sbatch --parsable --export=ALL "${render_opts[@]}" "$here/render-array.sbatch")
array="${array%%;*}"
merge=$(sbatch --parsable --export=ALL "${opts[@]}" "$@" --dependency="afterok:$array" "$here/merge.sbatch")
merge="${merge%%;*}"
echo "render array: $array ($n tasks); merge: $merge"
