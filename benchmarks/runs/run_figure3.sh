#!/usr/bin/env bash
# Issue 17: Figure 3 with every Discrete-capable algorithm of sb3_mbil.ALGORITHMS, in the order the compute allows
# (about 2 000 runs; each stage resumes, rows are appended as they finish). Ray by default (one torch thread per
# task, as many tasks as cores); CURVE_RUNNER=--local runs without Ray. BC, MBIL and MBIL-C run their zoo entries'
# ELU hidden layers; the earlier ReLU rows are in results/classic_control*_relu.csv. BENCHMARKS.md: python -m benchmarks.make_benchmarks --overwrite
#   bash benchmarks/runs/run_figure3.sh published   # 5 seeds, each algorithm's published subsampling
#   bash benchmarks/runs/run_figure3.sh second      # the second experts, N = 1 and 3, 10 seeds
#   bash benchmarks/runs/run_figure3.sh full        # the first experts, full trajectories, 10 seeds
set -euo pipefail
cd "$(dirname "$0")/../.."
RUNNER=${CURVE_RUNNER:-}
ENVS="CartPole-v1 Acrobot-v1 LunarLander-v3"
# The grid is seed-major (every algorithm at a seed before the next seed), so DSFN runs in a pass of its own: its
# CartPole-v1 and Acrobot-v1 entries (the reference warm start, ten times shorter iterations: 135 000 steps;
# benchmarks/runs/tune_dsfn.sh) take about 2.5 min a run here, its reference schedule (LunarLander-v3) 15-20 min, against
# 0.5-3 min for the others. ValueDICE runs
# with the others since its classic-control entries moved to the published comparison's 1e4 updates (about 75 s).
#   bash benchmarks/runs/run_figure3.sh published dsfn   # DSFN alone (likewise valuedice)
ALGOS=${FIGURE3_ALGOS:-"bc mbil mbil_c edm rcal avril iq_learn valuedice"}
case "${2:-}" in dsfn|valuedice) ALGOS="$2" ;; "") ;; *) echo "second argument: dsfn or valuedice" >&2; exit 2 ;; esac
case "${1:-}" in
  published)
    python -m benchmarks.run_grid --algos $ALGOS --envs $ENVS --n-trajectories 1 3 7 10 15 --seeds 0-4 --episodes 300 \
      --protocol published --csv results/classic_control_published.csv $RUNNER ;;
  second)
    python -m benchmarks.run_grid --algos $ALGOS --envs $ENVS --n-trajectories 1 3 --seeds 0-9 --episodes 300 \
      --second-expert --csv results/classic_control_second.csv $RUNNER ;;
  full)
    # seeds 0-4 of AVRIL, ValueDICE and DSFN are the published grid's runs (the same data): reused, not rerun
    python -m benchmarks.run_grid --algos $ALGOS --envs $ENVS --n-trajectories 1 3 7 10 15 --seeds 0-9 --episodes 300 \
      --csv results/classic_control.csv --reuse results/classic_control_published.csv $RUNNER ;;
  *) echo "usage: bash benchmarks/runs/run_figure3.sh published|second|full" >&2; exit 2 ;;
esac
