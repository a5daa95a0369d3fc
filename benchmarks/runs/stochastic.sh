#!/usr/bin/env bash
# Stochastic demonstrators on one env (rows in results/stochastic/{tuning_,crossover_,}ENV.csv; rerun to resume:
# finished rows are skipped). Each cell's seeds train in lockstep (--lockstep: the same rows, faster), at most 10
# models together (an ensemble's cell appends its rows every two seeds).
#   bash benchmarks/runs/stochastic.sh ENV tuning|grid|baselines|curves|crossover|crossover-tuning [N ...]
#   bash benchmarks/runs/stochastic.sh ENV probes [VARIANT...]
#   bash benchmarks/runs/stochastic.sh ENV crossover-extra LEVEL VARIANT...
# N defaults to 1 3 (tuning, grid, baselines; LunarLander-v3's crossover) or 1 (the MuJoCo crossover).
# On the MuJoCo envs Figure 4 is the grid's one-trajectory runs: grid and baselines record their learning curve at
# N = 1 (the same runs, seeds 0-9, 300 episodes), and `curves` runs both at N = 1.
set -euo pipefail
cd "$(dirname "$0")/../.."
env=${1:?ENV}
stage=${2:?tuning, grid, baselines, curves, probes, crossover, crossover-extra or crossover-tuning}
shift 2
case "$env" in
  Hopper-v4|Walker2d-v4|HalfCheetah-v4|Ant-v4) levels="0 0.1 0.2 0.4"; crossover_n=1; mujoco=1;;
  *) levels="0 0.05 0.1 0.2"; crossover_n="1 3"; mujoco=0;;
esac
curve="--curve-every 500 --curve-episodes 10"
lockstep="--lockstep --lockstep-models 10"
# the grid's runs of one N, with their learning curve where they are Figure 4's (MuJoCo, N = 1)
grid_n() {
  local n=$1; shift
  local flags=""
  [ "$mujoco" = 1 ] && [ "$n" = 1 ] && flags=$curve
  python -m benchmarks.stochastic --env $env --pools $env-sampled "$@" --n-trajectories $n --seeds 0-9 \
    --episodes 300 --csv results/stochastic/$env.csv $lockstep $flags
}
tuned="--tuned-from results/stochastic/tuning_$env.csv"
noise_pools=""
for level in $levels; do noise_pools="$noise_pools benchmarks/pools/$env-noise$level.npz"; done
bc_variants=$(python -c "from benchmarks.stochastic import variants_for; print(' '.join(k for k, v in variants_for('$env').items() if v.algo == 'bc'))")
case "$stage" in
  # 1. every variant of BC, MBIL and MBIL-C on the sampled pool, tuning seeds 100-102 (the one budget)
  tuning) python -m benchmarks.stochastic --env $env --pools $env-sampled --variants all --n-trajectories ${@:-1 3} \
            --seeds 100-102 --episodes 100 --csv results/stochastic/tuning_$env.csv $lockstep;;
  # 2. the paper's Figure 3 on the sampled pool, seeds 0-9, 300 episodes: BC, MBIL, MBIL-C and their tuned variants
  grid) for n in ${@:-1 3}; do grid_n $n --variants bc mbil mbil_c $tuned; done;;
  # 2b. the same grid for every other algorithm that supports the action space, at its zoo entry (seed by seed
  #     where it cannot train in lockstep)
  baselines) for n in ${@:-1 3}; do grid_n $n --variants baselines; done;;
  # 2b'. a probe outside the tuning grid (benchmarks.stochastic.PROBES; default: all of them) on the grid's draws
  #      and seeds at N = 1 (on MuJoCo with its curve, Figure 4): paired against the family, never BC*
  probes) grid_n 1 --variants ${@:-bc_nll_5k};;
  # 2c. Figure 4 on the sampled pool: one trajectory, every 500 updates on 10 episodes, BC, MBIL, MBIL-C, their tuned
  #     variants and the baselines. MuJoCo: the grid's and the baselines' runs at N = 1. Elsewhere its own runs,
  #     seeds 0-4, the final policy on 100 episodes
  curves) if [ "$mujoco" = 1 ]; then
            grid_n 1 --variants bc mbil mbil_c $tuned
            grid_n 1 --variants baselines
          else
            python -m benchmarks.stochastic --env $env --pools $env-sampled --variants bc mbil mbil_c baselines \
              $tuned --n-trajectories ${@:-1} --seeds 0-4 --episodes 100 $curve \
              --csv results/stochastic/curves_$env.csv $lockstep
          fi;;
  # 3. the noise crossover, seeds 0-4, 100 episodes: BC, MBIL, MBIL-C at their defaults, and BC* as chosen on the
  #    sampled pool's tuning for the same N (--tuning-pool; BC's own tuning on each noise pool: crossover-tuning)
  crossover) python -m benchmarks.stochastic --env $env --pools $noise_pools --variants bc mbil mbil_c \
               $tuned --tuning-pool $env-sampled --tuned-algos bc \
               --n-trajectories ${@:-$crossover_n} --seeds 0-4 --episodes 100 \
               --csv results/stochastic/crossover_$env.csv $lockstep;;
  # 3b. a setting pushed after item 5's ablation (docs/stochastic.md), on one noise level, the crossover's seeds:
  #     crossover-extra LEVEL VARIANT... (the page lists it under the crossover table, paired against BC* and BC)
  crossover-extra) level=${1:?LEVEL}; shift
               python -m benchmarks.stochastic --env $env --pools benchmarks/pools/$env-noise$level.npz \
               --variants "${@:?VARIANT...}" --n-trajectories $crossover_n --seeds 0-4 --episodes 100 \
               --csv results/stochastic/crossover_$env.csv $lockstep;;
  crossover-tuning) python -m benchmarks.stochastic --env $env --pools $noise_pools --variants $bc_variants \
               --n-trajectories ${@:-$crossover_n} --seeds 100-102 --episodes 100 \
               --csv results/stochastic/tuning_$env.csv $lockstep;;
  *) echo "stage: expected tuning, grid, baselines, curves, probes, crossover, crossover-extra or crossover-tuning, found $stage" >&2; exit 2;;
esac
