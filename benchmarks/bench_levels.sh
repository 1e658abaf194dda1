#!/bin/sh
# The quality levels on the README scenes, end to end, against each scene's converged reference
# (issue 18; docs/speed_accuracy.md, "Quality levels"). One command on a quiet machine:
#     sh benchmarks/bench_levels.sh            # about 1 h on 2 quiet cores (one engine thread per run)
#     sh benchmarks/bench_levels.sh 96         # the reference from n_grid 48, 64, 96 instead of 32, 48, 64
# Writes benchmarks/results/bench_trade_{donut,guitar,kitchen}_verdict*.{json,md,png}; the run folders
# stay in out/levels/<scene>/<variant> (delete them after).
set -e
cd "$(dirname "$0")/.."
SET=verdict${1:-}
for scene in donut guitar kitchen; do
    python benchmarks/bench_trade.py --scene "$scene" --variants "$SET" --threads 1 --window 12 \
        --keep "out/levels/$scene" --tag "$SET"
done
