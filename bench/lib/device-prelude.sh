# Sourced by the one-call GPU scripts (bench/gpu-*.sh) from the repository root, with $script
# set to the script's name: makes the Vulkan loader and the NVIDIA driver findable, sets $bin to
# the blurlab binary, $out to the results folder ($OUT, else results/$script) and $work to a
# scratch folder removed on exit, and defines log, now and calc.
#
# The loader: where `ldconfig -p` has no libvulkan and .gl/*.deb exist (downloaded as
# ../shared/ENVIRONMENT.md and the device notes say), they are unpacked first. The binary:
# $BLURLAB_BIN, else ./bin/blurlab (a stripped release build carried to a machine without
# Rust), else `cargo build --release` here.

log() { echo "$script: $*" >&2; }

if ! ldconfig -p 2>/dev/null | grep -q libvulkan.so && compgen -G ".gl/*.deb" >/dev/null; then
  log "unpacking the Vulkan loader from .gl/"
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
fi
nvidia_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -z "${VK_DRIVER_FILES:-}" ] && [ -f "$nvidia_icd" ]; then
  export VK_DRIVER_FILES="$nvidia_icd"
fi

bin="${BLURLAB_BIN:-}"
if [ -z "$bin" ]; then
  if [ -x bin/blurlab ]; then
    bin=bin/blurlab
  else
    log "building the release binary"
    cargo build --release --quiet -p blurlab
    bin=target/release/blurlab
  fi
fi

now() { date +%s.%N; }
calc() { awk "BEGIN { printf \"%.3f\", $1 }"; }

out="${OUT:-results/$script}"
mkdir -p "$out"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
