#!/usr/bin/env bash
# The d3rlpy peer runs in its own venv: d3rlpy 2.8.1 pins gymnasium 1.0.0, which this package's envs do not use.
# CPU torch first (a bare torch requirement pulls a CUDA build). Usage: bash benchmarks/peers/make_venv.sh [VENV]
set -euo pipefail
VENV=${1:-.venv-d3rlpy}
python3 -m venv "$VENV"
"$VENV/bin/pip" install -q torch==2.13.0
"$VENV/bin/pip" install -q d3rlpy==2.8.1
"$VENV/bin/python" -c "import d3rlpy, torch; print('d3rlpy', d3rlpy.__version__, 'torch', torch.__version__)"
