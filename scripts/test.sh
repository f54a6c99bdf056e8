#!/usr/bin/env bash
# Quick start, command 2: install what is missing, then run the whole test
# suite on the Vulkan device (lavapipe on machines without a GPU). Every GPU
# test enables the Khronos validation layer and fails on any message.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --test
export STEREOCACHE_VALIDATE=1
cargo test --locked --no-fail-fast "$@"
