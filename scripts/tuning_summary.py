"""Summarise the tuning CSVs (seeds 100-102): mean return per (env, N) for each setting, and the mean
normalised score over those cells.

    python scripts/tuning_summary.py results/tuning/*.csv
"""

import sys

import numpy as np

from sb3_mbil.benchmark.report import RANDOM_RETURN, expert_returns, grouped, read_rows


def main(paths):
    cells, table = set(), {}
    for path in paths:
        g = grouped(read_rows(path))
        for (algo, env, n), v in g.items():
            table[(f"{algo} [{path.split('/')[-1][:-4]}]", env, n)] = v
            cells.add((env, n))
    cells = sorted(cells)
    expert = expert_returns(sorted({e for e, _ in cells}))
    print("| setting | " + " | ".join(f"{e} N={n}" for e, n in cells) + " | normalised mean |")
    print("|---|" + "---|" * (len(cells) + 1))
    for setting in sorted({k[0] for k in table}):
        vals = [table.get((setting, e, n)) for e, n in cells]
        norm = [np.mean((v - RANDOM_RETURN[e]) / (expert[e] - RANDOM_RETURN[e])) for v, (e, _) in zip(vals, cells) if v is not None]
        print(f"| {setting} | " + " | ".join("" if v is None else f"{v.mean():.1f} ({len(v)})" for v in vals)
              + f" | {np.mean(norm):.3f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
