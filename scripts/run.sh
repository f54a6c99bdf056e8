#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, and run the main job
# (a stereo reference render of the default scene) into out/render.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --locked
./target/release/stereocache info
./target/release/stereocache render --scene cornell --size 320x240 --spp 64 --out out/render "$@"
