"""The README's quick start, verbatim, with busy processes beside it, against the same snippet run with one torch
thread set by hand: wall and CPU seconds of each, in turn, and their ratio pair by pair.

    python -m benchmarks.speed_threads --busy 2 --repeats 3 --csv results/speed_threads.csv

The snippet is the first ``python`` block of README.md, run in a fresh interpreter in a temporary folder. The busy
processes each run torch matrix products with torch's default threads for as long as the measurement lasts (the
load of a shared 2-core machine). ``learn`` runs with one intra-op thread by default (sb3_mbil.common.threads), so the
verbatim snippet should cost about what the hand-set one does.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BUSY = "import torch\nx = torch.randn(512, 512)\nwhile True:\n    x = (x @ x).tanh()\n"


def quick_start(readme: Path) -> str:
    match = re.search(r"```python\n(.*?)```", readme.read_text(), re.S)
    if match is None:
        raise ValueError(f"{readme}: expected a ```python block (the quick start), found none")
    return match.group(1)


def timed(code: str) -> tuple[float, float]:
    with tempfile.TemporaryDirectory() as folder:
        t0, r0 = time.perf_counter(), os.times()
        subprocess.run([sys.executable, "-c", code], cwd=folder, check=True, capture_output=True)
        r1 = os.times()
        return time.perf_counter() - t0, (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--busy", type=int, default=2)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--csv", default=None)
    p.add_argument("--note", default="", help="what else ran on the machine (recorded in each row)")
    a = p.parse_args(argv)
    from benchmarks.harness.grid import git_commit
    from benchmarks.harness.results import append_rows

    snippet = quick_start(Path(__file__).resolve().parent.parent / "README.md")
    one_thread = "import torch\ntorch.set_num_threads(1)\n" + snippet
    busy = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(a.busy)]
    columns = ["busy", "note", "repeat", "verbatim_wall_s", "one_thread_wall_s", "ratio_wall", "verbatim_cpu_s",
               "one_thread_cpu_s", "commit"]
    ratios, commit = [], git_commit()
    try:
        for r in range(a.repeats):
            wall_a, cpu_a = timed(snippet)
            wall_b, cpu_b = timed(one_thread)
            ratios.append(wall_a / wall_b)
            row = {"busy": a.busy, "note": a.note, "repeat": r, "verbatim_wall_s": round(wall_a, 1), "one_thread_wall_s": round(wall_b, 1),
                   "ratio_wall": round(ratios[-1], 3), "verbatim_cpu_s": round(cpu_a, 1),
                   "one_thread_cpu_s": round(cpu_b, 1), "commit": commit}
            if a.csv:
                append_rows(a.csv, [row], columns)
            print(row, flush=True)
    finally:
        for proc in busy:
            proc.kill()
    print(f"verbatim / one thread, wall time, median of {a.repeats} pairs: {np.median(ratios):.3f}")


if __name__ == "__main__":
    main()
