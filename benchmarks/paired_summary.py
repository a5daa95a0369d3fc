"""Paired differences of a grid CSV (benchmarks/run_grid.py rows) against one algorithm, for any env and pool (no
expert pool needed): per (env, N), on how many seeds each algorithm is below the reference and the mean difference
+- its standard error, plus each algorithm's mean return.

    python -m benchmarks.paired_summary results/other_experts.csv --against bc
    python -m benchmarks.paired_summary results/classic_control.csv --against bc --algos mbil mbil_c
"""

import argparse
from collections import defaultdict

import numpy as np

from benchmarks.harness.cli import run


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("csv")
    p.add_argument("--against", default="bc")
    p.add_argument("--algos", nargs="+", default=None, help="algorithms to compare (default: all others in the CSV)")
    a = p.parse_args(argv)
    from benchmarks.harness.report import paired, read_rows

    rows = read_rows(a.csv)
    algos = a.algos or sorted({r["algo"] for r in rows} - {a.against})
    means = defaultdict(list)
    for r in rows:
        means[(r["env"], r["n_trajectories"], r["algo"])].append(float(r["mean_return"]))
    print("| env | N | " + " | ".join([a.against, *algos]) + " |")
    print("|---|---|" + "---|" * (len(algos) + 1))
    for env, n in sorted({(e, n) for e, n, _ in means}):
        cells = [f"{np.mean(means[(env, n, x)]):.1f} ({len(means[(env, n, x)])})" if means.get((env, n, x)) else ""
                 for x in [a.against, *algos]]
        print(f"| {env} | {n} | " + " | ".join(cells) + " |")
    for algo in algos:
        print(paired(rows, algo, a.against))


if __name__ == "__main__":
    run(main)
