#!/usr/bin/env bash
# Issues 17 and 19: Figure 4 with every Box-capable algorithm of sb3_mbil.ALGORITHMS (run_curves.py --figure 4), one
# trajectory, 50 000 updates, 10 episodes every 500 updates, seeds 0-4, the zoo settings of each algorithm. BC first
# (issue 19's goal), then MBIL and MBIL-C, then the critic baselines. Each stage resumes; rows are appended per run.
# Walker2d-v4 and Ant-v4 on their retrained experts' pools (issue 19); FIGURE4_ENVS picks envs, e.g. "Ant-v4".
# results/mujoco.csv keeps the runs of the first backbone (linear mean, constant learning rate), BC with weight decay
# 1e-3 among them; with the compute we have that variant is not rerun here (--only bc_wd1e-3 adds it).
#   bash benchmarks/runs/run_figure4.sh
#   python -m benchmarks.curve_summary results/figure4.csv --paired-against bc
set -euo pipefail
cd "$(dirname "$0")/../.."
ENVS=${FIGURE4_ENVS:-"Hopper-v4 HalfCheetah-v4 Walker2d-v4 Ant-v4"}
RUNNER=${CURVE_RUNNER:---local}
COMMON="--figure 4 --envs $ENVS --seeds 0-4 --updates 50000 --csv results/figure4.csv $RUNNER"
python -m benchmarks.run_curves $COMMON --only bc
python -m benchmarks.run_curves $COMMON --only mbil mbil_c
python -m benchmarks.run_curves $COMMON --only odice iq_learn valuedice
