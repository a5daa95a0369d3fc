#!/usr/bin/env bash
# First measurement of the critic-based baselines (issue 16) on tuning seeds: Hopper-v4, one trajectory, seeds
# 100-102, their zoo settings, 20 000 updates (a first look: the zoo's budgets are 5e4-1e5), evaluated every 5 000 on
# 10 episodes. BC on the same draws: results/tuning/bounded_mean.csv (bc, bc_tanh; gradient_step 20000).
# Resumable: rerun to finish.
set -euo pipefail
cd "$(dirname "$0")/../.."
python -m benchmarks.run_curves --envs Hopper-v4 --seeds 100-102 --updates 20000 --eval-every 5000 --episodes 10 --local \
  --csv results/tuning/baselines_hopper.csv --variants '{"iq_learn": ["iq_learn", {}], "valuedice": ["valuedice", {}], "odice": ["odice", {}]}'
# ValueDICE at Li et al.'s budget (1e5 updates, where they report Hopper 3560 with one trajectory offline): the
# 20 000-update look above cannot tell a slow actor (learning rate 1e-5) from a broken one.
python -m benchmarks.run_curves --envs Hopper-v4 --seeds 100-102 --updates 100000 --eval-every 10000 --episodes 10 --local \
  --csv results/tuning/valuedice_hopper_1e5.csv --variants '{"valuedice": ["valuedice", {}]}'
# ValueDICE's gradient penalty (the reference's weight 10), on interpolates of expert inputs: does it steady nu offline?
python -m benchmarks.run_curves --envs Hopper-v4 --seeds 100-102 --updates 100000 --eval-every 10000 --episodes 10 --local \
  --csv results/tuning/valuedice_hopper_1e5.csv --variants '{"valuedice_gp10": ["valuedice", {"gradient_penalty": 10.0}]}'
# ValueDICE after the regulariser fix (eb3b406), without and with the offline gradient penalty (the default since
# 54ee957), 50 000 updates, tuning seeds 100-101 (results/tuning/baselines_hopper.md, last section).
python -m benchmarks.run_curves --envs Hopper-v4 --seeds 100-101 --updates 50000 --eval-every 5000 --episodes 10 --local \
  --csv results/tuning/valuedice_orth_hopper.csv --variants '{"valuedice": ["valuedice", {"gradient_penalty": 0.0}]}'
python -m benchmarks.run_curves --envs Hopper-v4 --seeds 100-101 --updates 50000 --eval-every 5000 --episodes 10 --local \
  --csv results/tuning/valuedice_gp_hopper.csv --variants '{"valuedice": ["valuedice", {}]}'
