#!/usr/bin/env bash
# The paper's literal estimator (MBIL estimator="joint": one flow over (s', a'), a separate flow T, the target their
# difference) beside the factored default, on the tuning seeds of benchmarks/runs/tune_classic.sh: LunarLander-v3 N=1 on
# seeds 100-114 (the cell where MBIL is below BC), and Acrobot-v1 / LunarLander-v3 N=1 and 3 on seeds 100-102.
# References on the same seeds: results/tuning/default.csv (mbil default) and results/tuning/bc_wd1e-3.csv (tuned BC).
# Resumable: rerun to finish.
set -euo pipefail
cd "$(dirname "$0")/../.."
JOINT='{"mbil": {"estimator": "joint"}}'
python -m benchmarks.run_grid --algos mbil --envs LunarLander-v3 --n-trajectories 1 --seeds 100-114 --episodes 100 --local \
  --csv results/tuning/mbil_joint.csv --overrides "$JOINT"
python -m benchmarks.run_grid --algos mbil --envs LunarLander-v3 Acrobot-v1 --n-trajectories 1 3 --seeds 100-102 --episodes 100 \
  --local --csv results/tuning/mbil_joint.csv --overrides "$JOINT"
