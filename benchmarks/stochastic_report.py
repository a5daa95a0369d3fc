"""The stochastic-demonstrator results page, generated from the study's CSVs (benchmarks/stochastic.py).

    python -m benchmarks.stochastic_report --out results/stochastic.md

Reads ``results/stochastic/tuning_<env>.csv`` (tuning seeds >= 100), ``results/stochastic/<env>.csv`` (the grids,
seeds 0-9) and ``results/stochastic/crossover_<env>.csv`` (the noise families, seeds 0-4). Each algorithm's tuned
variant for (env, pool, N) is its best mean over the tuning seeds (BC's is BC*); every comparison pairs seeds (the
same draw of trajectories) and gives the mean difference with its 95% Student-t interval.
"""

from __future__ import annotations

import argparse
import functools
import glob
import os
import re
from collections import defaultdict

import numpy as np

from benchmarks.stochastic import PROBES, best_variants, variants_for
from benchmarks.harness.report import paired_verdict
from benchmarks.harness.results import read_result_rows, write_text
from sb3_mbil.experts import EXPERTS

ALGOS = ("bc", "mbil", "mbil_c")


def noise_level(pool: str) -> float:
    """The noise level of a noise-family pool (``.../LunarLander-v3-noise0.05.npz`` -> 0.05)."""
    match = re.search(r"noise([0-9.]*[0-9])(\.npz)?$", pool)
    if match is None:
        raise ValueError(f"pool: expected a noise-family pool '<env>-noise<level>', found {pool!r}")
    return float(match.group(1))


@functools.lru_cache(maxsize=None)
def demonstrator_return(pool: str) -> float:
    """The noisy demonstrator's own mean return: its pool's mean episode return (nan where the pool cannot be read,
    e.g. a page built away from the repository)."""
    from sb3_mbil import load_demonstrations

    try:
        return float(np.mean(load_demonstrations(pool).episode_returns))
    except (OSError, ValueError):
        return float("nan")


LABEL = {"bc": "BC", "mbil": "MBIL", "mbil_c": "MBIL-C", "edm": "EDM", "avril": "AVRIL", "rcal": "RCAL",
         "dsfn": "DSFN", "iq_learn": "IQ-Learn", "valuedice": "ValueDICE", "odice": "ODICE"}


def _by_cell(rows):
    out: dict[tuple, dict[str, dict[int, float]]] = defaultdict(lambda: defaultdict(dict))
    for r in rows:
        out[(r["env"], r["pool"], int(r["n_trajectories"]))][r["variant"]][int(r["seed"])] = float(r["mean_return"])
    return out


def _complete(variants: dict, env: str, algo: str) -> bool:
    """Whether every configuration of ``algo`` ran on every tuning seed in this cell."""
    from benchmarks.stochastic import TUNING_SEEDS

    names = [v for v, spec in variants_for(env).items() if spec.algo == algo]
    return all(set(TUNING_SEEDS) <= set(variants.get(v, {})) for v in names)


def tuning_table(rows) -> tuple[str, dict]:
    """Markdown: each variant's mean over the tuning seeds per (env, pool, N); and the chosen variants (an algorithm
    is chosen for only once its whole budget has run in the cell)."""
    lines, chosen = [], {}
    for (env, pool, n), variants in sorted(_by_cell(rows).items()):
        best = {algo: name for algo, name in best_variants(rows, env, pool, n).items()
                if _complete(variants, env, algo)}
        chosen[(env, pool, n)] = best
        seeds = sorted({s for v in variants.values() for s in v})
        lines += [f"**{env}, pool {pool}, N = {n}** (tuning seeds {', '.join(map(str, seeds))})", "",
                  "| variant | mean return | per seed |", "|---|---|---|"]
        for name in sorted(variants, key=lambda v: (variants_for(env)[v].algo if v in variants_for(env) else v, v)):
            vals = variants[name]
            mark = " **(best)**" if name in best.values() else ""
            lines.append(f"| {name}{mark} | {np.mean(list(vals.values())):.1f} | "
                         f"{', '.join(f'{vals[s]:.0f}' for s in sorted(vals))} |")
        lines.append("")
    return "\n".join(lines), chosen


def seed_differences(vals: dict, ref: dict) -> np.ndarray:
    """The paired differences ``vals[s] - ref[s]`` (two {seed: return} maps) over the seeds both ran, in seed order."""
    return np.array([vals[s] - ref[s] for s in sorted(set(vals) & set(ref))], dtype=float)


def grid_table(rows, chosen) -> str:
    """Per (env, pool, N): BC, BC*, MBIL, MBIL*, MBIL-C, MBIL-C* and the baselines that ran (at their zoo entries)
    means, and each against BC* and BC, paired."""
    lines = []
    for (env, pool, n), variants in sorted(_by_cell(rows).items()):
        best = chosen.get((env, pool, n), {})
        columns = []
        for algo in ALGOS:
            columns.append((LABEL[algo], algo))
            if best.get(algo) and best[algo] != algo:
                columns.append((f"{LABEL[algo]}* ({best[algo]})", best[algo]))
        tuned = variants_for(env)
        columns += [(LABEL.get(name, name), name) for name in sorted(variants) if name not in tuned]
        reference = best.get("bc", "bc")
        lines += [f"**{env}, pool {pool}, N = {n}** (BC* = {reference})", "",
                  "| algorithm | seeds | mean return | minus BC*, paired (95% CI) | minus BC, paired (95% CI) |",
                  "|---|---|---|---|---|"]
        for label, name in columns:
            vals = variants.get(name, {})
            if not vals:
                lines.append(f"| {label} | 0 | not run yet | | |")
                continue
            row = [label, str(len(vals)), f"{np.mean(list(vals.values())):.1f}"]
            for ref in (reference, "bc"):
                d = seed_differences(vals, variants.get(ref, {}))
                row.append("" if name == ref or not len(d) else paired_verdict(d))
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
        # a probe outside the tuning grid (benchmarks.stochastic.PROBES) is also paired against the family
        for probe in sorted(set(variants) & set(PROBES)):
            pairs = [f"{label} minus it {paired_verdict(d)}" for label, name in columns if name.startswith("mbil")
                     for d in [seed_differences(variants.get(name, {}), variants[probe])] if len(d) >= 2]
            lines += [f"Against {probe} (outside the tuning grid, not BC*): {'; '.join(pairs)}.", ""]
    return "\n".join(lines)


def bc_star(chosen, env: str, pool: str, n: int) -> str:
    """BC* of a noise pool: BC's best variant in that pool's own tuning, or (until it has run) in the tuning on the
    same expert's sampled pool at the same N, as the crossover's runs chose it (``--tuning-pool``)."""
    own = chosen.get((env, pool, n), {}).get("bc")
    return own or chosen.get((env, f"{env}-sampled", n), {}).get("bc", "bc")


def crossover_table(rows, chosen_by_pool) -> str:
    """Per (env, N): return against the noise level for the demonstrator itself (its pool's mean return), BC, BC*,
    MBIL, MBIL-C (mean +- standard error over seeds, the number of seeds in brackets), and MBIL's and MBIL-C's paired
    differences against BC* and against BC. Any other variant run on a noise pool (a setting pushed after item 5's
    ablation, e.g. ``mbil_alpha3``) follows the table as one line, paired against the same BC* and BC."""
    cells = _by_cell(rows)
    lines = []
    for env, n in sorted({(e, n) for e, _, n in cells}):
        pools = sorted({p for e, p, m in cells if (e, m) == (env, n)}, key=noise_level)
        lines += [f"**{env}, N = {n}**", "", "| noise | demonstrator | BC | BC* | MBIL | MBIL-C | MBIL minus BC* | MBIL-C minus BC* "
                  "| MBIL minus BC | MBIL-C minus BC |", "|---|---|---|---|---|---|---|---|---|---|"]
        others = []
        for pool in pools:
            variants = cells[(env, pool, n)]
            star = bc_star(chosen_by_pool, env, pool, n)

            def cell(name):
                v = np.array(list(variants.get(name, {}).values()))
                return "" if len(v) == 0 else \
                    f"{v.mean():.1f} +- {v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0:.1f} ({len(v)})"

            def diff(name, ref):
                d = seed_differences(variants.get(name, {}), variants.get(ref, {}))
                return paired_verdict(d) if len(d) else ""

            shown = demonstrator_return(pool)
            lines.append(f"| {noise_level(pool):g} | {'' if np.isnan(shown) else f'{shown:.1f}'} | {cell('bc')} | {cell(star)} ({star}) | {cell('mbil')} | "
                         f"{cell('mbil_c')} | {diff('mbil', star)} | {diff('mbil_c', star)} | {diff('mbil', 'bc')} | "
                         f"{diff('mbil_c', 'bc')} |")
            others += [f"- `{name}` at noise {noise_level(pool):g}: {cell(name)}; minus BC* ({star}) {diff(name, star)}; "
                       f"minus BC {diff(name, 'bc')}" for name in sorted(set(variants) - {"bc", star, "mbil", "mbil_c"})]
        lines += ["", "Other settings run on these pools:", "", *others] if others else []
        lines.append("")
    return "\n".join(lines)


def plot_crossover(rows, chosen_by_pool, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sb3_mbil.common.files import atomic_write

    cells = _by_cell(rows)
    keys = sorted({(e, n) for e, _, n in cells})
    if not keys:
        return
    fig, axes = plt.subplots(1, len(keys), figsize=(4.5 * len(keys), 3.5), squeeze=False)
    for ax, (env, n) in zip(axes[0], keys):
        pools = sorted({p for e, p, m in cells if (e, m) == (env, n)}, key=noise_level)
        levels = [noise_level(p) for p in pools]
        for label, pick in (("BC", lambda p: "bc"), ("BC*", lambda p: bc_star(chosen_by_pool, env, p, n)),
                            ("MBIL", lambda p: "mbil"), ("MBIL-C", lambda p: "mbil_c")):
            means = [np.mean(list(cells[(env, p, n)].get(pick(p), {np.nan: np.nan}).values())) for p in pools]
            ax.plot(levels, means, marker="o", label=label)
        ax.plot(levels, [demonstrator_return(p) for p in pools], color="grey", linestyle="--", marker=".",
                label="demonstrator")
        ax.set_title(f"{env}, N = {n}")
        ax.set_xlabel("demonstrator noise (epsilon or sigma / range)")
        ax.set_ylabel("return")
    axes[0][0].legend()
    fig.tight_layout()
    with atomic_write(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def curve_label(name: str, chosen: dict, tuning_grid) -> str | None:
    """A Figure 4 curve's legend: BC, MBIL and MBIL-C at their zoo entries, each algorithm's tuned variant (BC*,
    MBIL*, MBIL-C*, ``chosen``: algorithm -> variant) and the baselines; None for the other variants of the grid."""
    for algo in ALGOS:
        if name == algo:
            return LABEL[algo]
        if name == chosen.get(algo):
            return f"{LABEL[algo]}* ({name})"
    return None if name in tuning_grid else LABEL.get(name, name)


def _mean_curves(rows) -> dict[tuple, dict[str, tuple[list, np.ndarray, int]]]:
    """Per (env, pool, N) and variant: the curve's updates, its mean over seeds (curves of the first's length) and
    the number of seeds."""
    import json

    cells: dict[tuple, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        cells[(r["env"], r["pool"], int(r["n_trajectories"]))][r["variant"]].append(json.loads(r["curve"]))
    out: dict[tuple, dict] = {}
    for key, by_variant in cells.items():
        for name, curves in by_variant.items():
            steps = [p[0] for p in curves[0]]
            mean = np.mean([[p[1] for p in c] for c in curves if len(c) == len(steps)], axis=0)
            out.setdefault(key, {})[name] = (steps, mean, len(curves))
    return out


def curve_summary(rows, chosen) -> str:
    """Per Figure 4 cell and drawn curve (:func:`curve_label`): the mean curve's peak and the update it is at, and
    its mean over the first and the last fifth of the updates (overfitting shows as a late mean below the early)."""
    lines = ["| cell | algorithm | seeds | peak of the mean curve (at update) | mean, first fifth | mean, last fifth |",
             "|---|---|---|---|---|---|"]
    for key, by_variant in sorted(_mean_curves(rows).items()):
        for name, (steps, mean, seeds) in sorted(by_variant.items()):
            label = curve_label(name, chosen.get(key, {}), variants_for(key[0]))
            if label is None:
                continue
            fifth = max(1, len(mean) // 5)
            lines.append(f"| {key[0]}, N = {key[2]} | {label} | {seeds} | {mean.max():.0f} ({steps[int(mean.argmax())]}) "
                         f"| {mean[:fifth].mean():.0f} | {mean[-fifth:].mean():.0f} |")
    return "\n".join(lines)


def plot_curves(rows, chosen, path: str) -> None:
    """Figure 4 on the sampled pools: per env, the mean learning curve over seeds of BC, BC*, MBIL, MBIL*, MBIL-C,
    MBIL-C* and the baselines (nothing written without rows)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sb3_mbil.common.files import atomic_write

    cells = _mean_curves(rows)
    if not cells:
        return
    keys = sorted(cells)
    fig, axes = plt.subplots(1, len(keys), figsize=(4.5 * len(keys), 3.5), squeeze=False)
    for ax, key in zip(axes[0], keys):
        for name, (steps, mean, seeds) in sorted(cells[key].items()):
            label = curve_label(name, chosen.get(key, {}), variants_for(key[0]))
            if label is None:
                continue  # the other tuned variants: the table has them
            ax.plot(steps, mean, label=f"{label} ({seeds})")
        ax.set_title(f"{key[0]}, {key[1]}, N = {key[2]}")
        ax.set_xlabel("gradient updates")
        ax.set_ylabel("return (10 episodes)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_write(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def load(folder: str = "results/stochastic") -> tuple[list, list, list]:
    """The tuning, grid and crossover rows of every env in ``folder``."""
    tuning = [r for f in sorted(glob.glob(os.path.join(folder, "tuning_*.csv"))) for r in read_result_rows(f)]
    grid = [r for f in sorted(glob.glob(os.path.join(folder, "*.csv")))
            if not os.path.basename(f).startswith(("tuning_", "crossover_", "curves_")) for r in read_result_rows(f)]
    cross = [r for f in sorted(glob.glob(os.path.join(folder, "crossover_*.csv"))) for r in read_result_rows(f)]
    return tuning, grid, cross


def load_curves(folder: str = "results/stochastic") -> list:
    """The Figure 4 rows (learning curves on the sampled pools) of every env in ``folder``: the ``curves_<env>.csv``
    runs, and the grid's runs that recorded their curve (the MuJoCo envs' one-trajectory grid is Figure 4)."""
    return [*(r for f in sorted(glob.glob(os.path.join(folder, "curves_*.csv"))) for r in read_result_rows(f)),
            *(r for r in load(folder)[1] if r.get("curve"))]


#: the study's envs (the seven benchmark envs, those with an expert), the N of its grids, the N of each noise
#: crossover (benchmarks/runs/stochastic.sh), and the envs whose Figure 4 is the grid's one-trajectory runs
STUDY_ENVS = tuple(EXPERTS)
GRID_N = (1, 3, 7, 10, 15)
CROSSOVER = {"LunarLander-v3": (1, 3), "Hopper-v4": (1,), "Walker2d-v4": (1,)}
MUJOCO = ("Hopper-v4", "HalfCheetah-v4", "Walker2d-v4", "Ant-v4")


def coverage_table(folder: str = "results/stochastic") -> str:
    """Markdown: for each env of the study, how many of each stage's planned runs have a row (done / planned; '?'
    where the plan waits on a tuning that has not finished), so that what ran on fewer seeds is stated."""
    from benchmarks.stochastic import TUNING_SEEDS, baseline_variants
    from sb3_mbil.common.demonstrations import available_pools

    tuning, grid, cross = load(folder)
    curves = load_curves(folder)
    chosen = tuning_table(tuning)[1]

    def count(rows, env, pool, n, names=None):
        return sum(1 for r in rows if (r["env"], r["pool"], int(r["n_trajectories"])) == (env, pool, n)
                   and (names is None or r["variant"] in names))

    def cell(done, planned):
        return f"{done}/{planned}"

    ns = ", ".join(map(str, GRID_N))
    lines = [f"| env | sampled pool | tuning (N = {ns}) | grid: BC, MBIL, MBIL-C and tuned (N = {ns}) | baselines "
             f"(N = {ns}) | Figure 4 | noise crossover |",
             "|---|---|---|---|---|---|---|"]
    for env in STUDY_ENVS:
        pool = f"{env}-sampled"
        if pool not in available_pools():
            lines.append(f"| {env} | not yet | | | | | |")
            continue
        n_tuning = len(variants_for(env)) * len(TUNING_SEEDS)
        tuned = []
        for n in GRID_N:
            best = chosen.get((env, pool, n), {})
            names = set(ALGOS) | {best[a] for a in ALGOS if a in best}
            planned = 10 * len(names) if len(best) == len(ALGOS) else "?"
            tuned.append(cell(count(grid, env, pool, n, names | set(variants_for(env))), planned))
        baselines = baseline_variants(env)
        mujoco = env in MUJOCO
        best1 = chosen.get((env, pool, 1), {})
        figure4 = 10 * (len(set(ALGOS) | set(best1.values())) + len(baselines)) if len(best1) == len(ALGOS) else "?"
        planned4 = set(ALGOS) | set(best1.values()) | set(baselines)  # a probe's curves (PROBES) are not planned
        done4 = sum(1 for r in curves if (r["env"], int(r["n_trajectories"])) == (env, 1) and r["variant"] in planned4)
        levels = sorted({r["pool"] for r in cross if r["env"] == env})

        def crossover(n):
            star = chosen.get((env, pool, n), {}).get("bc")
            names = {"bc", "mbil", "mbil_c", star}
            planned = 4 * 5 * len(names) if star else "?"
            return cell(sum(count(cross, env, p, n, names if star else None) for p in levels), planned)

        lines.append(" | ".join([
            f"| {env}", "shipped",
            " / ".join(cell(count(tuning, env, pool, n, set(variants_for(env))), n_tuning) for n in GRID_N),
            " / ".join(tuned),
            " / ".join(cell(count(grid, env, pool, n, set(baselines)), 10 * len(baselines)) for n in GRID_N),
            cell(done4, figure4) if mujoco else (f"{done4} (not asked)" if done4 else "not asked"),
            " / ".join(crossover(n) for n in CROSSOVER[env]) if env in CROSSOVER else "not asked"]) + " |")
    return "\n".join(lines)


#: the issue's little-data settings: the Figure 3 cells with N <= 3 on every env's sampled pool (on the MuJoCo envs
#: the N = 1 cell is Figure 4 too: the same runs), and the seeds a finished cell has
GOAL_N = (1, 3)
GOAL_SEEDS = 10
FAMILY = ("mbil", "mbil_c")


def _verdict(d) -> str:
    """above / below / level for paired differences (fewer than two: "too few seeds")."""
    from benchmarks.harness.report import paired_interval

    if len(d) < 2:
        return "too few seeds"
    lo, hi = paired_interval(np.asarray(d, dtype=float))
    return "above" if lo > 0 else ("below" if hi < 0 else "level")


def goal_table(grid_rows, chosen, envs=STUDY_ENVS) -> str:
    """Markdown: the goal's scoreboard. For each little-data setting (env x N in :data:`GOAL_N` on the sampled pool),
    each family member (MBIL, MBIL*, MBIL-C, MBIL-C*) against BC*, paired over the seeds both have; a setting counts
    as "above" where a member is above BC* and as "below" where a member is below it (both can hold), and as
    finished once BC* and every member have :data:`GOAL_SEEDS` seeds. The goal: above in at least half of the
    settings, below in none."""
    cells = _by_cell(grid_rows)
    head = ["| setting | BC* | " + " | ".join(f"{LABEL[a]} | {LABEL[a]}*" for a in FAMILY) + " | setting counts as |",
            "|---|---|" + "---|---|" * len(FAMILY) + "---|"]
    lines, above, above_finished, below, finished, planned = [], 0, 0, 0, 0, 0
    for env in envs:
        pool = f"{env}-sampled"
        for n in GOAL_N:
            planned += 1
            label = f"{env}, N = {n}" + (" (Figure 4 too)" if env in MUJOCO and n == 1 else "")
            best = chosen.get((env, pool, n), {})
            variants = cells.get((env, pool, n), {})
            if "bc" not in best or not all(a in best for a in FAMILY):
                lines.append(f"| {label} | tuning not finished |" + " |" * (2 * len(FAMILY) + 1))
                continue
            ref = variants.get(best["bc"], {})
            runs = [variants.get(name, {}) for name in {best["bc"], *FAMILY, *(best[a] for a in FAMILY)}]
            complete = all(len(vals) >= GOAL_SEEDS for vals in runs)

            def against_bc_star(name: str) -> str:
                d = seed_differences(variants.get(name, {}), ref)
                return _verdict(d) if len(d) else "not run yet"

            words = []
            for algo in FAMILY:
                words.append(against_bc_star(algo))
                words.append(f"= {LABEL[algo]} (its zoo entry is the best)" if best[algo] == algo
                             else against_bc_star(best[algo]))
            is_above = "above" in words
            is_below = "below" in words
            above += is_above
            above_finished += is_above and complete
            below += is_below
            finished += complete
            if is_above or is_below:
                status = " and ".join(w for w, on in (("above", is_above), ("below", is_below)) if on)
            else:
                status = "level" if any(w == "level" for w in words) else "not run yet"
            status += "" if complete else " (not finished)"
            lines.append(f"| {label} | {best['bc']} ({len(ref)} seeds) | " + " | ".join(words) + f" | {status} |")
    if below:
        verdict = "missed (a setting is below BC*)"
    elif above * 2 >= planned and finished == planned:
        verdict = "met"
    elif (above_finished + planned - finished) * 2 < planned:
        verdict = "missed (too few settings can still be above BC*)"
    else:
        verdict = "not decided yet"
    summary = (f"Settings: {planned}; finished: {finished}; above BC*: {above}; below BC*: {below}. "
               f"The goal (above in at least {-(-planned // 2)}, below in none): **{verdict}**.")
    return "\n".join([summary, "", *head, *lines])


def sections(folder: str = "results/stochastic", level: str = "##", figure: str = "stochastic_crossover.png",
             tuning_table_too: bool = True) -> str:
    """The study's tables as Markdown sections at heading ``level`` (the grids, the crossover and its figure at the
    relative path ``figure``, and the tuning)."""
    tuning, grid, cross = load(folder)
    tuned, chosen = tuning_table(tuning)
    commits = sorted({r["commit"] for r in tuning + grid + cross})
    text = ["Rows made by `python -m benchmarks.stochastic` (commands in `benchmarks/runs/stochastic*.sh`) in "
            f"`{folder}/`; commits of the rows: {', '.join(commits)}. Returns are means over each run's evaluation "
            "episodes (100 for tuning and the noise crossover, 300 for the grids); intervals are 95% Student-t "
            "intervals of paired differences over seeds (the same draw of trajectories for both). 'above'/'below': "
            "the interval excludes zero. BC*, MBIL* and MBIL-C*: each algorithm's best variant on the tuning seeds.", "",
            f"{level} Stochastic demonstrators: what has run", "",
            "Runs with a row, against the runs the protocol plans (tuning: every configuration on 3 tuning seeds; "
            "grids and baselines: 10 seeds; Figure 4, the MuJoCo envs: the grid's one-trajectory runs with their "
            "curves; crossover: 4 noise levels x BC, BC*, MBIL, MBIL-C x 5 seeds; each N separated by '/'; '?': waits "
            "on the tuning of that N).", "",
            coverage_table(folder), "",
            f"{level} Stochastic demonstrators: the issue's goal, setting by setting", "",
            "Each little-data setting (Figure 3 on the sampled pool, N = 1 and 3; on the MuJoCo envs the N = 1 cell is "
            "Figure 4's runs too), each MBIL-family member against BC*, paired over seeds 0-9 (95% intervals; the "
            "numbers are in the grids below).", "",
            goal_table(grid, chosen), "",
            f"{level} Stochastic demonstrators: the grids (seeds 0-9)", "", grid_table(grid, chosen), "",
            f"{level} Stochastic demonstrators: Figure 4, one trajectory", "",
            "The final policy's return of the runs that recorded their learning curve (every 500 updates on 10 "
            "episodes): on the MuJoCo envs the grid's one-trajectory runs (seeds 0-9, 300 episodes, in "
            "`results/stochastic/<env>.csv`), elsewhere `results/stochastic/curves_<env>.csv` (seeds 0-4, 100 "
            "episodes).", "",
            grid_table(load_curves(folder), chosen) or "Not run yet.", "",
            *(["The curves' shape (the mean over seeds of each point's 10 episodes):", "",
               curve_summary(load_curves(folder), chosen), ""] if load_curves(folder) else []),
            *([f"![curves]({os.path.join(os.path.dirname(figure), 'stochastic_curves.png')})", ""]
              if load_curves(folder) else []),
            f"{level} Stochastic demonstrators: the noise crossover (seeds 0-4)", "", crossover_table(cross, chosen), "",
            f"![crossover]({figure})", ""]
    if tuning_table_too:
        text += [f"{level} Stochastic demonstrators: tuning (seeds 100-102; the one budget of every algorithm)", "", tuned]
    return "\n".join(text)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--folder", default="results/stochastic")
    parser.add_argument("--out", default="results/stochastic.md")
    args = parser.parse_args(argv)
    text = ["# Stochastic demonstrators: results", "",
            "Generated by `python -m benchmarks.stochastic_report` from the CSVs in `results/stochastic/`.", "",
            sections(args.folder)]
    write_text(args.out, "\n".join(text) + "\n")
    tuning, _, cross = load(args.folder)
    chosen = tuning_table(tuning)[1]
    folder = os.path.dirname(args.out) or "."
    plot_crossover(cross, chosen, os.path.join(folder, "stochastic_crossover.png"))
    plot_curves(load_curves(args.folder), chosen, os.path.join(folder, "stochastic_curves.png"))


if __name__ == "__main__":
    main()
