#!/usr/bin/env bash
# Runs one experiment file as a Slurm job array, one shard per array task,
# then merges the shards into one report in a dependent job.
#
#   scripts/slurm-experiment.sh experiments/fig12-13-sponza.toml 8 [paper] [OUT]
#
# submits `sbatch --array=1-8` of this same script in "shard" mode (each task
# runs `stereocache experiment run FILE --scale SCALE --shard K/8 --out
# OUT/shard-K`, K = $SLURM_ARRAY_TASK_ID) and an `afterok` job that runs
# `stereocache experiment merge OUT/shard-* --out OUT/merged`. The runs
# (scene x trace x configuration) are dealt round robin, so the shards are
# disjoint and together the whole experiment; each shard renders the
# references of its comparisons (cached under OUT/reference-cache, shared
# by the tasks on one file system: the same frames give the same file).
#
# Run from the repository root (experiment files name paths relative to it)
# on a cluster whose nodes have a Vulkan driver. Environment:
#   STEREOCACHE   the binary (default target/release/stereocache)
#   SBATCH_ARGS   extra sbatch options, e.g. "--partition=gpu --gres=gpu:1 --time=02:00:00"
set -euo pipefail

mode=submit
if [ "${1:-}" = "--shard-task" ] || [ "${1:-}" = "--merge-task" ]; then
  mode=${1#--}
  shift
fi
file=${1:?usage: scripts/slurm-experiment.sh FILE SHARDS [SCALE] [OUT]}
shards=${2:?usage: scripts/slurm-experiment.sh FILE SHARDS [SCALE] [OUT]}
scale=${3:-paper}
name=$(basename "$file" .toml)
out=${4:-out/slurm/$name-$scale}
bin=${STEREOCACHE:-target/release/stereocache}

case "$mode" in
  submit)
    [ -x "$bin" ] || { echo "error: $bin: not built (cargo build --release)" >&2; exit 1; }
    # Check the file once before anything is queued: a bad file fails here.
    "$bin" experiment run "$file" --scale "$scale" --check >/dev/null
    mkdir -p "$out/logs"
    # shellcheck disable=SC2086
    array=$(sbatch --parsable ${SBATCH_ARGS:-} --job-name "sc-$name" \
      --array "1-$shards" --output "$out/logs/shard-%a.log" \
      "$0" --shard-task "$file" "$shards" "$scale" "$out")
    # shellcheck disable=SC2086
    merge=$(sbatch --parsable ${SBATCH_ARGS:-} --job-name "sc-$name-merge" \
      --dependency "afterok:$array" --output "$out/logs/merge.log" \
      "$0" --merge-task "$file" "$shards" "$scale" "$out")
    echo "submitted shards $array (1-$shards) and merge $merge; report: $out/merged/*/report.html"
    ;;
  shard-task)
    k=${SLURM_ARRAY_TASK_ID:?not in a Slurm array task}
    "$bin" experiment run "$file" --scale "$scale" --shard "$k/$shards" \
      --set "reference-cache=\"$out/reference-cache\"" --out "$out/shard-$k"
    ;;
  merge-task)
    dirs=()
    for k in $(seq 1 "$shards"); do dirs+=("$out/shard-$k"); done
    "$bin" experiment merge "${dirs[@]}" --out "$out/merged"
    ;;
esac
