"""Tables, the Figure 3 plot and normalised aggregate scores (rliable) from a results CSV."""

from __future__ import annotations

import contextlib
import os
from collections import defaultdict

import numpy as np

from benchmarks.harness.pools import pool_experts

# Random-policy returns and published anchors (best published baseline,
# read off the figures of earlier papers, about +-10; their data kept every 20th step).
RANDOM_RETURN = {"CartPole-v1": 20.0, "Acrobot-v1": -500.0, "LunarLander-v3": -180.0}
PUBLISHED_BEST = {
    "CartPole-v1": {1: 459, 3: 485, 7: 500, 10: 500, 15: 500},
    "Acrobot-v1": {1: -82, 3: -75, 7: -75, 10: -75, 15: -75},
    "LunarLander-v3": {1: 130, 3: 252, 7: 285, 10: 285, 15: 285},
}
PUBLISHED_BC = {
    "CartPole-v1": {1: 170, 3: 300, 7: 400, 10: 450, 15: 500},
    "Acrobot-v1": {1: -160, 3: -90, 7: -75, 10: -75, 15: -75},
    "LunarLander-v3": {1: -50, 3: 69, 7: 243, 10: 252, 15: 260},
}


def paired_interval(d) -> tuple[float, float]:
    """The 95% confidence interval of the mean of paired differences ``d`` (Student's t over seeds, scipy); a
    constant ``d`` gives its value at both ends. At least two differences."""
    from scipy import stats

    d = np.asarray(d, dtype=float)
    if len(d) < 2:
        raise ValueError(f"paired differences: expected at least 2, found {len(d)}")
    if np.allclose(d, d[0]):
        return float(d[0]), float(d[0])
    lo, hi = stats.ttest_rel(d, np.zeros_like(d)).confidence_interval(0.95)
    return float(lo), float(hi)



def paired_verdict(d) -> str:
    """The mean of paired differences ``d`` with its 95% interval and a word: "above" / "below" where the interval
    excludes zero, "level" where it does not (one difference: its value and "(1 seed)")."""
    d = np.asarray(d, dtype=float)
    if len(d) < 2:
        return f"{d.mean():+.1f} (1 seed)"
    lo, hi = paired_interval(d)
    word = "above" if lo > 0 else ("below" if hi < 0 else "level")
    return f"{d.mean():+.1f} [{lo:+.1f}, {hi:+.1f}] {word}"

def read_rows(path: str) -> list[dict]:
    """The grid's rows, typed; a malformed file is refused with its path and line."""
    from benchmarks.harness.results import read_result_rows

    rows = read_result_rows(path)
    for r in rows:
        r["n_trajectories"], r["seed"] = int(r["n_trajectories"]), int(r["seed"])
        r["mean_return"] = float(r["mean_return"])
    return rows


def expert_returns(envs, rows=None) -> dict[str, float]:
    """Per env, the mean return of the pool the runs drew from (``rows``' ``expert_pool`` setting; the env's shipped
    pool without rows or without the setting)."""
    from sb3_mbil import load_demonstrations

    if rows:
        return pool_experts(rows)
    return {e: float(load_demonstrations(e).episode_returns.mean()) for e in envs}


def grouped(rows) -> dict[tuple[str, str, int], np.ndarray]:
    out = defaultdict(list)
    for r in rows:
        out[(r["algo"], r["env"], r["n_trajectories"])].append(r["mean_return"])
    return {k: np.array(v) for k, v in out.items()}


def table(rows, anchors: bool = True) -> str:
    """Per env, mean +- std over seeds of every (algo, N); ``anchors``: also the published rows (read off earlier
    papers' figures, their experts and data) for the first pools."""
    g = grouped(rows)
    envs = sorted({r["env"] for r in rows})
    algos = sorted({r["algo"] for r in rows})
    ns = sorted({r["n_trajectories"] for r in rows})
    expert = expert_returns(envs, rows)
    lines = []
    for env in envs:
        lines.append(f"\n{env} (expert {expert[env]:.1f}, random {RANDOM_RETURN.get(env, float('nan')):.0f})\n")
        lines.append("| algo | " + " | ".join(f"N={n}" for n in ns) + " |")
        lines.append("|---|" + "---|" * len(ns))
        for algo in algos:
            cells = []
            for n in ns:
                v = g.get((algo, env, n))
                cells.append("" if v is None else f"{v.mean():.1f} +- {v.std():.1f} ({len(v)})")
            lines.append(f"| {algo} | " + " | ".join(cells) + " |")
        for label, ref in (("published best (every 20th step)", PUBLISHED_BEST), ("published BC (every 20th step)", PUBLISHED_BC)):
            if anchors and env in ref:
                lines.append(f"| {label} | " + " | ".join(str(ref[env].get(n, "")) for n in ns) + " |")
    return "\n".join(lines)


def normalised_scores(rows) -> dict[str, np.ndarray]:
    """Per algorithm: (runs x tasks) matrix of (return - random) / (expert - random); tasks = (env, N)."""
    envs = sorted({r["env"] for r in rows})
    expert = expert_returns(envs, rows)
    g = grouped(rows)
    tasks = sorted({(e, n) for (_, e, n) in g})
    out = {}
    for algo in sorted({r["algo"] for r in rows}):
        cols = [g.get((algo, e, n)) for e, n in tasks]
        if any(c is None for c in cols):
            continue
        k = min(len(c) for c in cols)
        out[algo] = np.stack([(c[:k] - RANDOM_RETURN[e]) / (expert[e] - RANDOM_RETURN[e]) for c, (e, _) in zip(cols, tasks)], 1)
    return out


@contextlib.contextmanager
def _seeded_bootstrap(seed: int = 0):
    """rliable's stratified bootstrap draws from numpy's global generator (its ``random_state`` does not reach its
    index draws): seed it for the call and put the global state back, so that a page regenerated from the same rows
    has the same intervals."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(state)


def aggregate(rows, reps: int = 2000) -> dict[str, dict[str, tuple[float, float, float]]]:
    """IQM and mean normalised score with stratified-bootstrap 95% intervals (rliable)."""
    from rliable import library as rly
    from rliable import metrics

    scores = normalised_scores(rows)
    if not scores:
        return {}
    fns = lambda x: np.array([metrics.aggregate_iqm(x), metrics.aggregate_mean(x)])  # noqa: E731
    with _seeded_bootstrap():
        point, ci = rly.get_interval_estimates(scores, fns, reps=reps)
    return {a: {"iqm": (point[a][0], ci[a][0, 0], ci[a][1, 0]), "mean": (point[a][1], ci[a][0, 1], ci[a][1, 1])} for a in scores}


def plot(rows, path: str):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g = grouped(rows)
    envs = sorted({r["env"] for r in rows})
    algos = sorted({r["algo"] for r in rows})
    colors = variant_colors(algos)
    expert = expert_returns(envs, rows)
    fig, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 4), squeeze=False)
    for ax, env in zip(axes[0], envs):
        for algo in algos:
            ns = sorted(n for (a, e, n) in g if a == algo and e == env)
            if not ns:
                continue
            m = np.array([g[(algo, env, n)].mean() for n in ns])
            se = np.array([g[(algo, env, n)].std(ddof=1) / np.sqrt(len(g[(algo, env, n)])) if len(g[(algo, env, n)]) > 1 else 0.0 for n in ns])
            ax.plot(ns, m, marker="o", label=algo.upper(), color=colors[algo])
            ax.fill_between(ns, m - 1.96 * se, m + 1.96 * se, alpha=0.2, color=colors[algo])
        ax.axhline(expert[env], color="k", ls="--", lw=1, label="expert")
        if env in RANDOM_RETURN:
            ax.axhline(RANDOM_RETURN[env], color="gray", ls=":", lw=1, label="random")
    finish_figure(fig, axes, envs, "expert trajectories", path)
    return fig


def variant_colors(names) -> dict[str, str]:
    """One colour per algorithm or variant, the same in every panel and every figure: the algorithms of
    ``sb3_mbil.ALGORITHMS`` keep their place in the tab10 palette, other variants take tab20's light colours."""
    from matplotlib import colormaps

    from sb3_mbil import ALGORITHMS

    names = set(names)  # read once: ``names`` may be a generator
    palette = list(colormaps["tab10"].colors) + list(colormaps["tab20"].colors[1::2])
    known = list(ALGORITHMS)
    others = sorted(names - set(known))
    return {name: palette[(known.index(name) if name in known else len(known) + others.index(name)) % len(palette)]
            for name in names}


def finish_figure(fig, axes, envs, xlabel: str, path: str) -> None:
    """Titles, labels, one legend of every line in any panel; write the figure to ``path``."""
    for ax, env in zip(axes[0], envs):
        ax.set_title(env)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("average return")
    legend: dict[str, object] = {}
    for ax in axes[0]:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            legend.setdefault(label, handle)
    axes[0][0].legend(list(legend.values()), list(legend))
    fig.tight_layout()
    from sb3_mbil.common.files import atomic_write

    with atomic_write(path) as tmp:  # a figure is written whole or not at all
        fig.savefig(tmp, dpi=120, format=os.path.splitext(path)[1][1:] or "png")


def paired_scores(rows, algo: str, reference: str = "bc") -> tuple[np.ndarray, np.ndarray] | None:
    """Normalised scores of ``algo`` and ``reference`` on the seeds both ran, (seeds x tasks) each, over the tasks
    (env, N) where both have the same seeds; None when they share no task."""
    envs = sorted({r["env"] for r in rows})
    expert = expert_returns(envs, rows)
    runs = defaultdict(dict)
    for r in rows:
        runs[(r["env"], r["n_trajectories"])].setdefault(r["algo"], {})[r["seed"]] = r["mean_return"]
    cols_a, cols_b = [], []
    for (env, _), by_algo in sorted(runs.items()):
        if algo not in by_algo or reference not in by_algo:
            continue
        seeds = sorted(set(by_algo[algo]) & set(by_algo[reference]))
        scale = expert[env] - RANDOM_RETURN[env]
        cols_a.append([(by_algo[algo][s] - RANDOM_RETURN[env]) / scale for s in seeds])
        cols_b.append([(by_algo[reference][s] - RANDOM_RETURN[env]) / scale for s in seeds])
    if not cols_a:
        return None
    k = min(len(c) for c in cols_a)
    return np.array([c[:k] for c in cols_a]).T, np.array([c[:k] for c in cols_b]).T


def probability_of_improvement(rows, reference: str = "bc", reps: int = 2000) -> dict[str, tuple[float, float, float]]:
    """P(algo > reference) over the shared (env, N) tasks, with its stratified-bootstrap 95% interval (rliable's
    ``probability_of_improvement``: the chance that a run of ``algo`` beats a run of ``reference`` on the same task,
    ties counted half, averaged over the tasks)."""
    from rliable import library as rly
    from rliable import metrics

    pairs = {}
    for algo in sorted({r["algo"] for r in rows} - {reference}):
        scores = paired_scores(rows, algo, reference)
        if scores is not None and scores[0].shape[0] >= 2:
            pairs[algo] = scores
    if not pairs:
        return {}
    with _seeded_bootstrap():
        point, ci = rly.get_interval_estimates(pairs, metrics.probability_of_improvement, reps=reps)
    return {a: (float(np.squeeze(point[a])), float(np.squeeze(ci[a][0])), float(np.squeeze(ci[a][1]))) for a in pairs}


def paired(rows, a: str = "mbil", b: str = "bc") -> str:
    """Per (env, N): on how many seeds ``a`` scored below ``b`` (the same trajectories, the same seed), and the
    mean paired difference ``a - b`` with its standard error."""
    runs = defaultdict(dict)
    for r in rows:
        runs[(r["env"], r["n_trajectories"], r["seed"])][r["algo"]] = r["mean_return"]
    cells = sorted({(e, n) for (e, n, _) in runs})
    ns = sorted({n for _, n in cells})
    lines = [f"\nSeeds on which {a} scored below {b} (paired: same trajectories, same seed), of the seeds with both; "
             f"then the mean difference {a} - {b} +- its standard error:\n",
             "| env | " + " | ".join(f"N={n}" for n in ns) + " |", "|---|" + "---|" * len(ns)]
    for env in sorted({e for e, _ in cells}):
        cells_env = []
        for n in ns:
            pairs = [(v[a], v[b]) for (e, nn, _), v in runs.items() if e == env and nn == n and a in v and b in v]
            if not pairs:
                cells_env.append("")
                continue
            d = np.array([x - y for x, y in pairs], dtype=float)
            se = d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else float("nan")
            cells_env.append(f"{int((d < 0).sum())} of {len(d)}, {d.mean():+.1f} +- {se:.1f}")
        lines.append(f"| {env} | " + " | ".join(cells_env) + " |")
    return "\n".join(lines)
