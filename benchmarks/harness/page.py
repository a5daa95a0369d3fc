"""BENCHMARKS.md from the result files: every table of the page is computed here from the committed CSVs, so the
page is regenerated, never edited (``python -m benchmarks.make_benchmarks``). The prose around the tables lives in
``docs/benchmarks_notes.md`` and is included as written."""

from __future__ import annotations

import os
import re
from collections import defaultdict
from pathlib import Path

import numpy as np

from benchmarks.harness.report import (
    RANDOM_RETURN,
    aggregate,
    expert_returns,
    paired_interval,
    probability_of_improvement,
    read_rows,
    table,
)

# The published classic-control baselines: the figure of CKIL (the same authors, protocol and baseline codes as MBIL's
# Figure 3; experts about -83 / 500 / 271 on Acrobot / CartPole / LunarLander-v2), read off
# the figure (about +-10), N = 1, 3, 7, 10, 15; None where the figure gives no value. "< -250" is entered as -250 and
# marked as a bound.
PUBLISHED_N = (1, 3, 7, 10, 15)
PUBLISHED_EXPERT = {"Acrobot-v1": -83.0, "CartPole-v1": 500.0, "LunarLander-v3": 271.0}
PUBLISHED = {
    "Acrobot-v1": {"bc": (-159, -97, -94, -94, -94), "valuedice": (-141, -108, -107, -101, -99),
                   "rcal": (-285, None, None, None, None), "edm": (-124, None, None, None, None),
                   "avril": (-292, -149, -99, -93, -90), "dsfn": (-415, -358, -265, -226, -147),
                   "iq_learn": (-88, -88, -89, -88, -89)},
    "CartPole-v1": {"bc": (170, 312, 411, 468, 500), "valuedice": (183, 372, 434, 483, 500),
                    "rcal": (136, 300, 450, 495, 500), "edm": (226, 450, 491, 500, 500),
                    "avril": (377, 430, 422, 427, 500), "dsfn": (174, 202, 272, 292, 336),
                    "iq_learn": (420, 460, 500, 500, 500)},
    "LunarLander-v3": {"bc": (-34, 175, 227, 242, 248), "valuedice": (-250, -175, -156, -151, -153),
                       "rcal": (-55, 177, 211, 237, 248), "edm": (6, 190, 240, 245, 248),
                       "avril": (-117, 102, 204, 225, 239), "dsfn": (-250, 52, 112, 191, 210),
                       "iq_learn": (131, 211, 250, 248, 248)},
}
BOUNDS = {("LunarLander-v3", "valuedice", 1), ("LunarLander-v3", "dsfn", 1)}  # "< -250" on the figure


def published_value(env: str, algo: str, n: int) -> float | None:
    values = PUBLISHED.get(env, {}).get(algo)
    if values is None or n not in PUBLISHED_N:
        return None
    return values[PUBLISHED_N.index(n)]


def normalised(value: float, env: str, expert: float) -> float:
    return (value - RANDOM_RETURN[env]) / (expert - RANDOM_RETURN[env])


def paired_ci_table(rows, reference: str = "bc") -> str:
    """Every algorithm against ``reference`` per (env, N), on the seeds both ran: the mean difference, its paired
    95% confidence interval (Student's t over seeds, scipy) and how many seeds are below."""
    runs = defaultdict(dict)
    for r in rows:
        runs[(r["env"], r["n_trajectories"], r["seed"])][r["algo"]] = r["mean_return"]
    algos = sorted({r["algo"] for r in rows} - {reference})
    cells = sorted({(e, n) for (e, n, _) in runs})
    lines = [f"| algo | env | N | seeds | mean difference to {reference} | paired 95% CI | below on | verdict |",
             "|---|---|---|---|---|---|---|---|"]
    for algo in algos:
        for env, n in cells:
            d = np.array([v[algo] - v[reference] for (e, nn, _), v in sorted(runs.items())
                          if (e, nn) == (env, n) and algo in v and reference in v], dtype=float)
            if len(d) < 2:
                continue
            lo, hi = paired_interval(d)
            verdict = "below" if hi < 0 else "above" if lo > 0 else "level"
            lines.append(f"| {algo} | {env} | {n} | {len(d)} | {d.mean():+.1f} | [{lo:+.1f}, {hi:+.1f}] | "
                         f"{int((d < 0).sum())} of {len(d)} | {verdict} |")
    return "\n".join(lines)


def returned_iterations(rows) -> str:
    """DSFN's returned policy per (env, N): how many seeds returned each pi_i (``returned_iteration``; 0 is its
    warm-start classifier, a BC policy), and how many rows predate the column. Empty without DSFN rows."""
    counts = defaultdict(lambda: defaultdict(int))
    for r in rows:
        if r["algo"] == "dsfn":
            value = str(r.get("returned_iteration", "") or "").strip()
            counts[(r["env"], r["n_trajectories"])][int(float(value)) if value else None] += 1
    if not counts:
        return ""
    lines = ["### DSFN: the iteration it returned", "",
             "DSFN returns the pi_i (i = 0: its warm-start classifier) whose feature expectations were closest to "
             "the expert's; seeds per returned i, and the rows that predate the `returned_iteration` column.", "",
             "| env | N | seeds per returned i | not recorded |", "|---|---|---|---|"]
    for (env, n), c in sorted(counts.items()):
        returned = ", ".join(f"i = {i}: {k}" for i, k in sorted((i, k) for i, k in c.items() if i is not None))
        lines.append(f"| {env} | {n} | {returned or '-'} | {c.get(None, 0)} |")
    return "\n".join(lines)


def aggregates(rows, reps: int) -> str:
    lines = ["Normalised score (0 = random, 1 = the pool's expert) over the (env, N) cells every algorithm ran; 95% "
             "stratified bootstrap intervals (rliable):", ""]
    for algo, s in aggregate(rows, reps=reps).items():
        lines.append(f"- {algo}: IQM {s['iqm'][0]:.3f} [{s['iqm'][1]:.3f}, {s['iqm'][2]:.3f}], "
                     f"mean {s['mean'][0]:.3f} [{s['mean'][1]:.3f}, {s['mean'][2]:.3f}]")
    improvement = probability_of_improvement(rows, "bc", reps=reps)
    if improvement:
        lines += ["", "Probability of improvement over BC (rliable: the chance that a run of the algorithm beats a run "
                  "of BC on the same (env, N) cell, averaged over the cells; 0.5 = level), 95% interval:", ""]
        lines += [f"- {algo}: {p:.3f} [{lo:.3f}, {hi:.3f}]" for algo, (p, lo, hi) in improvement.items()]
    return "\n".join(lines)


def published_check(rows) -> str:
    """Ours on the published protocol beside the published values, both normalised (each with its own expert: ours
    the pool's, theirs about -83 / 500 / 271), and whether ours lands within 0.15.

    "beyond BC" separates what an algorithm adds from what its data gives: its gap to the published value minus
    BC's gap in the same cell, ``(ours - our BC) - (published - published BC)`` in normalised units, with our BC on
    the same seeds. Near zero, the algorithm sits where the published one does relative to BC, and the cell's gap
    is one that BC shares (the expert, the env version, the kept states); far from zero, the gap is the
    algorithm's own. "our 95% CI" is Student's t interval of our mean over seeds (normalised): with one trajectory
    the seeds spread so widely that a cell can be off by more than 0.15 and still hold the published value."""
    from scipy import stats

    g = defaultdict(dict)
    for r in rows:
        g[(r["algo"], r["env"], r["n_trajectories"])][r["seed"]] = r["mean_return"]
    expert = expert_returns(sorted({r["env"] for r in rows}), rows)
    lines = ["| algo | env | N | ours (seeds) | published | ours normalised | published normalised | gap | beyond BC "
             "| our 95% CI | within 0.15 |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    within = total = own = off = inside = 0
    for (algo, env, n), by_seed in sorted(g.items()):
        pub = published_value(env, algo, n)
        if pub is None:
            continue
        ours = float(np.mean(list(by_seed.values())))
        a, b = normalised(ours, env, expert[env]), normalised(pub, env, PUBLISHED_EXPERT[env])
        bound = (env, algo, n) in BOUNDS
        ok = (a <= b + 0.15) if bound else abs(a - b) <= 0.15
        within += ok
        total += 1
        beyond = ""
        bc_seeds, pub_bc = g.get(("bc", env, n), {}), published_value(env, "bc", n)
        if algo != "bc" and pub_bc is not None and not bound and set(by_seed) <= set(bc_seeds):
            ours_bc = float(np.mean([bc_seeds[k] for k in by_seed]))
            rel = (a - normalised(ours_bc, env, expert[env])) - (b - normalised(pub_bc, env, PUBLISHED_EXPERT[env]))
            beyond = f"{rel:+.2f}"
            if not ok:
                off += 1
                own += abs(rel) > 0.15
        ci = ""
        if len(by_seed) > 1:
            v = np.array([normalised(x, env, expert[env]) for x in by_seed.values()])
            half = 0.0 if np.allclose(v, v[0]) else stats.t.ppf(0.975, len(v) - 1) * v.std(ddof=1) / np.sqrt(len(v))
            ci = f"[{a - half:.2f}, {a + half:.2f}]"
            if not ok and ((a - half <= b) if bound else (a - half <= b <= a + half)):
                inside += 1
        lines.append(f"| {algo} | {env} | {n} | {ours:.1f} ({len(by_seed)}) | {'< ' if bound else ''}{pub} | {a:.2f} | "
                     f"{'< ' if bound else ''}{b:.2f} | {a - b:+.2f} | {beyond} | {ci} | {'yes' if ok else 'no'} |")
    lines.append(f"\nWithin 0.15 of the published value: {within} of {total} cells.")
    if off:
        lines.append(f"Of the {off} cells off by more (BC's own excluded), {own} are also more than 0.15 off beyond BC "
                     f"(the algorithm's own gap); in the other {off - own} BC is off by about as much.")
    if within < total:
        lines.append(f"Of the {total - within} cells off by more than 0.15, {inside} hold the published value inside our "
                     f"95% interval.")
    return "\n".join(lines)


def control_section(published_path: str, control_path: str) -> str:
    """The published protocol against its control, per env and N on the shared seeds: BC, MBIL and MBIL-C on the kept
    steps, BC and MBIL-C also given each kept step's next step as a label, and MBIL's paired difference to both BCs
    (95% t intervals over seeds)."""
    title = "## The published protocol against its control"
    if not (os.path.isfile(published_path) and os.path.isfile(control_path)):
        return f"{title}\n\nNo results yet (`{published_path}` and `{control_path}`).\n"
    runs: dict = defaultdict(dict)
    for tag, path in (("", published_path), (" + next", control_path)):
        for r in read_rows(path):
            runs[(r["env"], r["n_trajectories"], r["seed"])][r["algo"] + tag] = r["mean_return"]
    cols = ["bc", "mbil", "mbil_c", "bc + next", "mbil_c + next"]
    lines = [title, "", f"From `{published_path}` and `{control_path}`: mean return over the seeds every column ran; "
             "\"+ next\": the kept steps and each one's next step, all as labelled pairs (`--protocol published_next`).", "",
             "| env | N | seeds | " + " | ".join(cols) + " | mbil - bc [95% CI] | mbil - (bc + next) [95% CI] |",
             "|---|---|---|" + "---|" * (len(cols) + 2)]
    for env, n in sorted({(e, n) for e, n, _ in runs}):
        seeds = [s for (e, nn, s), v in sorted(runs.items()) if (e, nn) == (env, n) and all(c in v for c in cols)]
        if len(seeds) < 2:
            continue
        v = {c: np.array([runs[(env, n, s)][c] for s in seeds]) for c in cols}
        diffs = []
        for ref in ("bc", "bc + next"):
            d = v["mbil"] - v[ref]
            lo, hi = paired_interval(d)
            diffs.append(f"{d.mean():+.1f} [{lo:+.1f}, {hi:+.1f}]")
        lines.append(f"| {env} | {n} | {len(seeds)} | " + " | ".join(f"{v[c].mean():.1f}" for c in cols) + " | "
                     + " | ".join(diffs) + " |")
    return "\n".join(lines) + "\n"


def figure(rows, path: str, title: str, plots: bool) -> str:
    """The plot of a section: written beside its CSV (``results/x.csv`` -> ``results/x.png``) when ``plots``, and
    linked from the page."""
    png = str(Path(path).with_suffix(".png"))
    if plots:
        import matplotlib.pyplot as plt

        if "gradient_step" in rows[0]:  # learning curves (Figure 4 layout), else the Figure 3 grid
            from benchmarks.harness.curves import plot_curves, pool_experts

            fig = plot_curves(rows, png, expert=pool_experts(rows))
        else:
            from benchmarks.harness.report import plot

            fig = plot(rows, png)
        plt.close(fig)
    return f"![{title}]({png})"


def grid_section(title: str, path: str, reps: int, intro: str = "", published: bool = False,
                 anchors: bool = True, plots: bool = False) -> str:
    if not os.path.isfile(path):
        return f"## {title}\n\nNo results yet (`{path}` does not exist).\n"
    rows = read_rows(path)
    commits = ", ".join(sorted({r.get("commit", "") for r in rows}))
    parts = [f"## {title}", "", intro, "", figure(rows, path, title, plots), "",
             f"{len(rows)} runs from `{path}` (commits: {commits}); mean +- std over seeds (number of seeds), each seed "
             "the mean return of its evaluation episodes.", table(rows, anchors=anchors and not published), "",
             "### Every algorithm against BC, paired (the same draws and seeds)", "", paired_ci_table(rows), "",
             aggregates(rows, reps)]
    returned = returned_iterations(rows)
    if returned:
        parts += ["", returned]
    if published:
        parts += ["", "### Against the published values (CKIL's figure, the MBIL paper's protocol and baseline codes)", "",
                  "\"beyond BC\" is the algorithm's gap minus BC's in the same cell (our BC on the same seeds, in "
                  "normalised units): near zero, the algorithm stands where the published one does relative to BC, "
                  "and the gap is one that BC shares (the expert, the env version, the kept states); far from zero, "
                  "the gap is the algorithm's own. \"our 95% CI\" is Student's t interval of our mean over seeds "
                  "(normalised).", "", published_check(rows)]
    return "\n".join(parts) + "\n"


def curves_section(title: str, path: str, intro: str = "", plots: bool = False) -> str:
    from benchmarks.harness.curves import curve_table, paired_table, pool_experts
    from benchmarks.harness.results import read_result_rows

    if not os.path.isfile(path):
        return f"## {title}\n\nNo results yet (`{path}` does not exist).\n"
    rows = read_result_rows(path)
    commits = ", ".join(sorted({r.get("commit", "") for r in rows}))
    return "\n".join([f"## {title}", "", intro, "", figure(rows, path, title, plots), "",
                      f"From `{path}` (commits: {commits}).", "",
                      curve_table(rows, pool_experts(rows), last=10), "", paired_table(rows, "bc", last=10)]) + "\n"


def peers_section(path: str, title: str = "## Peers: d3rlpy's BC beside ours", intro: str = "") -> str:
    from benchmarks.harness.results import read_result_rows

    if not os.path.isfile(path):
        return f"{title}\n\nNo results yet (`{path}` does not exist; `python -m benchmarks.peers.compare_d3rlpy`).\n"
    rows = read_result_rows(path)
    g = defaultdict(lambda: defaultdict(list))
    for r in rows:
        g[(r["env"], int(r["n_trajectories"]))][r["library"]].append(
            (int(r["seed"]), float(r["mean_return"]), float(r["seconds_per_update"])))
    lines = [title, "", *([intro, ""] if intro else []), f"From `{path}` (commits: {', '.join(sorted({r['commit'] for r in rows}))}): the same draws, "
             "the same evaluation episodes, our BC's zoo settings for both; the speed ratio is d3rlpy's time per update "
             "over ours, measured in the same run; the paired difference is the library's return minus ours on the "
             "same seeds, with its 95% interval (Student's t over seeds) and the seeds where it is above ours.", "",
             "| env | N | library | mean return (seeds) | median ms / update | median speed ratio | minus ours, paired |",
             "|---|---|---|---|---|---|---|"]
    for (env, n), libs in sorted(g.items()):
        ours = {s: t for s, _, t in libs.get("sb3_mbil", [])}
        ours_return = {s: v for s, v, _ in libs.get("sb3_mbil", [])}
        for lib, vals in sorted(libs.items()):
            ratios = [t / ours[s] for s, _, t in vals if s in ours and ours[s] > 0]
            d = np.array([v - ours_return[s] for s, v, _ in vals if s in ours_return])
            lines.append(f"| {env} | {n} | {lib} | {np.mean([v for _, v, _ in vals]):.1f} ({len(vals)}) | "
                         f"{1e3 * np.median([t for _, _, t in vals]):.2f} | {np.median(ratios):.2f} | "
                         f"{'-' if lib == 'sb3_mbil' else paired_difference(d)} |")
    return "\n".join(lines) + "\n"


def paired_difference(d: np.ndarray) -> str:
    """Mean of paired differences, its 95% t interval over seeds and how many are above zero."""
    if len(d) < 2:
        return f"{d.mean():+.1f} (one seed)" if len(d) else "-"
    lo, hi = paired_interval(d)
    return f"{d.mean():+.1f} [{lo:+.1f}, {hi:+.1f}], above on {int((d > 0).sum())} of {len(d)}"


def stochastic_section(folder: str) -> str:
    """The stochastic-demonstrator study (sampled and noisy pools; ``benchmarks.stochastic_report``)."""
    from benchmarks.stochastic_report import sections

    if not os.path.isdir(folder):
        return ""
    return ("## Stochastic demonstrators\n\nThe experts' own sampled actions and noisy demonstrators, every algorithm "
            "against BC at its best (BC*) with one tuning budget; protocol and findings: "
            "[docs/stochastic.md](docs/stochastic.md).\n\n" + sections(folder, level="###",
                                                                         figure="results/stochastic_crossover.png",
                                                                         tuning_table_too=False) + "\n")


def benchmarks_page(reps: int = 2000, notes: str | Path = "docs/benchmarks_notes.md", plots: bool = True) -> str:
    """The whole BENCHMARKS.md; with ``plots``, each section's figure is written beside its CSV."""
    from benchmarks.harness.grid import git_commit

    notes_text = Path(notes).read_text() if os.path.isfile(notes) else ""
    # the notes' relative links are written from their own folder: re-root them at the page's (the repository's top)
    folder = os.path.dirname(os.path.normpath(notes))
    notes_text = re.sub(r"\]\((?![a-z]+:|#|/)([^)\s]+)\)",
                        lambda m: f"]({os.path.normpath(os.path.join(folder, m.group(1)))})", notes_text)
    head = ("# Benchmarks\n\nGenerated by `python -m benchmarks.make_benchmarks --overwrite` at commit "
            f"{git_commit()} from the result files named in each section; the prose is `docs/benchmarks_notes.md`. "
            "Protocol: N expert trajectories drawn from a pool with the run's seed (`Demonstrations.sample(N, seed)`), "
            "seeds 0-9 unless said otherwise (tuning used seeds >= 100), the deterministic policy scored on 300 "
            "evaluation episodes (classic control) or every 500 updates on 10 episodes (MuJoCo).\n")
    sections = [
        head, notes_text,
        grid_section("Figure 3: full trajectories, the first expert", "results/classic_control.csv", reps,
                     "Every step of each drawn trajectory (`--protocol full`), the shipped pools.", plots=plots),
        grid_section("Figure 3: the published protocol", "results/classic_control_published.csv", reps,
                     "Each baseline's own code's subsampling (`--protocol published`, `benchmarks.harness.protocol`): "
                     "every 20th step for BC, EDM, RCAL, MBIL and MBIL-C, IQ-Learn every 20th step "
                     "on CartPole and every 5th on Acrobot and LunarLander, AVRIL, ValueDICE and DSFN full "
                     "trajectories; 5 seeds.", published=True, plots=plots),
        grid_section("Figure 3: the published protocol, ValueDICE on every 20th step (superseded)",
                     "results/classic_control_published_valuedice_every20.csv", reps,
                     "ValueDICE's earlier rows, on BC's every-20th rate; the published comparison ran the "
                     "google-research value_dice code (CKIL's appendix C.1), which keeps every step, so its "
                     "published-protocol rows above are on whole trajectories.", anchors=False, plots=plots),
        grid_section("Figure 3: the published protocol, DSFN's shorter schedule on LunarLander-v3 (superseded)",
                     "results/classic_control_published_dsfn_warm.csv", reps,
                     "DSFN's earlier LunarLander-v3 rows, with the reference warm start and ten times shorter "
                     "iterations (135 000 steps). That schedule did not return the reference schedule's policy on a "
                     "tuning draw with seven trajectories, so LunarLander-v3 is back on the reference schedule "
                     "(900 000 steps) and its rows above are rerun.", anchors=False, plots=plots),
        grid_section("Figure 3: the published protocol from each trajectory's first step (superseded)",
                     "results/classic_control_published_start0.csv", reps,
                     "The rerun's first rows, every trajectory subsampled from step 0 (IQ-Learn's code) instead of from "
                     "its own random step (the GAIL codes'): on Acrobot-v1 every algorithm that keeps every 20th step "
                     "stays at -500.", anchors=False, plots=plots),
        grid_section("Figure 3: full trajectories, the second expert", "results/classic_control_second.csv", reps,
                     "Each env's second expert pool (`--second-expert`: PPO CartPole-v1, DQN Acrobot-v1, DQN "
                     "LunarLander-v3), N = 1 and 3.", anchors=False, plots=plots),
        grid_section("Figure 3 with ReLU hidden layers: full trajectories, the first expert",
                     "results/classic_control_relu.csv", reps,
                     "The earlier runs of BC, MBIL and MBIL-C, before the zoo's classic-control entries moved to the "
                     "published comparison's ELU hidden layers.", plots=plots),
        grid_section("Figure 3 with ReLU hidden layers: the published protocol",
                     "results/classic_control_published_relu.csv", reps,
                     "As above, every 20th step of each trajectory; 5 seeds.", published=True, plots=plots),
        control_section("results/classic_control_published_relu.csv",
                        "results/classic_control_published_next_relu.csv"),
        grid_section("Figure 3 with ReLU hidden layers: the published protocol, a control",
                     "results/classic_control_published_next_relu.csv", reps,
                     "`--protocol published_next`: each kept step and its next step as labelled pairs, so that BC sees "
                     "the labels MBIL gets from the successors (s', a') of the published protocol.", anchors=False, plots=plots),
        grid_section("Figure 3 with ReLU hidden layers: full trajectories, the second expert",
                     "results/classic_control_second_relu.csv", reps,
                     "As above, on each env's second expert pool, N = 1 and 3.", anchors=False, plots=plots),
        curves_section("Figure 4: MuJoCo, one trajectory, every Box-capable algorithm", "results/figure4.csv",
                       "`bash benchmarks/runs/run_figure4.sh`: each algorithm's zoo settings (BC, MBIL and MBIL-C on the "
                       "bounded-mean policy with a linearly decaying learning rate), 50 000 updates, seeds 0-4. "
                       "Walker2d-v4 and Ant-v4 on their retrained experts' pools (issue 19).", plots=plots),
        curves_section("Figure 4, the first backbone: MBIL and BC", "results/mujoco.csv",
                       "The earlier runs: a linear-output Gaussian mean and a constant learning rate, the previous "
                       "expert pools of Walker2d-v4 and Ant-v4.", plots=plots),
        stochastic_section("results/stochastic"),
        peers_section("results/peers.csv"),
        peers_section("results/peers_relu.csv", "## Peers with ReLU hidden layers: classic control",
                      "The earlier classic-control pairs: both libraries with ReLU hidden layers, before our BC's zoo "
                      "entries moved to ELU (d3rlpy offers no ELU; `benchmarks/peers/d3rlpy_train.py` adds it)."),
    ]
    return "\n".join(s for s in sections if s) + "\n"
