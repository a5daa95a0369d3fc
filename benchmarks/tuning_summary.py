"""Summarise the tuning CSVs (seeds 100 and up): mean return per (env, N) for each setting, the mean
normalised score over those cells, and, for cells tuned on 10 or more seeds, the paired differences
(same seed, so the same trajectories) of every setting against the cell's best.

    python -m benchmarks.tuning_summary results/tuning/*.csv
"""

import sys

import numpy as np

from benchmarks.harness.cli import run
from benchmarks.harness.report import RANDOM_RETURN, expert_returns, grouped, read_rows

PAIRED_MIN_SEEDS = 10


def main(paths):
    cells, table, by_seed = set(), {}, {}
    for path in paths:
        rows = read_rows(path)
        if not rows or "n_trajectories" not in rows[0] or "gradient_step" in rows[0]:
            print(f"(skipped {path}: not a grid CSV of benchmarks/run_grid.py)", file=sys.stderr)
            continue
        others = sorted({r["env"] for r in rows} - set(RANDOM_RETURN))
        if others:
            raise ValueError(f"{path}: expected classic-control rows ({', '.join(sorted(RANDOM_RETURN))}), found {others}")
        g = grouped(rows)
        for (algo, env, n), v in g.items():
            table[(f"{algo} [{path.split('/')[-1][:-4]}]", env, n)] = v
            cells.add((env, n))
        for r in rows:
            setting = f"{r['algo']} [{path.split('/')[-1][:-4]}]"
            by_seed.setdefault((setting, r["env"], r["n_trajectories"]), {})[r["seed"]] = r["mean_return"]
    cells = sorted(cells)
    expert = expert_returns(sorted({e for e, _ in cells}))
    print("| setting | " + " | ".join(f"{e} N={n}" for e, n in cells) + " | normalised mean |")
    print("|---|" + "---|" * (len(cells) + 1))
    for setting in sorted({k[0] for k in table}):
        vals = [table.get((setting, e, n)) for e, n in cells]
        norm = [np.mean((v - RANDOM_RETURN[e]) / (expert[e] - RANDOM_RETURN[e])) for v, (e, _) in zip(vals, cells) if v is not None]
        print(f"| {setting} | " + " | ".join("" if v is None else f"{v.mean():.1f} ({len(v)})" for v in vals)
              + f" | {np.mean(norm):.3f} |")
    for env, n in cells:
        runs = {k[0]: v for k, v in by_seed.items() if k[1:] == (env, n) and len(v) >= PAIRED_MIN_SEEDS}
        paired_table(runs, f"{env} N={n}, paired against the best mean, {{best}} (difference of mean returns on the "
                     "shared seeds, mean +- standard error; on how many seeds below):", "seeds", "mean return", digits=1)
    pooled(by_seed, expert)


def pooled(by_seed: dict, expert: dict) -> None:
    """Every setting against the best normalised mean, paired over every draw (env, N, seed) the two share: where
    cells have too few seeds for a paired table of their own, the pooled difference still says whether a setting
    is above by more than two standard errors (the tuning rule of docs/benchmarks_notes.md)."""
    norm: dict[str, dict] = {}
    for (setting, env, n), seeds in by_seed.items():
        for seed, ret in seeds.items():
            norm.setdefault(setting, {})[(env, n, seed)] = (ret - RANDOM_RETURN[env]) / (expert[env] - RANDOM_RETURN[env])
    paired_table(norm, "Pooled over every shared draw (env, N, seed), normalised returns, paired against the best, "
                 "{best} (difference mean +- standard error; on how many draws below):", "draws", "normalised mean",
                 digits=3)


def paired_table(values: dict[str, dict], title: str, unit: str, mean_name: str, digits: int) -> None:
    """With two settings or more: ``title`` (``{best}`` names the setting of the best mean) and a markdown table of
    every setting against the best on the keys (seeds or draws) the two share: mean, mean difference +- standard
    error, and on how many keys the setting is below."""
    if len(values) < 2:
        return
    best = max(values, key=lambda k: np.mean(list(values[k].values())))
    print("\n" + title.format(best=best) + "\n")
    print(f"| setting | {unit} | {mean_name} | difference | below |")
    print("|---|---|---|---|---|")
    for setting in sorted(values):
        keys = sorted(set(values[setting]) & set(values[best]))
        d = np.array([values[setting][k] - values[best][k] for k in keys])
        se = d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else float("nan")
        print(f"| {setting} | {len(keys)} | {np.mean([values[setting][k] for k in keys]):.{digits}f} | "
              f"{d.mean():+.{digits}f} +- {se:.{digits}f} | {int((d < 0).sum())} of {len(d)} |")


if __name__ == "__main__":
    run(lambda: main(sys.argv[1:]))
