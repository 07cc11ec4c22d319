#!/usr/bin/env bash
# Regenerates shaders/vrrt.spv from shaders-rust + core with rust-gpu (pinned nightly).
#   shaders-builder/build.sh           rebuild and overwrite shaders/vrrt.spv
#   shaders-builder/build.sh --check   rebuild and fail if shaders/vrrt.spv is stale (CI)
# The codegen backend (~10 min cold on 2 cores) and the shader build are cached outside the clone,
# in $VRRT_SHADER_CACHE (default ~/.cache/vrrt-shaders), so later runs take seconds.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export VRRT_SHADER_CACHE=${VRRT_SHADER_CACHE:-$HOME/.cache/vrrt-shaders}
export CARGO_TARGET_DIR=$VRRT_SHADER_CACHE/builder
export VRRT_ROOT=$(cd "$here/.." && pwd)
cd "$here"
cargo +nightly-2026-08-15 run --release --quiet -- "$@"
spirv-val --target-env vulkan1.2 ../shaders/vrrt.spv
