#!/bin/bash
# Round 81's device call (issues 65 and 67), on a lent GPU after ../shared/device/pack.sh: one call, under 9 minutes.
#   1. a pile of rigid blocks (benchmarks/rigid_pairs_cost.py, scenes_rigid3.heap_setup: 2 x 2 to 10 x 10 columns of
#      3 blocks of 2 x 2 x 5 cm, n_grid 96) on CUDA and on the machine's CPU cores, 6 frames each under Taichi's
#      kernel profiler: the one-thread rigid-pair Gauss-Seidel (`rigid_pairs`) against the whole substep as the pile
#      grows from 12 to 300 bodies;
#   2. the README donut on CUDA against the CPU cores (benchmarks/bench_gpu.py), the regression look since round 59;
#   3. gpu_checks.py's slope and rolling sections on CUDA (round 76's spin booking has not run on a GPU).
# Usage there: bash .device/setup.sh && export PYTHONPATH=/tmp/site && bash benchmarks/gpu_round81.sh $OUT
set -u
OUT=${1:?the output folder}
export PYTHONUNBUFFERED=1
for spec in "cuda 2" "cuda 4" "cuda 6" "cuda 10" "cpu 4" "cpu 10"; do
  set -- $spec
  echo "== pile $1 ${2}x${2}x3"
  timeout 90 python3 benchmarks/rigid_pairs_cost.py --engine taichi_mpm --n-grid 96 --side 0.02 --cols "$2" \
    --layers 3 --frames 6 --profile --device "$1" --tag "pile_$1_$2" --no-write --json "$OUT/pile.jsonl" \
    2>&1 | grep -v "^\[Taichi\]" | head -14
done
echo "== donut"
timeout 150 python3 benchmarks/bench_gpu.py --out "$OUT" --budget 140 --donut-frames 10 \
  --only donut_cuda_auto,donut_cpu_auto 2>&1 | tail -12
echo "== checks"
timeout 150 python3 benchmarks/gpu_checks.py --out "$OUT" --only primitives slope rolling 2>&1 | grep -v "^\[Taichi\]"
rm -f "$OUT"/*.npy
ls -la "$OUT"
