"""The harness's own command-line helpers (the generic ones live in :mod:`sb3_mbil.common.cli` and are
re-exported here): ``--overrides`` checked against each algorithm's constructor, results files checked
appendable before any training, and reports printed and written whole."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from sb3_mbil.common.cli import (  # noqa: F401  (re-exported for the harness's scripts)
    EXTRA_OF, check_output, finite_float, fraction, is_committed, parse_seeds, positive_int, run, seed,
)


#: the checkout: the harness is not installed, so a harness command run elsewhere needs it on PYTHONPATH
REPO = Path(__file__).resolve().parents[2]


def harness_env(**extra: str) -> dict[str, str]:
    """This process's environment with the checkout on PYTHONPATH (for ``python -m benchmarks.<script>`` run from
    any folder), plus ``extra``."""
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, **extra}


def overrides_json(text: str) -> dict[str, dict[str, Any]]:
    """``--overrides``: a JSON object of settings per algorithm, ``{"mbil": {"alpha": 0.1}}``; each checked against
    the algorithm's constructor (one line naming a misspelt key)."""
    import json

    from sb3_mbil import ALGORITHMS
    from benchmarks.harness.grid import check_overrides

    try:
        value = json.loads(text)
    except json.JSONDecodeError as e:
        raise argparse.ArgumentTypeError(f"expected JSON, found {text!r} ({e.msg})") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f'expected an object {{"algo": {{settings}}}}, found {text!r}')
    for algo, settings in value.items():
        if algo not in ALGORITHMS:
            raise argparse.ArgumentTypeError(f"expected algorithms among {sorted(ALGORITHMS)}, found {algo!r}")
        try:
            check_overrides(algo, settings)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    return value


def check_appendable(path: str | os.PathLike, option: str) -> None:
    """Refuse, before any training, a results file that cannot be appended to (a read-only file or file system, a
    folder that cannot be created): one line naming the option, instead of a traceback after the runs."""
    path = Path(path)
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if path.exists():
        ok = path.is_file() and os.access(path, os.W_OK) and os.access(path.parent, os.W_OK)
    else:
        ok = folder.is_dir() and os.access(folder, os.W_OK)
    if ok and path.exists():
        try:  # a read-only mount passes os.access for root: try to open it for appending
            with open(path, "a"):
                pass
        except OSError:
            ok = False
    elif ok:
        try:
            import tempfile

            with tempfile.TemporaryFile(dir=folder):
                pass
        except OSError:
            ok = False
    if not ok:
        raise ValueError(f"{option}: expected a results file that can be appended to, found {path} not writable "
                         "(a read-only file, folder or file system)")


def emit(text: str, markdown: str | os.PathLike | None = None) -> None:
    """Print a script's report, and write it whole to ``markdown`` when given."""
    print(text)
    if markdown:
        from benchmarks.harness.results import write_text

        write_text(markdown, text + "\n")




def probe_parser(doc: str, *, pools: list[str], n_trajectories: list[int], variants: list[str],
                 choices: list[str], csv: str) -> argparse.ArgumentParser:
    """The options of a probe on tuning seeds (``benchmarks.fit_budget``, ``benchmarks.balance_ablation``): env,
    pools, N, seeds (100-109 by default), variants, episodes, the CSV, and ``--summary CSV``."""
    p = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="LunarLander-v3")
    p.add_argument("--pools", nargs="+", default=pools)
    p.add_argument("--n-trajectories", type=positive_int, nargs="+", default=n_trajectories)
    p.add_argument("--seeds", type=parse_seeds, default=list(range(100, 110)))
    p.add_argument("--variants", nargs="+", default=variants, choices=choices)
    p.add_argument("--episodes", type=positive_int, default=100)
    p.add_argument("--csv", default=csv)
    p.add_argument("--summary", default=None, metavar="CSV", help="print the comparison of a finished CSV and stop")
    return p


def check_tuning_seeds(seeds: list[int]) -> None:
    """A probe that picks settings runs on tuning seeds (>= 100) only."""
    if min(seeds) < 100:
        raise ValueError(f"--seeds: expected tuning seeds >= 100, found {min(seeds)}")
