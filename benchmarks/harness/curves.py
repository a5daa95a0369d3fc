"""Learning curves (the paper's Figure 4 and 5 protocol): evaluate every ``eval_every`` gradient updates.

One run = (variant, env, seed): train a variant (an algorithm plus settings) on N expert
trajectories and score its deterministic policy on ``n_episodes`` episodes every ``eval_every``
gradient updates. All rows of a run are appended in one write when it finishes, so an interrupted set of
runs resumes by skipping finished (variant, env, seed).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.callbacks import BaseCallback

from sb3_mbil import ALGORITHMS
from benchmarks.harness.grid import check_overrides, git_commit, tuned_settings
from benchmarks.harness.pools import load_pool_version, pool_experts, pool_version, row_pool  # noqa: F401  (pool_experts: re-exported)
from benchmarks.harness.report import paired_interval
from benchmarks.harness.results import append_rows, finished_keys, settings_by_cell

CURVE_COLUMNS = ["algo", "env", "seed", "gradient_step", "mean_return", "n_episodes", "n_trajectories", "settings", "commit",
                 "heldout_bc_loss"]
CURVE_KEY = ("algo", "env", "seed")

# Figure 4: MBIL (MSE BC term, Gaussian policy) against BC with MSE, with and without weight decay, and every other
# algorithm of sb3_mbil.ALGORITHMS that takes Box actions, with its zoo settings.
FIGURE4_VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "mbil": ("mbil", {"bc_loss": "mse"}),
    "bc": ("bc", {"bc_loss": "mse", "weight_decay": 0.0}),
    "bc_wd1e-3": ("bc", {"bc_loss": "mse", "weight_decay": 1e-3}),
    **{name: (name, {}) for name, algo in ALGORITHMS.items()
       if spaces.Box in algo.supported_action_spaces and name not in ("mbil", "bc")},
}
# Figure 5: the (alpha, beta) ablation.
ABLATION_VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    f"mbil_a{a:g}_b{b:g}": ("mbil", {"alpha": a, "beta": b}) for a, b in ((1, 0), (0, 1), (1, 0.001), (0.001, 1))
}


def parse_variants(text: str) -> dict[str, tuple[str, dict[str, Any]]]:
    """Variants from JSON, ``{"name": ["algo", {settings}]}`` (e.g. tuning runs beside the figures' variants)."""
    import json

    try:
        raw = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"variants: expected JSON {{\"name\": [\"algo\", {{settings}}]}}, found {text!r} ({e})") from None
    if not isinstance(raw, dict) or not raw:
        raise ValueError(f"variants: expected a non-empty JSON object, found {text!r}")
    out = {}
    for name, spec in raw.items():
        if not (isinstance(spec, list) and len(spec) == 2 and spec[0] in ALGORITHMS and isinstance(spec[1], dict)):
            raise ValueError(f"variants[{name!r}]: expected [algo, {{settings}}] with algo in {sorted(ALGORITHMS)}, found {spec!r}")
        try:
            check_overrides(spec[0], spec[1])
        except ValueError as e:
            raise ValueError(f"variants[{name!r}]: {e}") from None
        out[str(name)] = (spec[0], dict(spec[1]))
    return out


@dataclass(frozen=True)
class CurveRun:
    variant: str
    env: str
    seed: int

    def key(self) -> tuple[str, ...]:
        return (self.variant, self.env, str(self.seed))


class _Scorer(BaseCallback):
    def __init__(self, env_id: str, every: int, n_episodes: int, seed: int):
        super().__init__()
        self.env_id, self.every, self.n_episodes, self.seed = env_id, every, n_episodes, seed
        self.points: list[tuple[int, float]] = []

    def _on_step(self) -> bool:
        if self.num_timesteps % self.every == 0:
            from sb3_mbil.common.evaluation import evaluate

            returns = evaluate(self.model, self.env_id, self.n_episodes, seed=self.seed + self.num_timesteps, n_envs=self.n_episodes)
            self.points.append((self.num_timesteps, float(np.mean(returns))))
        return True


def drawn_demonstrations(env: str, seed: int, n_trajectories: int = 1, pool: str | None = None,
                         commit: str | None = None):
    """The expert trajectories a run of this seed trains on (drawn from ``pool`` or the env's shipped pool; with
    ``commit``, a result row's, from the version of the pool that row drew from, :func:`pool_version`)."""
    name = pool or env
    return load_pool_version(name, pool_version(name, commit)).sample(n_trajectories, seed=seed)


def _resolved_settings(algo: str, env: str, variant_settings: dict[str, Any],
                       extra_settings: dict[str, Any] | None = None) -> dict[str, Any]:
    """A variant's constructor settings on ``env``: the zoo's entry, overridden by what the variant sets."""
    settings = tuned_settings(algo, env, {**variant_settings, **(extra_settings or {})})
    settings.pop("n_timesteps", None)
    return settings


def _settings_column(algo: str, settings: dict[str, Any], pool: str | None, holdout_fraction: float | None) -> str:
    """The ``settings`` column of a row: every setting the run used, sorted."""
    recorded = {"algo": algo, **settings, **({"expert_pool": pool} if pool else {}),
                **({"holdout_fraction": holdout_fraction} if holdout_fraction else {})}
    return repr(sorted(recorded.items()))


def check_variant_settings(variants: dict[str, tuple[str, dict[str, Any]]], envs, csv_path: str,
                           pool: str | None = None, extra_settings: dict[str, Any] | None = None,
                           holdout_fraction: float | None = None) -> None:
    """Refuse runs whose variant names would mislead, with a ``ValueError`` naming them.

    A variant inherits the zoo's settings for whatever it leaves out, so two variants can resolve to the same run
    (a "constant learning rate" variant that does not set its rate, once the zoo's entry decays it), and a variant's
    earlier rows in ``csv_path`` can have been run with other settings (the zoo's entry changed since). Either would
    put one label on two different things.
    """
    earlier = settings_by_cell(csv_path)
    for env in envs:
        seen: dict[str, str] = {}
        for name, (algo, variant_settings) in variants.items():
            column = _settings_column(algo, _resolved_settings(algo, env, variant_settings, extra_settings), pool,
                                      holdout_fraction)
            if column in seen:
                raise ValueError(f"variants: expected different settings for each variant on {env}, found "
                                 f"{seen[column]!r} and {name!r} both {column} (a variant inherits the zoo's "
                                 "settings for what it leaves out: set what distinguishes them)")
            seen[column] = name
            other = sorted(earlier.get((name, env), set()) - {column})
            if other:
                raise ValueError(f"variants: expected {name!r} on {env} to run with the settings of its rows in "
                                 f"{csv_path}, found {column} now and {other[0]} there (the zoo's entry or the "
                                 "variant changed): give the new runs another name or another CSV")


def run_curve(run: CurveRun, variants: dict[str, tuple[str, dict[str, Any]]], n_updates: int, eval_every: int = 500,
              n_episodes: int = 10, n_trajectories: int = 1, pool: str | None = None, commit: str | None = None,
              extra_settings: dict[str, Any] | None = None, holdout_fraction: float | None = None) -> list[dict[str, Any]]:
    """Train one variant and return one row per evaluation point.

    ``holdout_fraction``: hold out that share of the expert steps (blocks of 50, drawn with the run's seed) with a
    :class:`~sb3_mbil.common.heldout.ValidationCallback`; each row then has the held-out BC loss at its step.
    """
    import torch as th

    th.set_num_threads(1)
    algo, variant_settings = variants[run.variant]
    settings = _resolved_settings(algo, run.env, variant_settings, extra_settings)
    demos = drawn_demonstrations(run.env, run.seed, n_trajectories, pool)
    model = ALGORITHMS[algo]("MlpPolicy", run.env, expert_data=demos, seed=run.seed, **settings)
    scorer = _Scorer(run.env, eval_every, n_episodes, seed=1_000_000 + 1000 * run.seed)
    callbacks: list[BaseCallback] = [scorer]
    if holdout_fraction:
        from sb3_mbil.common.heldout import ValidationCallback

        validator = ValidationCallback(holdout_fraction, eval_freq=eval_every, block_length=50, seed=run.seed)
        callbacks.insert(0, validator)
    model.learn(n_updates, callback=callbacks)
    heldout = {step: losses["bc_loss"] for step, losses in validator.history} if holdout_fraction else {}
    commit = commit or git_commit()
    base = {"algo": run.variant, "env": run.env, "seed": run.seed, "n_episodes": n_episodes,
            "n_trajectories": n_trajectories, "settings": _settings_column(algo, settings, pool, holdout_fraction),
            "commit": commit}
    return [{**base, "gradient_step": step, "mean_return": ret, "heldout_bc_loss": heldout.get(step, "")}
            for step, ret in scorer.points]


def run_curves(variants: dict[str, tuple[str, dict[str, Any]]], envs, seeds, csv_path: str, n_updates: int,
               eval_every: int = 500, n_episodes: int = 10, n_trajectories: int = 1, pool: str | None = None,
               use_ray: bool = True, address: str | None = None, num_cpus: int | None = None,
               extra_settings: dict[str, Any] | None = None, holdout_fraction: float | None = None) -> int:
    """All (variant, env, seed) runs not yet in the CSV; on Ray unless ``use_ray`` is False. Variants that would put
    one name on two different runs are refused first (:func:`check_variant_settings`)."""
    done = finished_keys(csv_path, CURVE_KEY)  # first: it drops a line that an interrupted run left unfinished
    check_variant_settings(variants, envs, csv_path, pool, extra_settings, holdout_fraction)
    todo = [CurveRun(v, e, int(s)) for s, e, v in itertools.product(seeds, envs, variants) if CurveRun(v, e, int(s)).key() not in done]
    commit = git_commit()
    args = (variants, n_updates, eval_every, n_episodes, n_trajectories, pool, commit, extra_settings, holdout_fraction)
    if not use_ray:
        for run in todo:
            append_rows(csv_path, run_curve(run, *args), CURVE_COLUMNS)
        return len(todo)
    import ray

    if address:
        ray.init(address=address)
    else:
        ray.init(address="local", num_cpus=num_cpus, include_dashboard=False, log_to_driver=False,
                 runtime_env={"env_vars": {"OMP_NUM_THREADS": "1"}})
    task = ray.remote(num_cpus=1, max_retries=1)(run_curve)
    futures = {task.remote(run, *args): run for run in todo}
    n = 0
    try:
        while futures:
            ready, _ = ray.wait(list(futures), num_returns=1)
            futures.pop(ready[0])
            append_rows(csv_path, ray.get(ready[0]), CURVE_COLUMNS)
            n += 1
    finally:
        ray.shutdown()
    return n


def curve_summary(rows: list[dict]) -> dict[tuple[str, str, int], tuple[float, float, int]]:
    """(variant, env, gradient_step) -> (mean over seeds, std over seeds, number of seeds)."""
    groups: dict[tuple[str, str, int], list[float]] = {}
    for r in rows:
        groups.setdefault((r["algo"], r["env"], int(r["gradient_step"])), []).append(float(r["mean_return"]))
    return {k: (float(np.mean(v)), float(np.std(v)), len(v)) for k, v in groups.items()}


def final_returns(rows: list[dict], last: int = 10) -> dict[tuple[str, str], dict[int, tuple[float, int]]]:
    """(env, variant) -> {seed: (mean of its last ``last`` evaluations, its number of updates)}."""
    per_seed: dict[tuple[str, str, int], list[tuple[int, float]]] = {}
    for r in rows:
        per_seed.setdefault((r["env"], r["algo"], int(r["seed"])), []).append((int(r["gradient_step"]), float(r["mean_return"])))
    out: dict[tuple[str, str], dict[int, tuple[float, int]]] = {}
    for (env, variant, seed), points in per_seed.items():
        points.sort()
        out.setdefault((env, variant), {})[seed] = (float(np.mean([ret for _, ret in points[-last:]])), points[-1][0])
    return out


def _spread(values: np.ndarray, standard_error: bool = False) -> str:
    """'mean +- std' (or +- the standard error) over seeds; 'mean (one seed)' when there is no spread to show."""
    values = np.asarray(values, dtype=float)
    if len(values) < 2:
        return f"{values.mean():.0f} (one seed)"
    spread = values.std(ddof=1) / np.sqrt(len(values)) if standard_error else values.std()
    return f"{values.mean():.0f} +- {spread:.0f}"


def curve_table(rows: list[dict], expert: dict[str, float] | None = None, last: int = 10) -> str:
    """Markdown: per (env, variant) the final return (each seed's mean over its last ``last``
    evaluations, then mean +- std over seeds), its share of the expert's return, the best point of
    the seed-mean curve and the final minus the best (a late collapse shows as a large drop)."""
    summary = curve_summary(rows)
    lines = [f"| env | variant | final return (last {last} evaluations) | final / expert | best point (updates) | final - best | seeds | updates |",
             "|---|---|---|---|---|---|---|---|"]
    for (env, variant), by_seed in sorted(final_returns(rows, last).items()):
        finals = [f for f, _ in by_seed.values()]
        curve = {step: m for (v, e, step), (m, _, _) in summary.items() if (e, v) == (env, variant)}
        best_step = max(curve, key=curve.get)
        final = float(np.mean(finals))
        share = f"{final / expert[env]:.2f}" if expert and env in expert else ""
        lines.append(f"| {env} | {variant} | {_spread(finals)} | {share} | {curve[best_step]:.0f} ({best_step}) | "
                     f"{final - curve[best_step]:.0f} | {len(finals)} | {min(n for _, n in by_seed.values())} |")
    return "\n".join(lines)


def paired_table(rows: list[dict], reference: str, last: int = 10) -> str:
    """Markdown: each variant's final return minus the ``reference`` variant's on the same seeds (same
    trajectory), mean +- standard error, its paired 95% confidence interval, and on how many seeds it is below."""
    finals = final_returns(rows, last)
    lines = [f"| env | variant | seeds | final return | minus {reference} | paired 95% CI | below on |",
             "|---|---|---|---|---|---|---|"]
    for (env, variant), by_seed in sorted(finals.items()):
        ref = finals.get((env, reference))
        if ref is None or variant == reference:
            continue
        seeds = sorted(set(by_seed) & set(ref))
        d = np.array([by_seed[s][0] - ref[s][0] for s in seeds])
        if len(d) == 0:
            continue
        ci = "[{:+.0f}, {:+.0f}]".format(*paired_interval(d)) if len(d) > 1 else "-"
        lines.append(f"| {env} | {variant} | {len(d)} | {np.mean([by_seed[s][0] for s in seeds]):.0f} | {_spread(d, True)} | "
                     f"{ci} | {int((d < 0).sum())} of {len(d)} |")
    return "\n".join(lines)


def draw_table(rows: list[dict], last: int = 10) -> str:
    """Markdown: per (env, seed) the trajectories the seed drew (pool indices, return, length) beside each
    variant's final return on them, so a low final can be set against a short or low-return draw."""

    finals = final_returns(rows, last)
    variants = sorted({v for _, v in finals})
    draws = {(r["env"], int(r["seed"])): (int(r.get("n_trajectories") or 1), row_pool(r), r.get("commit") or "")
             for r in rows}
    lines = ["| env | seed | drawn (pool index) | return of the draw (mean) | steps | " + " | ".join(variants) + " |",
             "|---|---|---|---|---|" + "---|" * len(variants)]
    for (env, seed), (n, pool, commit) in sorted(draws.items()):
        demos = drawn_demonstrations(env, seed, n, pool, commit)
        cells = [f"{finals[(env, v)][seed][0]:.0f}" if seed in finals.get((env, v), {}) else "" for v in variants]
        lines.append(f"| {env} | {seed} | {', '.join(map(str, demos.metadata['sampled']['indices']))} | "
                     f"{demos.episode_returns.mean():.0f} | {sum(len(t) for t in demos.trajectories)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot_curves(rows: list[dict], path: str, expert: dict[str, float] | None = None):
    """The Figure 4 layout: mean return vs gradient updates per env, a band of one std over seeds, the expert as a
    line; each variant has one colour in every panel. Returns the figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from benchmarks.harness.report import finish_figure, variant_colors

    summary = curve_summary(rows)
    envs = sorted({k[1] for k in summary})
    colors = variant_colors(k[0] for k in summary)
    fig, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 4), squeeze=False)
    for ax, env in zip(axes[0], envs):
        for variant in sorted({k[0] for k in summary if k[1] == env}):
            steps = sorted(k[2] for k in summary if k[0] == variant and k[1] == env)
            m = np.array([summary[(variant, env, s)][0] for s in steps])
            sd = np.array([summary[(variant, env, s)][1] for s in steps])
            ax.plot(steps, m, label=variant, color=colors[variant])
            ax.fill_between(steps, m - sd, m + sd, alpha=0.2, color=colors[variant])
        if expert and env in expert:
            ax.axhline(expert[env], color="k", ls="--", lw=1, label="expert")
    finish_figure(fig, axes, envs, "gradient updates", path)
    return fig


__all__ = ["ABLATION_VARIANTS", "CURVE_COLUMNS", "FIGURE4_VARIANTS", "CurveRun", "curve_summary", "curve_table", "final_returns",
           "paired_table", "parse_variants", "plot_curves", "run_curve", "run_curves"]


def heldout_table(rows: list[dict]) -> str:
    """Markdown: does the held-out BC loss pick a good stopping point? Per (env, variant), over seeds: the return
    at the point of lowest held-out loss, the final return and the best return of each seed's curve."""
    runs: dict[tuple[str, str], dict[int, list[tuple[int, float, float]]]] = {}
    for r in rows:
        if r.get("heldout_bc_loss") in (None, ""):
            continue
        runs.setdefault((r["env"], r["algo"]), {}).setdefault(int(r["seed"]), []).append(
            (int(r["gradient_step"]), float(r["mean_return"]), float(r["heldout_bc_loss"])))
    lines = ["| env | variant | seeds | return at the lowest held-out loss | final return | best return | picked - final (paired) |",
             "|---|---|---|---|---|---|---|"]
    for (env, variant), by_seed in sorted(runs.items()):
        picked = np.array([min(p, key=lambda x: x[2])[1] for p in by_seed.values()])
        final = np.array([max(p)[1] for p in by_seed.values()])
        best = np.array([max(x[1] for x in p) for p in by_seed.values()])
        d = picked - final
        lines.append(f"| {env} | {variant} | {len(d)} | {_spread(picked)} | {_spread(final)} | {best.mean():.0f} | "
                     f"{_spread(d, True)} |")
    return "\n".join(lines)
