"""The README's numbers, computed from the committed result files: the "which algorithm" table, the results table
(one trajectory: at most 14 lines) and its figure. Each table is written between its two markers in README.md,
never by hand::

    python -m benchmarks.readme --overwrite        # rewrites the marked blocks and results/readme.png

What goes in (one expert trajectory unless stated; every algorithm on the same draws and seeds):

* deterministic demonstrations (the shipped pools): the classic-control grid (results/classic_control.csv, N = 1,
  10 seeds, 300 episodes) and the MuJoCo curves (results/figure4.csv, 5 seeds, the mean of each seed's last 10
  evaluations);
* sampled demonstrations (the experts' own sampled actions): results/stochastic/<env>.csv, each algorithm at its
  best variant on the tuning seeds (BC*, MBIL*, MBIL-C*): N = 1 in the results table and figure, N = 1 and 3 in
  the which table.

Scores are normalised: 0 is a random policy and 1 the expert (MuJoCo: the return over the expert's). A mark after
a score says its paired 95% interval against BC (BC* on sampled data) excludes zero: ``+`` above, ``-`` below; a
score over fewer seeds than the setting's others (a cell still running) says how many.
"""

from __future__ import annotations

import argparse
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks.harness.cli import run
from benchmarks.harness.curves import final_returns, pool_experts
from benchmarks.harness.report import RANDOM_RETURN, expert_returns, paired_interval, read_rows
from benchmarks.harness.results import read_result_rows
from benchmarks.stochastic_report import LABEL, tuning_table
from sb3_mbil.common.demonstrations import load_demonstrations
from sb3_mbil.common.files import write_text

CLASSIC = ("CartPole-v1", "Acrobot-v1", "LunarLander-v3")
MUJOCO = ("Hopper-v4", "HalfCheetah-v4", "Walker2d-v4", "Ant-v4")
FAMILY = ("mbil", "mbil_c")
MARKERS = {"which": ("<!-- which-algorithm: python -m benchmarks.readme -->", "<!-- /which-algorithm -->"),
           "results": ("<!-- results: python -m benchmarks.readme -->", "<!-- /results -->")}


@dataclass
class Setting:
    """One line of the results table: per algorithm, its normalised score per seed (paired by seed)."""

    demonstrations: str
    env: str
    n: int
    scores: dict[str, dict[int, float]] = field(default_factory=dict)
    names: dict[str, str] = field(default_factory=dict)  # algo -> the variant that ran (sampled data: the tuned one)

    def mean(self, algo: str) -> float:
        return float(np.mean(list(self.scores[algo].values())))

    def against_bc(self, algo: str) -> tuple[float, float] | None:
        """The paired 95% interval of ``algo`` minus BC over the seeds both ran (None on fewer than 2)."""
        common = sorted(set(self.scores[algo]) & set(self.scores["bc"]))
        if len(common) < 2:
            return None
        return paired_interval(np.array([self.scores[algo][s] - self.scores["bc"][s] for s in common]))

    def cell(self, algo: str) -> str:
        if algo not in self.scores:
            return "–"
        mark, interval = "", self.against_bc(algo) if algo != "bc" else None
        if interval is not None:
            mark = "+" if interval[0] > 0 else ("-" if interval[1] < 0 else "")
        seeds = len(self.scores[algo])
        partial = f" ({seeds} seeds)" if seeds < max(len(v) for v in self.scores.values()) else ""
        return f"{self.mean(algo):.2f}{mark}{partial}"

    def best_baseline(self) -> str | None:
        others = [a for a in self.scores if a not in ("bc", *FAMILY)]
        return max(others, key=self.mean) if others else None


def _normalise(value: float, env: str, expert: float) -> float:
    if env in RANDOM_RETURN:
        return (value - RANDOM_RETURN[env]) / (expert - RANDOM_RETURN[env])
    return value / expert


def grid_settings(n: int, grid_csv: str = "results/classic_control.csv") -> list[Setting]:
    """The classic-control grid's cells with ``n`` trajectories (full trajectories, the shipped pools)."""
    if not Path(grid_csv).is_file():
        return []
    rows = [r for r in read_rows(grid_csv) if r.get("protocol", "full") in ("", "full") and r["n_trajectories"] == n]
    expert = expert_returns(CLASSIC)
    out = []
    for env in CLASSIC:
        s = Setting("deterministic", env, n)
        for r in rows:
            if r["env"] == env:
                s.scores.setdefault(r["algo"], {})[r["seed"]] = _normalise(r["mean_return"], env, expert[env])
        if s.scores.get("bc"):
            out.append(s)
    return out


def deterministic_settings(grid_csv: str = "results/classic_control.csv",
                           curves_csv: str = "results/figure4.csv") -> list[Setting]:
    out = grid_settings(1, grid_csv)
    if Path(curves_csv).is_file():
        rows = read_result_rows(curves_csv)
        expert = pool_experts(rows)
        finals = final_returns(rows)
        for env in MUJOCO:
            s = Setting("deterministic", env, 1)
            for (e, algo), by_seed in finals.items():
                if e == env and algo in LABEL:
                    s.scores[algo] = {seed: _normalise(ret, env, expert[env]) for seed, (ret, _) in by_seed.items()}
            if s.scores.get("bc"):
                out.append(s)
    return out


def sampled_settings(folder: str = "results/stochastic") -> list[Setting]:
    """Per env and N of the sampled pools: BC*, MBIL* and MBIL-C* (the chosen variants of the tuning), once all
    three have a chosen variant and rows on the grid's seeds."""
    out = []
    for env in (*CLASSIC, *MUJOCO):
        grid, tuning = Path(folder) / f"{env}.csv", Path(folder) / f"tuning_{env}.csv"
        if not (grid.is_file() and tuning.is_file()):
            continue
        _, chosen = tuning_table(read_result_rows(tuning))
        rows = read_result_rows(grid)
        pool = f"{env}-sampled"
        expert = float(load_demonstrations(pool).episode_returns.mean())
        for n in sorted({int(r["n_trajectories"]) for r in rows}):
            best = chosen.get((env, pool, n), {})
            if not all(a in best for a in ("bc", *FAMILY)):
                continue
            s = Setting("sampled", env, n)
            for algo in ("bc", *FAMILY):
                s.names[algo] = best[algo]
                s.scores[algo] = {int(r["seed"]): _normalise(float(r["mean_return"]), env, expert) for r in rows
                                  if r["variant"] == best[algo] and r["pool"] == pool and int(r["n_trajectories"]) == n
                                  and int(r["seed"]) < 100}
            if all(len(v) >= 2 for v in s.scores.values()):
                out.append(s)
    return out


def results_table(settings: list[Setting]) -> str:
    lines = ["| demonstrations | env | N | BC | MBIL | MBIL-C | best other baseline |", "|---|---|---|---|---|---|---|"]
    for s in settings:
        best = s.best_baseline()
        other = f"{s.cell(best)} {LABEL[best]}" if best else "–"
        lines.append(f"| {s.demonstrations} | {s.env} | {s.n} | {s.cell('bc')} | {s.cell('mbil')} | "
                     f"{s.cell('mbil_c')} | {other} |")
    return "\n".join(lines)


def recommendation(settings: list[Setting]) -> tuple[str, float, float, int]:
    """The algorithm to pick over some settings: an MBIL-family algorithm only where it is above BC with an interval
    that excludes zero in more than half of them (never below in any), else BC; with its mean score over them."""
    for algo in FAMILY:
        intervals = [s.against_bc(algo) for s in settings]
        above = sum(1 for i in intervals if i is not None and i[0] > 0)
        below = sum(1 for i in intervals if i is not None and i[1] < 0)
        if above > len(settings) / 2 and below == 0:
            scores = [s.mean(algo) for s in settings]
            return algo, min(scores), max(scores), len(settings)
    scores = [s.mean("bc") for s in settings]
    return "bc", min(scores), max(scores), len(settings)


def which_table(deterministic: list[Setting], sampled: list[Setting], many_csv: str = "results/classic_control.csv") -> str:
    lines = ["| your demonstrations | trajectories | pick | expected score (0 random, 1 expert) | measured on |",
             "|---|---|---|---|---|"]
    if deterministic:
        algo, lo, hi, n = recommendation(deterministic)
        lines.append(f"| deterministic (the expert's chosen action) | 1 | `{algo}` | {lo:.2f}-{hi:.2f} | {n} envs, "
                     "[BENCHMARKS.md](BENCHMARKS.md) |")
    many = grid_settings(15, many_csv)
    if many:
        algo, lo, hi, n = recommendation(many)
        lines.append(f"| deterministic | 15 | `{algo}` | {lo:.2f}-{hi:.2f} | {n} envs, [BENCHMARKS.md](BENCHMARKS.md) |")
    for trajectories in sorted({s.n for s in sampled}):  # one row per N that has run: few (1, 3) and many (15)
        group = [s for s in sampled if s.n == trajectories]
        algo, lo, hi, n = recommendation(group)
        variants = sorted({s.names[algo] for s in group})
        lines.append(f"| noisy or sampled (the expert's own random actions) | {trajectories} | `{algo}` "
                     f"(tuned: {', '.join(variants)}) | {lo:.2f}-{hi:.2f} | {', '.join(s.env for s in group)} so far, "
                     "[results/stochastic.md](results/stochastic.md) |")
    return "\n".join(lines)


def plot(settings: list[Setting], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 3.2))
    labels = [f"{s.env.split('-')[0]}\nN={s.n}{' sampled' if s.demonstrations == 'sampled' else ''}" for s in settings]
    x = np.arange(len(settings))
    for i, algo in enumerate(("bc", *FAMILY)):
        means = [s.mean(algo) if algo in s.scores else np.nan for s in settings]
        errors = [np.std(list(s.scores[algo].values()), ddof=1) / np.sqrt(len(s.scores[algo]))
                  if algo in s.scores and len(s.scores[algo]) > 1 else 0.0 for s in settings]
        ax.bar(x + (i - 1) * 0.27, means, 0.27, yerr=errors, label=LABEL[algo] + (" (* on sampled)" if algo == "bc" else ""))
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xticks(x, labels, fontsize=7)
    ax.set_ylabel("score (1 = expert)")
    ax.legend(fontsize=7, ncol=3, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def replace_block(text: str, name: str, body: str) -> str:
    start, end = MARKERS[name]
    pattern = re.compile(re.escape(start) + r".*?" + re.escape(end), re.S)
    if not pattern.search(text):
        raise ValueError(f"README: expected the markers {start} ... {end}, found none")
    return pattern.sub(lambda _: f"{start}\n{body}\n{end}", text)


def readme_blocks() -> tuple[dict[str, str], list[Setting]]:
    deterministic, sampled = deterministic_settings(), sampled_settings()
    # one trajectory in the results table and figure (at most 7 + 7 lines); three enter the which table
    settings = deterministic + [s for s in sampled if s.n == 1]
    return {"which": which_table(deterministic, sampled), "results": results_table(settings)}, settings


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--readme", default="README.md")
    parser.add_argument("--figure", default="results/readme.png")
    parser.add_argument("--overwrite", action="store_true", help="rewrite the README's marked blocks and the figure")
    args = parser.parse_args(argv)
    blocks, settings = readme_blocks()
    if not args.overwrite:
        print("\n\n".join(blocks.values()))
        return
    text = Path(args.readme).read_text()
    for name, body in blocks.items():
        text = replace_block(text, name, body)
    write_text(args.readme, text)
    plot(settings, args.figure)
    print(f"wrote the marked blocks of {args.readme} and {args.figure}")


if __name__ == "__main__":
    run(main)
