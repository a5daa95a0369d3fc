"""MBIL's and MBIL-C's density fits at smaller budgets: does a cheaper fit of P(a' | s, a, s') change the return?

Each variant is MBIL with its zoo settings and a fit budget; the seeds of a cell train in lockstep (the same runs as
separate ones); one row per (variant, pool, N, seed) with the return (100 episodes), the fit's CPU seconds, its chosen
noise and steps, its held-out log-likelihood and the mean balance target. Tuning seeds (>= 100) only: the question is
which default to ship. Rerun to resume (finished rows are skipped).

    python -m benchmarks.fit_budget --env LunarLander-v3 --pools LunarLander-v3 LunarLander-v3-sampled \\
        --n-trajectories 1 15 --seeds 100-109 --csv results/fit_budget.csv
    python -m benchmarks.fit_budget --variants mbil_c mbil_c_fit300 --csv results/fit_budget.csv
    python -m benchmarks.fit_budget --summary results/fit_budget.csv
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import torch as th

from benchmarks.harness.cli import check_tuning_seeds, probe_parser, run
from benchmarks.harness.grid import git_commit
from benchmarks.harness.report import paired_verdict
from benchmarks.harness.results import append_rows, read_result_rows
from benchmarks.stochastic import Variant, _row, draw, pending_cells, train_variant_lockstep

#: the fit budgets compared, each paired against its algorithm's reference ("mbil", "mbil_c"): MBIL's P at up to
#: 1 000 steps per noise level, then a refit on all the tuples for the chosen steps (MBIL's default until commit
#: d854302, whose rows record it as settings {}; the default is now flow_max_steps="auto", 300 steps for a Discrete
#: P), and MBIL-C's default of up to 2 000 steps
BUDGETS = {
    "mbil": {"flow_max_steps": 1000},
    "mbil_fit300": {"flow_max_steps": 300},
    "mbil_fit300_norefit": {"flow_max_steps": 300, "flow_refit": False},
    "mbil_norefit": {"flow_max_steps": 1000, "flow_refit": False},
    "mbil_c": {"model_max_steps": 2000},
    "mbil_c_fit300": {"model_max_steps": 300},
}


def _algo(name: str) -> str:
    return "mbil_c" if name.startswith("mbil_c") else "mbil"
COLUMNS = ["variant", "env", "pool", "n_trajectories", "seed", "mean_return", "std_return", "n_episodes", "fit_seconds",
           "fit_noise", "fit_steps", "p_heldout_ll", "target_mean", "settings", "commit"]


def run_budgets(env_id: str, pools: list[str], n_trajectories: list[int], seeds: list[int], variants: list[str],
                n_episodes: int, csv_path: str) -> None:
    th.set_num_threads(1)
    commit = git_commit()
    for pool, n, name, todo in pending_cells(csv_path, env_id, pools, n_trajectories, variants, seeds):
        variant = Variant(_algo(name), BUDGETS[name])
        trained = train_variant_lockstep(variant, env_id, {s: draw(env_id, pool, n, s) for s in todo})
        for s in todo:
            model, _ = trained[s]
            row = _row(name, variant, env_id, pool, n, s, model, None, 0.0, n_episodes, commit)
            report = model.flow_report if _algo(name) == "mbil" else model.model_report
            row.update(fit_seconds=round(report["fit_seconds"], 2), fit_noise=report["next_action"]["noise"],
                       fit_steps=report["next_action"]["steps"],
                       p_heldout_ll=round(report["next_action"]["heldout_ll"], 4),
                       target_mean=round(float(model.tuple_targets().mean()), 4) if _algo(name) == "mbil" else "")
            row = {k: v for k, v in row.items() if k in COLUMNS}
            append_rows(csv_path, [row], COLUMNS)  # each row as its evaluation ends
            print(f"{name} {pool} N={n} seed={s}: {row['mean_return']:.1f} (fit {row['fit_seconds']} s, "
                  f"{row['fit_steps']} steps)", flush=True)


def summary(csv_path: str) -> str:
    """Markdown: per (pool, N), each budget's mean return and fit seconds, and its return minus the default's,
    paired over seeds."""
    cells: dict[tuple, dict[str, dict[int, dict]]] = defaultdict(lambda: defaultdict(dict))
    for r in read_result_rows(csv_path):
        cells[(r["pool"], int(r["n_trajectories"]))][r["variant"]][int(r["seed"])] = r
    lines = ["| pool | N | fit budget | seeds | mean return | fit CPU s (median) | held-out LL | minus the reference (mbil, mbil_c), "
             "paired (95% CI) |", "|---|---|---|---|---|---|---|---|"]
    for (pool, n), variants in sorted(cells.items()):
        for name in [v for v in BUDGETS if v in variants]:
            base = variants.get(_algo(name), {})
            rows = variants[name]
            ret = np.mean([float(r["mean_return"]) for r in rows.values()])
            fit = np.median([float(r["fit_seconds"]) for r in rows.values()])
            ll = np.mean([float(r["p_heldout_ll"]) for r in rows.values()])
            common = sorted(set(rows) & set(base))
            diff = ""
            if name != _algo(name) and len(common) >= 2:
                diff = paired_verdict([float(rows[s]["mean_return"]) - float(base[s]["mean_return"]) for s in common])
            lines.append(f"| {pool} | {n} | {name} | {len(rows)} | {ret:.1f} | {fit:.2f} | {ll:.3f} | {diff} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    a = probe_parser(__doc__, pools=["LunarLander-v3", "LunarLander-v3-sampled"], n_trajectories=[1, 15],
                     variants=[v for v in BUDGETS if _algo(v) == "mbil"], choices=list(BUDGETS),
                     csv="results/fit_budget.csv").parse_args(argv)
    if a.summary:
        print(summary(a.summary))
        return
    check_tuning_seeds(a.seeds)
    run_budgets(a.env, a.pools, a.n_trajectories, a.seeds, a.variants, a.episodes, a.csv)


if __name__ == "__main__":
    run(main)
