#!/usr/bin/env bash
# Tuning on seeds 100-102 (never reported in the grid, which uses seeds 0-9): LunarLander-v3 and
# Acrobot-v1 (CartPole-v1 saturates at N=1 with full trajectories), N = 1 and 3, 100 episodes.
# One CSV per setting in results/tuning/. Resumable: rerun to finish.
set -euo pipefail
cd "$(dirname "$0")/../.."
COMMON="--envs LunarLander-v3 Acrobot-v1 --n-trajectories 1 3 --seeds 100-102 --episodes 100 --num-cpus ${NUM_CPUS:-2}"
LL="--envs LunarLander-v3 --n-trajectories 1 --seeds 103-114 --episodes 100 --num-cpus ${NUM_CPUS:-2}"
ONLY=${1:-all}
case "$ONLY" in all|5) ;; *) echo "usage: bash benchmarks/runs/tune_classic.sh [5]" >&2; exit 2 ;; esac
if [ "$ONLY" = all ]; then
python -m benchmarks.run_grid --algos bc mbil $COMMON --csv results/tuning/default.csv --overrides '{"bc": {"weight_decay": 0.0}}'
python -m benchmarks.run_grid --algos mbil $COMMON --csv results/tuning/mbil_alpha0.1.csv --overrides '{"mbil": {"alpha": 0.1}}'
python -m benchmarks.run_grid --algos mbil $COMMON --csv results/tuning/mbil_alpha10.csv --overrides '{"mbil": {"alpha": 10.0}}'
python -m benchmarks.run_grid --algos bc $COMMON --csv results/tuning/bc_wd1e-3.csv --overrides '{"bc": {"weight_decay": 0.001}}'
python -m benchmarks.run_grid --algos mbil $COMMON --csv results/tuning/mbil_wd1e-3.csv --overrides '{"mbil": {"weight_decay": 0.001}}'

# Stage 2: LunarLander-v3 N=1, the one cell where the grid has MBIL below BC, with 12 more seeds
# (103-114; 15 with the three above) for the settings that differ there.
python -m benchmarks.run_grid --algos bc mbil $LL --csv results/tuning/default.csv --overrides '{"bc": {"weight_decay": 0.0}}'
python -m benchmarks.run_grid --algos bc $LL --csv results/tuning/bc_wd1e-3.csv --overrides '{"bc": {"weight_decay": 0.001}}'
python -m benchmarks.run_grid --algos mbil $LL --csv results/tuning/mbil_wd1e-3.csv --overrides '{"mbil": {"weight_decay": 0.001}}'

# Stage 3: d3rlpy's DiscreteBC regulariser (logit_penalty, lambda * mean of the squared logits; its default 0.5): a difference
# between d3rlpy's BC and ours, on the cell of BENCHMARKS.md's peers table where d3rlpy's is above (LunarLander-v3, one trajectory).
python -m benchmarks.run_grid --algos bc ${LL/103-114/100-114} --csv results/tuning/bc_logit0.5.csv --overrides '{"bc": {"logit_penalty": 0.5}}'
python -m benchmarks.run_grid --algos bc ${LL/103-114/100-114} --csv results/tuning/bc_logit0.5_wd0.csv --overrides '{"bc": {"logit_penalty": 0.5, "weight_decay": 0.0}}'
python -m benchmarks.run_grid --algos mbil_c ${LL/103-114/100-114} --csv results/tuning/mbil_c_logit0.5.csv --overrides '{"mbil_c": {"logit_penalty": 0.5, "weight_decay": 0.001}}'
python -m benchmarks.run_grid --algos bc $COMMON --csv results/tuning/bc_logit0.5.csv --overrides '{"bc": {"logit_penalty": 0.5}}'

# Stage 4: ELU hidden layers, the 2x64 ELU policies of the published comparison (CKIL's appendix), for BC, MBIL and MBIL-C;
# and BC on the published protocol (every 20th step) with ReLU, the logit penalty and ELU.
ELU='"policy_kwargs": "dict(activation_fn=nn.ELU)"'
python -m benchmarks.run_grid --algos bc ${LL/103-114/100-114} --csv results/tuning/bc_elu.csv --overrides "{\"bc\": {$ELU}}"
python -m benchmarks.run_grid --algos bc $COMMON --csv results/tuning/bc_elu.csv --overrides "{\"bc\": {$ELU}}"
python -m benchmarks.run_grid --algos mbil_c ${LL/103-114/100-114} --csv results/tuning/mbil_c_elu.csv --overrides "{\"mbil_c\": {$ELU}}"
python -m benchmarks.run_grid --algos mbil ${LL/103-114/100-114} --csv results/tuning/mbil_elu.csv --overrides "{\"mbil\": {$ELU}}"
PUB="--envs LunarLander-v3 --n-trajectories 1 --seeds 100-104 --episodes 100 --protocol published --num-cpus ${NUM_CPUS:-2}"
python -m benchmarks.run_grid --algos bc $PUB --csv results/tuning/published_bc.csv
python -m benchmarks.run_grid --algos bc $PUB --csv results/tuning/published_bc_logit0.5.csv --overrides '{"bc": {"logit_penalty": 0.5}}'
python -m benchmarks.run_grid --algos bc $PUB --csv results/tuning/published_bc_elu.csv --overrides "{\"bc\": {$ELU}}"
fi

# Stage 5 (issue 18): is MBIL-C's lead over BC on the second experts (reported seeds, ELU: CartPole-v1 N = 1 +73.2,
# LunarLander-v3 N = 3 +95.1) the balance term, or a soft label that any smoothing gives? BC with label smoothing
# (the target (1 - eps) onehot(a) + eps / K) beside the zoo's BC and MBIL-C, on tuning seeds, in those two cells and
# in LunarLander-v3 N = 1 on the first expert (paired with stage 4's ELU rows, the zoo's settings there). And BC with
# ReLU on the DQN lander with three trajectories, where the reported BC with ELU is 130 below its ReLU rows.
#   bash benchmarks/runs/tune_classic.sh 5    # this stage alone
SECOND_CP="--second-expert --envs CartPole-v1 --n-trajectories 1 --seeds 100-109 --episodes 100 --num-cpus ${NUM_CPUS:-2}"
SECOND_LL="--second-expert --envs LunarLander-v3 --n-trajectories 3 --seeds 100-109 --episodes 100 --num-cpus ${NUM_CPUS:-2}"
stage5() {
  for cell in "$SECOND_CP" "$SECOND_LL"; do
    python -m benchmarks.run_grid --algos bc mbil_c $cell --csv results/tuning/second_zoo.csv
    python -m benchmarks.run_grid --algos bc $cell --csv results/tuning/second_bc_ls0.1.csv --overrides '{"bc": {"label_smoothing": 0.1}}'
    python -m benchmarks.run_grid --algos bc $cell --csv results/tuning/second_bc_ls0.3.csv --overrides '{"bc": {"label_smoothing": 0.3}}'
  done
  python -m benchmarks.run_grid --algos bc $SECOND_LL --csv results/tuning/second_bc_relu.csv --overrides '{"bc": {"policy_kwargs": "dict(activation_fn=nn.ReLU)"}}'
  python -m benchmarks.run_grid --algos bc ${LL/103-114/100-114} --csv results/tuning/bc_ls0.1.csv --overrides '{"bc": {"label_smoothing": 0.1}}'
  python -m benchmarks.run_grid --algos bc ${LL/103-114/100-114} --csv results/tuning/bc_ls0.3.csv --overrides '{"bc": {"label_smoothing": 0.3}}'
}
stage5
