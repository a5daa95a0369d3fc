"""What does the balance term add? MBIL and MBIL-C with the paper's P(a' | s, a, s') against the same algorithm with
P(a' | s') (s and a hidden from P at its fit and at the targets) and against no balance term (alpha = 0).

The balance equation's content is P's conditioning on the predecessor (s, a): with P(a' | s') the balance term fits
log pi(a' | s') to a second model of the same (s', a') labels that behaviour cloning fits (a self-distillation), so
equal returns with P(a' | s') say that what the term adds is that smoothing, not the balance equation. Hiding s and a:
they are replaced by zeros in P's inputs (constant columns, which the fit's standardiser gives unit input noise while
fitting and zero at the targets, so P learns to ignore them).

Not part of the installed package: a probe on tuning seeds (>= 100); rows in a CSV (rerun to resume), seeds in
lockstep (each its separate run), 100 evaluation episodes.

    python -m benchmarks.balance_ablation --env LunarLander-v3 --n-trajectories 1 --seeds 100-109 \\
        --pools LunarLander-v3-sampled benchmarks/pools/LunarLander-v3-noise0.1.npz \\
        benchmarks/pools/LunarLander-v3-noise0.2.npz --csv results/balance_ablation.csv
    python -m benchmarks.balance_ablation --summary results/balance_ablation.csv

The NLL pair (``--variants mbil_nll mbil_nll_alpha0``) asks the same of MBIL on top of BC's Gaussian NLL, and
``mbil_alpha3`` weighs the balance term three times as much:

    python -m benchmarks.balance_ablation --env Walker2d-v4 --n-trajectories 1 --seeds 100-104 \\
        --pools benchmarks/pools/Walker2d-v4-noise0.1.npz --csv results/balance_ablation.csv \\
        --variants mbil mbil_alpha0 mbil_nll mbil_nll_alpha0 mbil_next_state_only mbil_alpha3

MBIL-C* on Walker2d-v4's sampled pool (weight decay 1e-3), taken apart the same way, with the balance term's anchored
mean part alone (``mbil_c_wd0.001_alpha0_beta7``):

    python -m benchmarks.balance_ablation --env Walker2d-v4 --n-trajectories 1 --seeds 100-109 \\
        --pools Walker2d-v4-sampled --csv results/balance_ablation.csv --variants mbil_c_wd0.001 \\
        mbil_c_wd0.001_alpha0 mbil_c_wd0.001_alpha0_beta7 mbil_c_wd0.001_next_state_only

and pushed where its ablation points (P's std target): the balance term three times as heavy, a stronger weight decay

    python -m benchmarks.balance_ablation --env Walker2d-v4 --n-trajectories 1 --seeds 100-109 \\
        --pools Walker2d-v4-sampled --csv results/balance_ablation.csv --variants mbil_c_wd0.001_alpha3 mbil_c_wd0.003

and against BC on a shorter budget (``bc_2k``, ``bc_5k``, ``bc_nll_5k``): is MBIL-C*'s lead BC's overfitting?
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import torch as th

from benchmarks.harness.cli import check_tuning_seeds, probe_parser, run
from benchmarks.harness.grid import git_commit, tuned_settings
from benchmarks.harness.report import paired_verdict
from benchmarks.harness.results import append_rows, read_result_rows
from benchmarks.stochastic import PROBES, Variant, _row, draw, pending_cells
from sb3_mbil import BC, MBIL, MBILC, learn_lockstep
from sb3_mbil.mbil.policies import MarkovBalanceModel
from sb3_mbil.mbil_c.policies import BalanceModel


class _NextStateOnly:
    """P's inputs with s and a replaced by zeros: P(a' | s') in place of P(a' | s, a, s')."""

    def next_action_inputs(self, s, a, s_next, a_next):
        return super().next_action_inputs(th.zeros_like(s), th.zeros_like(a), s_next, a_next)

    def next_action_distribution(self, s, a, s_next):  # MBIL-C's targets
        return super().next_action_distribution(th.zeros_like(s), th.zeros_like(a), s_next)


class _FlowsNextStateOnly(_NextStateOnly, MarkovBalanceModel):
    pass


class _ModelNextStateOnly(_NextStateOnly, BalanceModel):
    pass


class MBILNextStateOnly(MBIL):
    """MBIL whose P is P(a' | s')."""

    def _setup_model(self) -> None:
        super()._setup_model()
        self.flows.__class__ = _FlowsNextStateOnly


class MBILCNextStateOnly(MBILC):
    """MBIL-C whose P is P(a' | s')."""

    def _setup_model(self) -> None:
        super()._setup_model()
        self.balance_model.__class__ = _ModelNextStateOnly


#: name -> (class, zoo entry of, settings over the entry)
VARIANTS = {
    "mbil": (MBIL, "mbil", {}),
    "mbil_next_state_only": (MBILNextStateOnly, "mbil", {}),
    "mbil_alpha0": (MBIL, "mbil", {"alpha": 0.0}),
    "mbil_c": (MBILC, "mbil_c", {}),
    "mbil_c_next_state_only": (MBILCNextStateOnly, "mbil_c", {}),
    "mbil_c_alpha0": (MBILC, "mbil_c", {"alpha": 0.0}),
    # the same pair on top of the Gaussian NLL (a state-dependent std), the regulariser that is BC* on Walker2d-v4:
    # what the balance term adds to a BC that already fits a distribution
    "mbil_nll": (MBIL, "mbil", {"bc_loss": "nll"}),
    "mbil_nll_alpha0": (MBIL, "mbil", {"bc_loss": "nll", "alpha": 0.0}),
    # pushing the balance term where it pays (Walker2d-v4, sigma 0.1): a heavier weight on it
    "mbil_alpha3": (MBIL, "mbil", {"alpha": 3.0}),
    # MBIL-C* on Walker2d-v4's sampled pool (weight decay 1e-3, above BC* in Figure 4): the same triple on top of
    # weight decay, and the balance term's mean part alone. With W2 anchored on the data, the term at the data is
    # sum_j (a'_j - mean_pi(s')_j)^2 + (std_P(s, a, s')_j - std_pi(s')_j)^2: its mean part is a second MSE cloning
    # term at the next states, summed over the action's dimensions where BC's MSE averages them (6 on Walker2d-v4).
    # alpha = 0 with beta = 7 keeps that part and drops P's std target; under Adam with L2 weight decay (coupled),
    # a loss 7 times as large is the same training as weight decay 1e-3 / 7 on the loss itself
    "mbil_c_wd0.001": (MBILC, "mbil_c", {"weight_decay": 1e-3}),
    "mbil_c_wd0.001_next_state_only": (MBILCNextStateOnly, "mbil_c", {"weight_decay": 1e-3}),
    "mbil_c_wd0.001_alpha0": (MBILC, "mbil_c", {"weight_decay": 1e-3, "alpha": 0.0}),
    "mbil_c_wd0.001_alpha0_beta7": (MBILC, "mbil_c", {"weight_decay": 1e-3, "alpha": 0.0, "beta": 7.0}),
    # pushing what carries it (P's std target): the balance term three times as heavy, and a stronger weight decay
    "mbil_c_wd0.001_alpha3": (MBILC, "mbil_c", {"weight_decay": 1e-3, "alpha": 3.0}),
    "mbil_c_wd0.003": (MBILC, "mbil_c", {"weight_decay": 3e-3}),
    # is MBIL-C*'s lead BC's overfitting? On one trajectory BC's learning curve peaks within 5 000 updates and falls
    # over the 50 000 of its zoo entry, where MBIL-C*'s holds (results/stochastic_curves.png): BC and its NLL trained
    # for fewer updates (the learning rate's linear schedule runs over the shorter budget)
    "bc_2k": (BC, "bc", {"n_timesteps": 2000}),
    "bc_5k": (BC, "bc", {"n_timesteps": 5000}),
    "bc_nll_5k": (BC, "bc", PROBES["bc_nll_5k"].settings),  # the probe that then ran on Figure 4's seeds
}
#: the pushed settings of MBIL-C*, and BC on a shorter budget, each paired against it
PUSHED = {"mbil_c_wd0.001_alpha3": "MBIL-C with weight decay 1e-3 at alpha 3", "mbil_c_wd0.003": "MBIL-C with weight decay 3e-3",
          "bc_2k": "BC, 2 000 updates", "bc_5k": "BC, 5 000 updates", "bc_nll_5k": "BC's NLL, 5 000 updates"}
#: what runs without --variants: the paper's P, P(a' | s') and alpha = 0, for MBIL and MBIL-C
DEFAULT_VARIANTS = ["mbil", "mbil_next_state_only", "mbil_alpha0", "mbil_c", "mbil_c_next_state_only", "mbil_c_alpha0"]
COLUMNS = ["variant", "env", "pool", "n_trajectories", "seed", "mean_return", "std_return", "n_episodes", "settings",
           "commit"]


def run_ablation(env_id: str, pools: list[str], n_trajectories: list[int], seeds: list[int], variants: list[str],
                 n_episodes: int, csv_path: str) -> None:
    th.set_num_threads(1)
    commit = git_commit()
    for pool, n, name, todo in pending_cells(csv_path, env_id, pools, n_trajectories, variants, seeds):
        cls, entry, overrides = VARIANTS[name]
        settings = tuned_settings(entry, env_id, overrides)
        steps = int(float(settings.pop("n_timesteps")))
        models = [cls("MlpPolicy", env_id, expert_data=draw(env_id, pool, n, s), seed=s, **settings) for s in todo]
        learn_lockstep(models, steps)
        variant = Variant(entry, overrides)
        for s, m in zip(todo, models):  # each row as its evaluation ends
            row = _row(name, variant, env_id, pool, n, s, m, None, 0.0, n_episodes, commit)
            append_rows(csv_path, [{k: v for k, v in row.items() if k in COLUMNS}], COLUMNS)
            print(f"{name} {pool} N={n} seed={s}: {row['mean_return']:.1f}", flush=True)


def summary(csv_path: str) -> str:
    """Markdown: per (pool, N), each variant's mean return, and the paper's P against P(a' | s') and against no
    balance term, paired over seeds."""
    cells: dict[tuple, dict[str, dict[int, float]]] = defaultdict(lambda: defaultdict(dict))
    for r in read_result_rows(csv_path):
        cells[(r["pool"], int(r["n_trajectories"]))][r["variant"]][int(r["seed"])] = float(r["mean_return"])
    lines = ["| pool | N | algorithm | P(a' given s, a, s') | P(a' given s') | alpha = 0 | P(s, a, s') minus P(s') | "
             "P(s, a, s') minus alpha = 0 |", "|---|---|---|---|---|---|---|---|"]

    def diff(a: dict, b: dict) -> str:
        common = sorted(set(a) & set(b))
        return paired_verdict([a[s] - b[s] for s in common]) if len(common) >= 2 else ""

    for (pool, n), v in sorted(cells.items()):
        for algo, label in (("mbil", "MBIL"), ("mbil_c", "MBIL-C"), ("mbil_nll", "MBIL, NLL"),
                            ("mbil_c_wd0.001", "MBIL-C, weight decay 1e-3")):
            names = (algo, f"{algo}_next_state_only", f"{algo}_alpha0")
            if not any(v.get(x) for x in names):
                continue
            means = [f"{np.mean(list(v[x].values())):.1f} ({len(v[x])})" if v.get(x) else "" for x in names]
            lines.append(f"| {pool} | {n} | {label} | {' | '.join(means)} | "
                         f"{diff(v.get(names[0], {}), v.get(names[1], {}))} | {diff(v.get(names[0], {}), v.get(names[2], {}))} |")
    # does MBIL's balance term on MSE cloning do more than the NLL alone (BC* on Walker2d-v4)?
    against_nll = [f"- {pool}, N = {n}: MBIL (MSE, balance term{label}) minus the NLL without it: "
                   f"{diff(v[name], v['mbil_nll_alpha0'])}"
                   for (pool, n), v in sorted(cells.items()) for name, label in (("mbil", ""), ("mbil_alpha3", ", alpha 3"))
                   if v.get(name) and v.get("mbil_nll_alpha0")]
    # does P's std target add anything to the anchored mean part (the MSE term 7 times as large)?
    against_doubled = [f"- {pool}, N = {n}: MBIL-C with weight decay 1e-3 minus the same without the balance term and "
                       f"the MSE 7 times as large (beta = 7): {diff(v['mbil_c_wd0.001'], v['mbil_c_wd0.001_alpha0_beta7'])}"
                       for (pool, n), v in sorted(cells.items())
                       if v.get("mbil_c_wd0.001") and v.get("mbil_c_wd0.001_alpha0_beta7")]
    # does pushing P's std target (a heavier balance term, a stronger weight decay) add to MBIL-C*, and does BC on a
    # shorter budget reach it?
    pushed = [f"- {pool}, N = {n}: {label} minus MBIL-C at alpha 1 and weight decay 1e-3: "
              f"{diff(v[name], v['mbil_c_wd0.001'])}"
              for (pool, n), v in sorted(cells.items()) for name, label in PUSHED.items()
              if v.get(name) and v.get("mbil_c_wd0.001")]
    # every variant's mean and per-seed returns, the rows the tables above pair
    per_variant = [f"- {pool}, N = {n}, {name}: {np.mean(list(by_seed.values())):.1f} "
                   f"({', '.join(f'{by_seed[s]:.1f}' for s in sorted(by_seed))})"
                   for (pool, n), v in sorted(cells.items()) for name, by_seed in sorted(v.items())]
    extra = against_nll + against_doubled + pushed
    return "\n".join(lines + ([""] + extra if extra else []) + [""] + per_variant)


def main(argv=None) -> None:
    a = probe_parser(__doc__, pools=["LunarLander-v3-sampled"], n_trajectories=[1], variants=DEFAULT_VARIANTS,
                     choices=list(VARIANTS), csv="results/balance_ablation.csv").parse_args(argv)
    if a.summary:
        print(summary(a.summary))
        return
    check_tuning_seeds(a.seeds)
    run_ablation(a.env, a.pools, a.n_trajectories, a.seeds, a.variants, a.episodes, a.csv)


if __name__ == "__main__":
    run(main)
