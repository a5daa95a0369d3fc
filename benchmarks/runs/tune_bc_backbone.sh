#!/usr/bin/env bash
# Issue 19, the BC backbone: the Gaussian negative log-likelihood (the loss of ValueDICE's BC, which Li et al. 2022
# regularised with weight decay 1e-3) against our MSE, with the bounded (tanh) mean and standardised inputs, on the
# MuJoCo tuning seeds 100-102, one trajectory, 5e4 updates, 10 episodes every 5000. MSE references on the same draws
# and protocol: results/tuning/bounded_mean.csv (bc, bc_tanh; Hopper-v4). Why weight decay hurts MSE and not NLL:
# python -m benchmarks.weight_decay_scale (results/tuning/weight_decay_scale.md). Resumable: rerun to finish.
# The table: python -m benchmarks.curve_summary results/tuning/bc_backbone.csv results/tuning/bounded_mean.csv --variants bc \
#   bc_tanh bc_tanh_lin bc_tanh_nll bc_tanh_nll_lin bc_tanh_nll_wd1e-3 bc_tanh_nll_wd1e-3_lin --envs Hopper-v4 \
#   HalfCheetah-v4 --last 3 --paired-against bc --markdown results/tuning/BACKBONE.md --overwrite
# Walker2d-v4 (its regenerated pool; bounded_mean.csv's Walker2d rows drew from the old one): python -m benchmarks.curve_summary \
#   results/tuning/bc_backbone.csv --envs Walker2d-v4 --last 3 --paired-against bc_tanh_lin
set -euo pipefail
cd "$(dirname "$0")/../.."
CSV=results/tuning/bc_backbone.csv
COMMON="--seeds 100-102 --updates 50000 --eval-every 5000 --episodes 10 --csv $CSV --local"
TANH='"policy_kwargs": {"net_arch": [256, 256], "normalize_observations": true, "bounded_mean": true}'
# the learning rate decayed linearly to 0 over the run (rl_zoo3's "lin_1e-3"): is the late-training noise the step size?
LIN='"learning_rate": "lin_1e-3"'
# a variant inherits the zoo's settings for what it leaves out, and the zoo's MuJoCo BC entry decays its rate
# (lin_1e-3) since the bounded-mean decision: a constant-rate variant says so
CONST='"learning_rate": 0.001'
# "bc" here is the zoo's backbone before that decision: a linear mean at a constant rate
LINEAR='"policy_kwargs": {"net_arch": [256, 256], "normalize_observations": true}'
python -m benchmarks.run_curves --envs Hopper-v4 HalfCheetah-v4 $COMMON --variants "{
  \"bc_tanh_lin\": [\"bc\", {$LIN, $TANH}]}"
# two more tuning seeds for the decision between the zoo's BC and the bounded mean with a decaying learning rate
# (Hopper's seeds 100-102 of the zoo's BC are in results/tuning/bounded_mean.csv)
MORE='{"bc": ["bc", {'"$CONST, $LINEAR"'}], "bc_tanh_lin": ["bc", {'"$LIN, $TANH"'}]}'
python -m benchmarks.run_curves --envs Hopper-v4 ${COMMON/100-102/103-104} --variants "$MORE"
python -m benchmarks.run_curves --envs HalfCheetah-v4 ${COMMON/100-102/100-104} --variants "$MORE"
# the same backbone under MBIL and MBIL-C (references on the same draws: results/tuning/mujoco.csv, mbil_norm;
# results/tuning/mbil_c_hopper.csv)
python -m benchmarks.run_curves --envs Hopper-v4 $COMMON --variants "{
  \"mbil_tanh_lin\": [\"mbil\", {$LIN, $TANH}], \"mbil_c_tanh_lin\": [\"mbil_c\", {$LIN, $TANH}]}"
python -m benchmarks.run_curves --envs Hopper-v4 $COMMON --variants "{
  \"bc_tanh_nll\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.0, $CONST, $TANH}],
  \"bc_tanh_nll_wd1e-3\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.001, $CONST, $TANH}]}"
python -m benchmarks.run_curves --envs HalfCheetah-v4 $COMMON --variants "{
  \"bc\": [\"bc\", {$CONST, $LINEAR}], \"bc_tanh\": [\"bc\", {$CONST, $TANH}],
  \"bc_tanh_nll\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.0, $CONST, $TANH}],
  \"bc_tanh_nll_wd1e-3\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.001, $CONST, $TANH}]}"
# HalfCheetah-v4 is still at 0.70 with the zoo's backbone; the NLL with weight decay 1e-3 (Li et al.'s BC) scored 0.88
# on seed 100: five tuning seeds, with the constant and the decaying learning rate
python -m benchmarks.run_curves --envs HalfCheetah-v4 ${COMMON/100-102/100-104} --variants "{
  \"bc_tanh_nll_wd1e-3\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.001, $CONST, $TANH}],
  \"bc_tanh_nll_wd1e-3_lin\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.001, $LIN, $TANH}]}"
# Walker2d-v4 on its regenerated pool: BC at 0.21 of the expert with the zoo's backbone (Figure 4, seeds 0-2); Li et
# al.'s BC (the NLL with weight decay 1e-3) on three tuning seeds, against the zoo's backbone on the same draws
python -m benchmarks.run_curves --envs Walker2d-v4 $COMMON --variants "{
  \"bc_tanh_lin\": [\"bc\", {$LIN, $TANH}],
  \"bc_tanh_nll_wd1e-3\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.001, $CONST, $TANH}],
  \"bc_tanh_nll_wd1e-3_lin\": [\"bc\", {\"bc_loss\": \"nll\", \"weight_decay\": 0.001, $LIN, $TANH}]}"
# Walker2d-v4 stays at 0.2-0.3 with every loss and rate above. Gaussian noise on the expert states with the expert's
# action kept (BC's observation_noise, in units of the states' std): does a smoothness prior keep the clone on its feet?
python -m benchmarks.run_curves --envs Walker2d-v4 $COMMON --variants "{
  \"bc_tanh_lin_obs0.1\": [\"bc\", {\"observation_noise\": 0.1, $LIN, $TANH}],
  \"bc_tanh_lin_obs0.3\": [\"bc\", {\"observation_noise\": 0.3, $LIN, $TANH}]}"
# CCIL on Walker2d-v4 (Ke et al. report BC 1923 -> 3538 there with 10-50 trajectories): BC plus corrective labels from
# a dynamics model T of s' - s (MBIL-C with alpha = 0, model_labels="corrective", residual_transition), the zoo's
# backbone otherwise. Fitted on one trajectory, T barely depends on the action (docs/method.md): this measures what such
# labels do to the return.
python -m benchmarks.run_curves --envs Walker2d-v4 $COMMON --variants "{
  \"ccil_residual\": [\"mbil_c\", {\"alpha\": 0.0, \"alpha_model\": 1.0, \"model_labels\": \"corrective\", \"residual_transition\": true}]}"
# Li et al.'s BC literally (their figure: one complete trajectory, BC at about 0.61 of their Walker2d expert with weight
# decay 1e-3 at 5e5 updates, a peak of 5830 and a collapse without it): ValueDICE's actor, a tanh-squashed Gaussian
# (bc_loss="tanh_nll"), learning rate 1e-5, batch 256, 5e5 updates, against the zoo's 5e4 updates at 1e-3 decayed.
# Tuning seed 100 first (about 25 min a run here); python -m benchmarks.curve_summary results/tuning/bc_li.csv \
#   results/tuning/bc_backbone.csv --envs Walker2d-v4 --last 3 --paired-against bc_tanh_lin
LI='"bc_loss": "tanh_nll", "learning_rate": 1e-05'
python -m benchmarks.run_curves --envs Walker2d-v4 --seeds 100 --updates 500000 --eval-every 25000 --episodes 10 \
  --csv results/tuning/bc_li.csv --local --variants "{
  \"bc_li\": [\"bc\", {$LI, \"weight_decay\": 0.001, $TANH}], \"bc_li_wd0\": [\"bc\", {$LI, \"weight_decay\": 0.0, $TANH}]}"
