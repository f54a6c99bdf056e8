#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build, and run the main job:
# a side-by-side comparison of rendering methods on a shipped scene along a
# shipped real head-motion recording, with metrics against a reference and an
# HTML report. Extra arguments go to `stereocache compare`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --locked
./target/release/stereocache info
methods="sample-cache,hash-cache,hybrid,taa,naive"
./target/release/stereocache compare --scene hairball --trace captures/mmsys18-user1.csv \
  --methods "$methods" --frames 24 --size 96x72 --rt software --stereo-blend moments \
  --reference-spp 128 --out out/compare "$@"
