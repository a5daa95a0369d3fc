"""The default test suite's wall time (the README's `python -m pytest`, two xdist workers) with busy processes beside
it, appended as one row:

    python -m benchmarks.speed_suite --busy 1 --csv results/speed_suite.csv

``--busy K`` starts K single-thread torch loops for as long as the suite runs (a study's runs, each one torch
thread); ``--note`` records what else ran on the machine.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.harness.cli import check_appendable, run
from benchmarks.harness.grid import git_commit
from benchmarks.harness.results import append_rows

REPO = Path(__file__).resolve().parents[1]
BUSY = "import torch\ntorch.set_num_threads(1)\nx = torch.randn(256, 256)\nwhile True:\n    x = (x @ x).tanh()\n"
COLUMNS = ["busy", "note", "wall_seconds", "passed", "failed", "summary", "failures", "commit"]


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--busy", type=int, default=1)
    p.add_argument("--csv", default=None)
    p.add_argument("--note", default="")
    a = p.parse_args(argv)
    if a.csv:
        check_appendable(a.csv, "--csv")
    busy = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(a.busy)]
    try:
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"], cwd=REPO,
                             capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
        wall = time.perf_counter() - t0
    finally:
        for b in busy:
            b.kill()
    summary = next((line.strip("= ") for line in reversed(out.stdout.splitlines()) if " in " in line and "passed" in line),
                   out.stdout.strip().splitlines()[-1] if out.stdout.strip() else "no output")
    counts = {k: int(n) for n, k in re.findall(r"(\d+) (passed|failed)", summary)}
    failures = [line.split(" ")[1] for line in out.stdout.splitlines() if line.startswith("FAILED ")]
    row = {"busy": a.busy, "note": a.note, "wall_seconds": round(wall, 1), "passed": counts.get("passed", 0),
           "failed": counts.get("failed", 0), "summary": summary, "failures": " ".join(failures), "commit": git_commit()}
    print(row)
    if a.csv:
        append_rows(a.csv, [row], COLUMNS)


if __name__ == "__main__":
    run(main)
