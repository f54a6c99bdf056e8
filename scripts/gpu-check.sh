#!/usr/bin/env bash
# One prepared check for a machine with an NVIDIA GPU that has no Rust
# toolchain and no network. Writes every figure into one folder in about
# 9 minutes (each step has its own limit; figures.md is written before
# the last one and after it): `info`, a render of every method on the GPU paths (the CLI
# equivalent of the GPU-path tests: every method on both ray backends the
# device offers, exit status checked), `bench rays`, `bench sample-cache`
# at 2x960x1080 on Sponza, `bench materials` (issue 17: the memoization
# cache's variants, a table-size sweep and the eviction policies — Table
# 6.2's small-table question — on the procedural Cornell box at the same
# size, along the real head trace), and the Fig. 12/13 experiment at paper
# scale for 60 frames.
#
# Prepare here (a machine with the toolchain and network), from the repo root:
#   scripts/gpu-check.sh --prepare
# builds the release binary, strips it into .gpu/stereocache, downloads the
# Vulkan loader packages (amd64 .debs) into .gpu/debs, glslc and its
# library (material graphs compile to SPIR-V at scene load) into
# .gpu/tools, and copies Sponza (../shared/scenes/sponza, 19 MB) into
# .gpu/sponza; .gpu/ is git-ignored (.git/info/exclude), about 45 MB: carry
# it (device tool: carry [".gpu"]).
#
# Run there, from the repo root (root: unpacks the loader into /):
#   scripts/gpu-check.sh [--out DIR] [--tiny]
# DIR defaults to $OUT/gpu-check when $OUT is set, else out/gpu-check.
# --tiny: the same steps at toy sizes (64x48, a few frames, CI scale, the
# Cornell box for Sponza) — to check the script itself on lavapipe; the
# figures mean nothing then. SPONZA=DIR: Sponza elsewhere than .gpu/sponza.
# Each step has its own time limit; a step that fails or runs out is
# recorded in DIR/steps.txt and the next one runs.
set -uo pipefail
cd "$(dirname "$0")/.."

prepare() {
  set -e
  cargo build --release --locked
  mkdir -p .gpu/debs
  grep -qx '/.gpu/' .git/info/exclude 2>/dev/null || echo '/.gpu/' >>"$(git rev-parse --git-path info/exclude)"
  strip -o .gpu/stereocache target/release/stereocache
  local o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
  mkdir -p /tmp/amd64/partial
  # shellcheck disable=SC2086
  apt-get $o update >/dev/null
  # shellcheck disable=SC2086
  (cd .gpu/debs && apt-get $o download libvulkan1)
  mkdir -p .gpu/tools
  # shellcheck disable=SC2086
  (cd .gpu/tools && apt-get $o download glslc libshaderc1)
  rm -rf .gpu/sponza && cp -r ../shared/scenes/sponza .gpu/sponza
  du -sh .gpu
  echo "prepared .gpu/: carry it and run scripts/gpu-check.sh there"
}

out=""
tiny=0
while [ $# -gt 0 ]; do
  case "$1" in
    --prepare) prepare; exit $? ;;
    --out) out=$2; shift 2 ;;
    --tiny) tiny=1; shift ;;
    *) echo "error: gpu-check.sh: unknown argument '$1' (--prepare, --out DIR, --tiny)" >&2; exit 2 ;;
  esac
done
out=${out:-${OUT:+$OUT/gpu-check}}
out=${out:-out/gpu-check}
mkdir -p "$out"
bin=${STEREOCACHE:-.gpu/stereocache}
[ -x "$bin" ] || bin=target/release/stereocache
[ -x "$bin" ] || { echo "error: no binary: run scripts/gpu-check.sh --prepare first" >&2; exit 1; }
sponza=${SPONZA:-.gpu/sponza}
[ -d "$sponza" ] || sponza=../shared/scenes/sponza

# The Vulkan loader: carried packages when the system has none.
if ! ldconfig -p 2>/dev/null | grep -q libvulkan.so.1; then
  for f in .gpu/debs/*.deb; do [ -f "$f" ] && dpkg -x "$f" /; done
  ldconfig 2>/dev/null || true
fi
# glslc for the material graphs, unpacked beside the tree (not into /).
if ! command -v "${GLSLC:-glslc}" >/dev/null 2>&1 && ls .gpu/tools/*.deb >/dev/null 2>&1; then
  for f in .gpu/tools/*.deb; do dpkg -x "$f" .gpu/root; done
  export GLSLC=$PWD/.gpu/root/usr/bin/glslc
  export LD_LIBRARY_PATH=$PWD/.gpu/root/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  [ -x "$GLSLC" ] || echo "warning: gpu-check.sh: no glslc in .gpu/tools: scenes with material graphs will not load" >&2
fi
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$icd" ] && [ -z "${VK_DRIVER_FILES:-}" ] && export VK_DRIVER_FILES=$icd

if [ $tiny = 1 ]; then
  # Plumbing only: the Cornell box instead of Sponza (its BVH build alone
  # takes minutes on two CPU cores).
  size=64x48; bench_size=64x48; frames=4; scale=ci; exp_frames=4; rays_size=64x64; sponza=cornell
  # The plain fill: llvmpipe compiles the cooperative builds slowly.
  memo_sizes=256,4096; memo_frames=3; memo_fill=plain
else
  size=256x144; bench_size=960x1080; frames=30; scale=paper; exp_frames=60; rays_size=1024x1024
  # 4x4 tiles; the sizes are set from the frame's working set below (these
  # stand if that measurement fails).
  memo_sizes=131072,524288,2097152; memo_frames=12; memo_fill=subgroup
fi

start=$(date +%s)
: >"$out/steps.txt"
# step NAME LIMIT_SECONDS COMMAND...: stdout+stderr into DIR/NAME.txt.
step() {
  local name=$1 limit=$2
  shift 2
  local t0 rc
  t0=$(date +%s)
  timeout "$limit" "$@" >"$out/$name.txt" 2>&1
  rc=$?
  printf '%-28s rc=%-3s %4ss  %s\n' "$name" "$rc" "$(($(date +%s) - t0))" "$*" | tee -a "$out/steps.txt"
}

step info 60 "$bin" info
# Every method on every backend the device has (auto: ray queries where
# present; software: the CWBVH compute path), one stereo frame each.
for rt in auto software; do
  for m in reference sample-cache naive supersample taa isrt hash-cache hybrid debug-normals; do
    step "render-$rt-$m" 60 "$bin" render --scene cornell --method "$m" --rt "$rt" \
      --size "$size" --spp 4 --out "$out/render/$rt-$m"
  done
done
step bench-rays 90 "$bin" bench rays --size "$rays_size"
step bench-sample-cache 120 "$bin" bench sample-cache --scene "$sponza" \
  --size "$bench_size" --frames "$frames" --rt auto
# Fig. 12/13 at paper scale, 60 frames, Sponza from the bundle; its claims are printed at the end.
step fig12-13 300 "$bin" experiment run experiments/fig12-13-sponza.toml \
  --scale "$scale" --set frames="$exp_frames" --set "scenes=[\"$sponza\"]" \
  --set "reference-cache=\"$out/reference-cache\"" --out "$out/fig12-13"
rm -rf "$out/reference-cache" "$out/render"/*/*.exr
# The figures in one place: what the docs quote. Written before the last
# step and again after it, so a run cut short still leaves the summary.
summary() {
  {
    echo "# gpu-check $(date -u +%FT%TZ), $(($(date +%s) - start)) s"
    grep -m1 -i "device" "$out/info.txt"
    cat "$out/steps.txt"
    echo; echo "## bench rays"; cat "$out/bench-rays.txt"
    echo; echo "## bench sample-cache ($bench_size per eye, Sponza)"; cat "$out/bench-sample-cache.txt"
    echo; echo "## Fig. 12/13"; cat "$out/fig12-13/claims.md" 2>/dev/null
    grep -A12 "^method" "$out/fig12-13.txt" 2>/dev/null
    if [ -f "$out/bench-materials.txt" ]; then
      echo; echo "## bench materials ($bench_size per eye, procedural Cornell box)"
      cat "$out/memo-sizes.txt" 2>/dev/null
      cat "$out/bench-materials.txt"
    fi
  } >"$out/figures.md"
}
summary
# The memo table's sizes from frame 0's working set: the tiles one frame
# of the bench's setting stores (fills + evictions) into a table of
# 1,048,576 4x4 tiles (780 B each, 0.8 GB). The smallest size is 1.19 of
# it, the thesis's small tiled table against the tiles its Classroom frame
# touched (Table 6.2: where its frame clock collapsed), then 4x and 16x,
# none above 2,097,152 tiles (1.6 GB: a storage buffer's range).
if [ $tiny = 0 ]; then
  step memo-working-set 120 "$bin" replay --scene procedural-uv:cornell --rt software \
    --size "$bench_size" --spp 1 --bounces 2 --frames 1 --memo both --memo-tile 4 \
    --memo-entries 1048576 --trace captures/mmsys18-user1.csv --out "$out/memo-working-set"
  counter() { grep -o "\"$1\":[0-9]*" "$out/memo-working-set/frames.jsonl" 2>/dev/null | head -1 | cut -d: -f2; }
  fills=$(counter memo_fills)
  evictions=$(counter memo_evictions)
  if [ -n "$fills" ] && [ "$fills" -gt 0 ]; then
    fills=$((fills + ${evictions:-0}))
    small=$((fills * 119 / 100))
    memo_sizes=$small
    for k in 4 16; do
      [ $((small * k)) -le 2097152 ] && memo_sizes="$memo_sizes,$((small * k))"
    done
  fi
  rm -rf "$out/memo-working-set/frames"
  echo "memo sizes: $memo_sizes (frame 0 filled ${fills:-?} tiles)" | tee "$out/memo-sizes.txt"
fi
# Memoization (issue 17): every variant, the sweep and the eviction rows
# (no eviction, random, LRW/LRU by frame and by the 64-bit counter) at the
# smallest size, 4x4 tiles (the cooperative fill on the GPU), both eyes,
# along the real head trace.
step bench-materials 180 "$bin" bench materials --scene procedural-uv:cornell --rt software \
  --size "$bench_size" --frames "$memo_frames" --repeats 1 --sweep-tile 4 \
  --sweep-fill "$memo_fill" --sizes "$memo_sizes" \
  --trace captures/mmsys18-user1.csv --out "$out/bench-materials.csv"
summary
echo "wrote $out (figures.md, steps.txt, one log per step)"
! grep -qv 'rc=0 ' "$out/steps.txt"
