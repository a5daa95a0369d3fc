#!/usr/bin/env bash
# Stochastic demonstrators on LunarLander-v3: benchmarks/runs/stochastic.sh for that env.
#   bash benchmarks/runs/stochastic_lunarlander.sh tuning|grid|crossover|crossover-tuning [N ...]
exec bash "$(dirname "$0")/stochastic.sh" LunarLander-v3 "$@"
