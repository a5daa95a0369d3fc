#!/usr/bin/env bash
# The stochastic pools (shipped in sb3_mbil/data as "<env>-sampled") and the noise families (benchmarks/pools/, not
# shipped) from the expert agents in experts/<algo>-<env>/ (the zoo cache's training when an agent is not there yet).
# Rerun to resume: finished pools are skipped.
#   bash benchmarks/runs/stochastic_pools.sh ENV [ENV ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
for env in "$@"; do
  algo=$(python -c "from sb3_mbil.experts import EXPERTS; print(EXPERTS['$env'].algo)")
  source=experts/$algo-$env/best_model.zip
  [ -f "$source" ] || source=zoo
  case "$env" in
    Hopper-v4|Walker2d-v4) n=50; levels="0 0.1 0.2 0.4"; nn=20;;
    LunarLander-v3) n=1000; levels="0 0.05 0.1 0.2"; nn=200;;
    HalfCheetah-v4|Ant-v4) n=50; levels=""; nn=0;;
    *) n=1000; levels=""; nn=0;;
  esac
  out=sb3_mbil/data/$env-sampled.npz
  [ -f "$out" ] || python scripts/generate_expert_data.py --env "$env" --algo "$algo" --n-trajectories $n \
      --source "$source" --seed 0 --sampled-actions --out "$out"
  for level in $levels; do
    out=benchmarks/pools/$env-noise$level.npz
    [ -f "$out" ] || python scripts/generate_expert_data.py --env "$env" --algo "$algo" --n-trajectories $nn \
        --source "$source" --seed 0 --action-noise "$level" --out "$out"
  done
done
