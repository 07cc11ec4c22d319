#!/usr/bin/env bash
# Regenerates shaders/vrrt.spv from shaders-rust + core with rust-gpu (pinned nightly).
#   shaders-builder/build.sh           rebuild and overwrite shaders/vrrt.spv
#   shaders-builder/build.sh --check   rebuild and fail if shaders/vrrt.spv is stale (CI)
#   shaders-builder/build.sh --crate DIR --out FILE
#                                      build another shader crate (e.g. one depending on vrrt-core)
#                                      to FILE with the same toolchain and cache
# The codegen backend (~10 min cold on 2 cores) and the shader build are cached outside the clone,
# in $VRRT_SHADER_CACHE (default ~/.cache/vrrt-shaders), so later runs take seconds.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export VRRT_SHADER_CACHE=${VRRT_SHADER_CACHE:-$HOME/.cache/vrrt-shaders}
export CARGO_TARGET_DIR=$VRRT_SHADER_CACHE/builder
export VRRT_ROOT=$(cd "$here/.." && pwd)
# Paths are taken relative to the caller's directory, before the cd below.
args=()
spv=$VRRT_ROOT/shaders/vrrt.spv
while [ $# -gt 0 ]; do
  case $1 in
    --crate|--out)
      [ $# -ge 2 ] || { echo "$1 needs a path" >&2; exit 2; }
      path=$(realpath -m "$2")
      [ "$1" = --out ] && spv=$path
      args+=("$1" "$path")
      shift 2 ;;
    *) args+=("$1"); shift ;;
  esac
done
cd "$here"
cargo +nightly-2026-08-15 run --release --quiet -- "${args[@]}"
spirv-val --target-env vulkan1.2 "$spv"
