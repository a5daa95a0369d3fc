"""The environment of a harness command run from a folder other than the checkout: the checkout on PYTHONPATH, so
that ``python -m benchmarks.<script>`` finds the (not installed) harness."""

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def harness_env(**extra: str) -> dict[str, str]:
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, **extra}
