#!/bin/bash
# golden.sh BIN OUTDIR: renders every deterministic method (reference, naive,
# supersample, sample-cache, taa, isrt) on the shipped scenes (cornell,
# hairball, plane), 3 frames of captures/synth-head-turn.csv at 40x30, 4 spp,
# software backend, and writes the md5 of every EXR to OUTDIR/hashes.txt.
# Two binaries whose hashes.txt agree render those scenes bit for bit alike:
# the check that a change is exact where it should not apply (see
# docs/PERFORMANCE.md). Run from anywhere; BIN is a stereocache binary.
set -u
if [ $# -ne 2 ]; then
    echo "usage: scripts/golden.sh BIN OUTDIR" >&2
    exit 2
fi
BIN=$(realpath "$1")
OUT=$(realpath -m "$2")
mkdir -p "$OUT"
cd "$(dirname "$0")/.."
status=0
for sc in cornell hairball plane; do
    for m in reference naive supersample sample-cache taa isrt; do
        if ! "$BIN" replay --scene $sc --trace captures/synth-head-turn.csv --method $m \
            --frames 3 --size 40x30 --spp 4 --rt software --out "$OUT/$sc-$m" \
            > "$OUT/$sc-$m.log" 2>&1; then
            echo "error: $sc $m failed (see $OUT/$sc-$m.log)" >&2
            status=1
        fi
    done
done
(cd "$OUT" && find . -name "*.exr" | sort | xargs md5sum) > "$OUT/hashes.txt"
echo "$(wc -l < "$OUT/hashes.txt") EXR hashes in $OUT/hashes.txt"
exit $status
