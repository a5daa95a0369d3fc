#!/usr/bin/env bash
# MuJoCo tuning on seeds 100-102 (never in results/mujoco.csv, which uses seeds 0-4): one trajectory,
# 5e4 updates, 10 episodes every 5000 updates. One CSV, resumable: a rerun skips the finished runs.
#   bash benchmarks/runs/tune_mujoco.sh
#   python -m benchmarks.curve_summary results/tuning/mujoco.csv --last 3 --paired-against bc_norm --markdown results/tuning/MUJOCO.md --overwrite
# Stage 1 (Hopper-v4): the weight of the balance term and a smaller learning rate for MBIL, beside BC.
set -euo pipefail
cd "$(dirname "$0")/../.."
CSV=results/tuning/mujoco.csv
COMMON="--seeds 100-102 --updates 50000 --eval-every 5000 --episodes 10 --csv $CSV ${CURVE_RUNNER:---local}"
# Raw inputs (pinned: the zoo entries standardise them since stage 2).
RAW='"policy_kwargs": {"net_arch": [256, 256]}'
python -m benchmarks.run_curves --envs Hopper-v4 $COMMON --variants "{
  \"bc\": [\"bc\", {\"weight_decay\": 0.0, $RAW}], \"bc_wd1e-3\": [\"bc\", {\"weight_decay\": 0.001, $RAW}],
  \"mbil\": [\"mbil\", {$RAW}], \"mbil_a0.1\": [\"mbil\", {\"alpha\": 0.1, $RAW}], \"mbil_a0.01\": [\"mbil\", {\"alpha\": 0.01, $RAW}],
  \"mbil_a0.001\": [\"mbil\", {\"alpha\": 0.001, $RAW}], \"mbil_lr3e-4\": [\"mbil\", {\"learning_rate\": 0.0003, $RAW}]}"

# Stage 2 (Hopper-v4): the policy's input standardised with the expert states' statistics
# (policy_kwargs normalize_observations), for BC and for MBIL at alpha 1 and 0.01.
NORM='"policy_kwargs": {"net_arch": [256, 256], "normalize_observations": true}'
python -m benchmarks.run_curves --envs Hopper-v4 $COMMON --variants "{
  \"bc_norm\": [\"bc\", {\"weight_decay\": 0.0, $NORM}], \"bc_wd1e-3_norm\": [\"bc\", {\"weight_decay\": 0.001, $NORM}],
  \"mbil_norm\": [\"mbil\", {$NORM}], \"mbil_a0.01_norm\": [\"mbil\", {\"alpha\": 0.01, $NORM}]}"

# Stage 3 (Hopper-v4): BC with decoupled weight decay (AdamW; torch multiplies the decay by the learning
# rate, so weight_decay 1.0 at lr 1e-3 shrinks the weights by 1e-3 a step, as TF-Addons' AdamW(weight_decay=1e-3)
# does, the optimizer of google-research's policy_eval BC), with and without standardised inputs.
python -m benchmarks.run_curves --envs Hopper-v4 $COMMON --variants '{
  "bc_adamw": ["bc", {"weight_decay": 1.0, "policy_kwargs": "dict(net_arch=[256, 256], optimizer_class=th.optim.AdamW)"}],
  "bc_adamw_norm": ["bc", {"weight_decay": 1.0,
                     "policy_kwargs": "dict(net_arch=[256, 256], optimizer_class=th.optim.AdamW, normalize_observations=True)"}]}'

# Stage 4 (Hopper-v4): a pool of the expert's sampled actions (SAC's stochastic policy) instead of its
# deterministic ones, so that log pi_D(a' | s') in the balance target is finite; BC and MBIL at the zoo
# settings. The pool is regenerated from the zoo expert (trained, or reused from SB3_MBIL_CACHE).
SAMPLED=results/tuning/Hopper-v4-sampled.npz
[ -f $SAMPLED ] || python scripts/generate_expert_data.py --env Hopper-v4 --n-trajectories 50 --source zoo --seed 0 \
    --sampled-actions --out $SAMPLED
python -m benchmarks.run_curves --envs Hopper-v4 --pool $SAMPLED $COMMON --variants '{
  "bc_norm_sampled": ["bc", {"weight_decay": 0.0}], "mbil_norm_sampled": ["mbil", {}]}'
