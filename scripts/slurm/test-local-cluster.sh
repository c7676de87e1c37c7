#!/usr/bin/env bash
# A real Slurm run on this machine: starts a single-node cluster (slurmctld, slurmd and
# munge on localhost, no systemd), submits a blurlab render as a job array of N shards plus
# the merge job (scripts/slurm/submit.sh), waits, and checks the merged set against an
# unsharded render of the same selection: the same sequences, every frame byte-identical.
#
#   scripts/slurm/test-local-cluster.sh [N] [render arguments...]
#
# Defaults: N = 4, preset quick, all sequences (BLURLAB_PRESET and the arguments change
# the request, e.g. `4 --views mono`). Needs root (it installs slurm-wlm and munge with
# apt-get when they are missing, and runs munged as the munge user) and a built blurlab
# (BLURLAB_BIN, default target/release/blurlab, else target/debug/blurlab). Prints the
# wall time of the Slurm run and of the unsharded render; exits non-zero on any mismatch.
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
n="${1:-4}"
[ $# -gt 0 ] && shift
render_args=("$@")
export BLURLAB_PRESET="${BLURLAB_PRESET:-quick}"

if [ -z "${BLURLAB_BIN:-}" ]; then
  for b in "$repo/target/release/blurlab" "$repo/target/debug/blurlab"; do
    if [ -x "$b" ]; then BLURLAB_BIN="$b"; break; fi
  done
fi
if [ ! -x "${BLURLAB_BIN:-}" ]; then
  echo "test-local-cluster.sh: no blurlab binary; build it (cargo build --release -p blurlab) or set BLURLAB_BIN" >&2
  exit 2
fi
export BLURLAB_BIN

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  echo "installing slurm-wlm and munge"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null 2>&1 ||
    { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null; }
fi

D="$(mktemp -d /tmp/blurlab-slurm.XXXXXX)"
pids=()
started_munge=0
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  if [ "$started_munge" = 1 ] && [ -f /run/munge/munged.pid ]; then
    kill "$(cat /run/munge/munged.pid)" 2>/dev/null || true
  fi
  if [ "${KEEP:-0}" = 1 ]; then echo "kept $D"; else rm -rf "$D"; fi
}
trap cleanup EXIT

# munge: the cluster's authentication.
if ! { [ -f /run/munge/munged.pid ] && kill -0 "$(cat /run/munge/munged.pid)" 2>/dev/null; }; then
  install -d -o munge -g munge -m 755 /run/munge
  runuser -u munge -- /usr/sbin/munged
  started_munge=1
fi
munge -n | unmunge >/dev/null

host="$(hostname -s)"
mem_mb=$(free -m | awk '/^Mem:/ {print int($2 * 0.8)}')
cpus=$(nproc)
mkdir -p "$D/state" "$D/spool" "$D/log"
cat >"$D/slurm.conf" <<CONF
ClusterName=blurlab-test
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/slurmctld.pid
SlurmdPidFile=$D/slurmd.pid
SlurmctldLogFile=$D/log/slurmctld.log
SlurmdLogFile=$D/log/slurmd.log
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
DependencyParameters=kill_invalid_depend
NodeName=$host CPUs=$cpus Sockets=1 CoresPerSocket=$cpus ThreadsPerCore=1 RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$D/slurm.conf"
setsid slurmctld -D -f "$SLURM_CONF" >"$D/log/slurmctld.out" 2>&1 </dev/null &
pids+=($!)
setsid slurmd -D -f "$SLURM_CONF" >"$D/log/slurmd.out" 2>&1 </dev/null &
pids+=($!)
for _ in $(seq 1 200); do
  [ "$(sinfo -h -N -o %T 2>/dev/null | head -n 1)" = idle ] && break
  sleep 0.1
done
if [ "$(sinfo -h -N -o %T 2>/dev/null | head -n 1)" != idle ]; then
  echo "test-local-cluster.sh: the node did not become idle" >&2
  tail -n 20 "$D"/log/* >&2
  exit 1
fi
echo "cluster up: $(sinfo -h -N -o '%N %T %c CPUs')"

# The array and the merge job, as a cluster user would submit them. Each task gets one
# CPU, so the node runs as many tasks at once as it has CPUs.
export BLURLAB_OUT="$D/set" BLURLAB_DESIGN="$repo/stimuli/navarro2011.toml" BLURLAB_DEVICE=cpu
BLURLAB_ARGS=""
if [ ${#render_args[@]} -gt 0 ]; then BLURLAB_ARGS="$(printf '%q ' "${render_args[@]}")"; fi
export BLURLAB_ARGS
cd "$D"
t0=$(date +%s.%N)
submitted=$("$repo/scripts/slurm/submit.sh" "$n" --cpus-per-task=1 --time=60)
echo "$submitted"
merge_id=$(sed -n 's/.*merge: \([0-9]*\).*/\1/p' <<<"$submitted")
array_id=$(sed -n 's/render array: \([0-9]*\).*/\1/p' <<<"$submitted")
while [ -n "$(squeue -h)" ]; do sleep 0.5; done
t1=$(date +%s.%N)
state=$(scontrol show job "$merge_id" | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p')
for f in "$D"/blurlab-render-"$array_id"_*.out "$D"/blurlab-merge-"$merge_id".out; do
  [ -f "$f" ] || { echo "--- $(basename "$f"): no log"; continue; }
  echo "--- $(basename "$f"): $(grep -c 'rendered\|verified' "$f" || true) progress lines; last:"
  tail -n 1 "$f"
done
if [ "$state" != COMPLETED ]; then
  echo "test-local-cluster.sh: merge job $merge_id ended $state" >&2
  cat "$D"/blurlab-*.out >&2
  exit 1
fi
slurm_seconds=$(echo "$t1 - $t0" | bc)

# The same selection unsharded, in one process.
t0=$(date +%s.%N)
"$BLURLAB_BIN" stimuli render --design "$BLURLAB_DESIGN" --preset "$BLURLAB_PRESET" --device cpu \
  --out "$D/whole" --progress quiet "${render_args[@]}"
t1=$(date +%s.%N)
whole_seconds=$(echo "$t1 - $t0" | bc)

for s in "$D/whole" "$D/set"; do
  if [ ! -f "$s/index.json" ]; then
    echo "test-local-cluster.sh: $s/index.json is missing" >&2
    exit 1
  fi
done
ids() { grep -o '"id": "[^"]*"' "$1/index.json" | sort; }
if ! diff <(ids "$D/whole") <(ids "$D/set") >/dev/null; then
  echo "test-local-cluster.sh: the merged set lists other sequences than the unsharded one" >&2
  diff <(ids "$D/whole") <(ids "$D/set") | head >&2
  exit 1
fi
sequences=$(ids "$D/whole" | wc -l)
frames=0
while IFS= read -r f; do
  rel="${f#"$D/whole/"}"
  if ! cmp -s "$f" "$D/set/$rel"; then
    echo "test-local-cluster.sh: $rel differs between the unsharded and the merged set" >&2
    exit 1
  fi
  frames=$((frames + 1))
done < <(find "$D/whole" -name 'frame-*' -type f)
echo "OK: $n shards on Slurm, merged: $sequences sequences, $frames frames byte-identical to the unsharded render"
printf 'slurm array + merge: %.1f s wall; unsharded render: %.1f s wall (%s CPUs)\n' "$slurm_seconds" "$whole_seconds" "$cpus"
