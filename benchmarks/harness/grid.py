"""One benchmark run: draw N expert trajectories with the run's seed, train with the algorithm's
tuned settings for the env, evaluate the deterministic policy on many episodes."""

from __future__ import annotations

import itertools
import subprocess
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

RESULT_COLUMNS = [
    "algo", "env", "n_trajectories", "seed", "mean_return", "std_return", "n_episodes", "train_seconds",
    "flow_fit_seconds", "gradient_steps", "settings", "commit",
    # MBIL diagnostics: mean balance target (log P - log T), held-out log-likelihoods, chosen noise
    "target_mean", "p_heldout_ll", "transition_heldout_ll", "next_action_noise",
    # the data protocol (benchmarks.harness.protocol); files written before it have full-trajectory rows only
    "protocol",
    # a row copied from another grid's file, whose run trained on the same data with the same settings
    # (benchmarks.harness.runner.reuse_rows): that file's name; empty for a row run here
    "reused_from",
    # DSFN: i of the returned pi_i (0: its warm-start classifier; sb3_mbil.DSFN.returned_iteration)
    "returned_iteration",
]
KEY_COLUMNS = ("algo", "env", "n_trajectories", "seed")


@dataclass(frozen=True)
class Run:
    algo: str
    env: str
    n_trajectories: int
    seed: int

    def key(self) -> tuple[str, ...]:
        return tuple(str(v) for v in asdict(self).values())


def make_grid(algos, envs, n_trajectories, seeds) -> list[Run]:
    """Seed-major order: an interrupted grid has results for every (algo, env, N) cell at fewer seeds."""
    return [Run(a, e, int(n), int(s)) for s, e, n, a in itertools.product(seeds, envs, n_trajectories, algos)]


def git_commit(root: str | Path | None = None) -> str:
    """The short commit of the checkout, with ``-dirty`` when a tracked file outside ``results/`` differs from it
    (the result files are the grids' own output, which a running grid changes; the code is what the suffix is for)."""
    try:
        root = Path(root) if root is not None else Path(__file__).resolve().parents[2]
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)results"],
                               cwd=root, capture_output=True, text=True, check=True).stdout.strip()
        return head + ("-dirty" if dirty else "")
    except Exception:
        return "unknown"


#: gradient steps of a run on an env without zoo settings (the classic-control budget)
DEFAULT_STEPS = 10_000


def has_zoo_entry(algo: str, env: str) -> bool:
    """Whether ``zoo_hyperparams/<algo>.yml`` has an entry for the env."""
    import yaml

    from sb3_mbil.zoo import hyperparams_file

    with open(hyperparams_file(algo)) as f:
        return env in yaml.safe_load(f)


def tuned_settings(algo: str, env: str, overrides: dict[str, Any] | None = None, fallback: bool = False) -> dict[str, Any]:
    """The algorithm's settings for the env from ``zoo_hyperparams/<algo>.yml`` (the same the RL Zoo uses).

    ``fallback``: for an env without an entry, the constructor's defaults and ``DEFAULT_STEPS`` gradient steps
    (a user's own env and data) instead of an error.
    """
    import yaml

    from sb3_mbil.zoo import DATA_KEYS, hyperparams_file

    with open(hyperparams_file(algo)) as f:
        table = yaml.safe_load(f)
    if env not in table and not fallback:
        raise ValueError(f"env: expected an entry for {env} in {hyperparams_file(algo)}, found entries {sorted(table)}")
    entry = table.get(env, {"n_timesteps": DEFAULT_STEPS})
    settings = {k: v for k, v in entry.items() if k not in DATA_KEYS and k != "policy"}
    check_overrides(algo, overrides)
    settings.update(overrides or {})
    if isinstance(settings.get("policy_kwargs"), str):
        # as rl_zoo3 writes it ("dict(net_arch=[256, 256], optimizer_class=th.optim.AdamW)"), parsed, never run
        from sb3_mbil.common.settings import parse_policy_kwargs

        settings["policy_kwargs"] = parse_policy_kwargs(settings["policy_kwargs"])
    if isinstance(settings.get("learning_rate"), str):
        # "lin_1e-3": rl_zoo3's linear schedule (decays to 0 over the run); rl_zoo3 reads any prefix as linear, we
        # accept only "lin_"
        from rl_zoo3.utils import linear_schedule

        prefix, _, value = settings["learning_rate"].partition("_")
        try:
            initial = float(value)
        except ValueError:
            initial = None
        if prefix != "lin" or initial is None:
            raise ValueError(f"learning_rate: expected a number or 'lin_<initial value>', found "
                             f"{settings['learning_rate']!r}")
        settings["learning_rate"] = linear_schedule(initial)
    return settings


def check_overrides(algo: str, overrides: Any) -> None:
    """Settings given on a command line for ``algo``: a dict whose keys are its constructor's settings (or
    ``n_timesteps``); a misspelt or unknown key is a ``ValueError`` naming it and the choices."""
    import inspect

    from sb3_mbil import ALGORITHMS

    if overrides is None:
        return
    if not isinstance(overrides, dict):
        raise ValueError(f"{algo}: expected an object of settings, found {overrides!r}")
    known = {p for p in inspect.signature(ALGORITHMS[algo].__init__).parameters
             if p not in ("self", "policy", "env", "expert_data", "_init_setup_model")} | {"n_timesteps"}
    unknown = sorted(k for k in overrides if k not in known)
    if unknown:
        raise ValueError(f"{algo}.{unknown[0]}: expected a setting of {ALGORITHMS[algo].__name__} "
                         f"({', '.join(sorted(known))}), found an unknown key")


def settings_column(algo: str, env: str, overrides: dict[str, dict[str, Any]] | None = None, pool: str | None = None,
                    protocol: str = "full") -> str:
    """The ``settings`` column of a grid row: the constructor settings, the gradient steps and the data (pool,
    protocol, its step rate and where it starts), sorted."""
    from benchmarks.harness.protocol import published_every, published_start

    settings = tuned_settings(algo, env, (overrides or {}).get(algo), fallback=pool is not None)
    steps = int(float(settings.pop("n_timesteps")))
    data = {"expert_pool": str(pool)} if pool else {}
    if protocol != "full":
        data.update(protocol=protocol, every=published_every(algo, env), start=published_start(algo))
    return repr(sorted({**settings, "n_timesteps": steps, **data}.items()))


def check_grid_settings(runs: list[Run], csv_path: str, overrides: dict[str, dict[str, Any]] | None = None,
                        pool=None, protocol: str = "full") -> None:
    """Refuse, with a ``ValueError`` naming both, runs whose (algo, env) already has rows in ``csv_path`` run with
    other settings (the zoo's entry, the overrides or the protocol changed since): a grid resumed across such a change
    would average two different things under one name. ``pool``: one pool, or one per env."""
    from benchmarks.harness.results import settings_by_cell

    earlier = settings_by_cell(csv_path)
    for algo, env in dict.fromkeys((r.algo, r.env) for r in runs):
        env_pool = pool.get(env) if isinstance(pool, dict) else pool
        column = settings_column(algo, env, overrides, env_pool, protocol)
        other = sorted(earlier.get((algo, env), set()) - {column})
        if other:
            raise ValueError(f"settings: expected {algo!r} on {env} to run with the settings of its rows in {csv_path}, "
                             f"found {column} now and {other[0]} there (the zoo's entry, the overrides or the protocol "
                             "changed): write the new runs to another CSV")


def run_one(run: Run, n_episodes: int = 300, overrides: dict[str, dict[str, Any]] | None = None, commit: str | None = None,
            n_eval_envs: int = 20, pool: str | None = None, protocol: str = "full") -> dict[str, Any]:
    """Train and evaluate one (algo, env, N, seed); returns the result row.

    ``overrides``: per algorithm, settings that replace the tuned ones (``{"mbil": {"alpha": 0.1}}``).
    ``pool``: draw the trajectories from this pool (a ``.npz`` path, a shipped pool name or ``minari:<id>``)
    instead of the env's shipped pool; then an env without zoo settings runs with the constructor's defaults.
    ``protocol``: ``"full"`` trajectories or the ``"published"`` baselines' subsampling
    (:mod:`benchmarks.harness.protocol`), named in the row's ``protocol`` and ``settings``.
    """
    import torch as th

    th.set_num_threads(1)
    data = _data(run, overrides, pool, protocol)
    t0 = time.perf_counter()  # training time: the model's construction on, the data's loading left out (as before)
    model, steps = _build(run, *data)
    model.learn(steps)
    return _result_row(run, model, steps, time.perf_counter() - t0, n_episodes, overrides, commit, n_eval_envs, pool,
                       protocol)


def run_cell_lockstep(runs: list[Run], n_episodes: int = 300, overrides: dict[str, dict[str, Any]] | None = None,
                      commit: str | None = None, n_eval_envs: int = 20, pool: str | None = None,
                      protocol: str = "full") -> list[dict[str, Any]]:
    """The seeds of one (algo, env, N) cell trained in lockstep (:func:`sb3_mbil.learn_lockstep`: one batched network,
    each seed's policy bit for bit its separate run's), then evaluated one by one: the rows :func:`run_one` gives, but
    ``train_seconds`` is the cell's training time divided among its seeds. An algorithm that cannot train in lockstep
    (AVRIL, EDM, DSFN, ValueDICE, ODICE, IQ-Learn on Box actions) runs its seeds one after the other."""
    import torch as th

    from sb3_mbil import learn_lockstep

    if len({(r.algo, r.env, r.n_trajectories) for r in runs}) > 1:
        raise ValueError(f"runs: expected the seeds of one (algo, env, N) cell, found {sorted({r.key()[:3] for r in runs})}")
    th.set_num_threads(1)
    data = [_data(run, overrides, pool, protocol) for run in runs]
    t0 = time.perf_counter()
    built = [_build(run, *d) for run, d in zip(runs, data)]
    models, steps = [m for m, _ in built], built[0][1]
    if not models[0].supports_lockstep():
        return [run_one(run, n_episodes, overrides, commit, n_eval_envs, pool, protocol) for run in runs]
    learn_lockstep(models, steps)
    share = (time.perf_counter() - t0) / len(runs)
    return [_result_row(run, model, steps, share, n_episodes, overrides, commit, n_eval_envs, pool, protocol)
            for run, model in zip(runs, models)]


def _data(run: Run, overrides, pool, protocol) -> tuple[dict[str, Any], int, Any]:
    """The run's settings, gradient steps and drawn demonstrations."""
    from benchmarks.harness.protocol import demonstrations_for

    settings = tuned_settings(run.algo, run.env, (overrides or {}).get(run.algo), fallback=pool is not None)
    steps = int(float(settings.pop("n_timesteps")))
    return settings, steps, demonstrations_for(run.algo, run.env, run.n_trajectories, run.seed, protocol, pool)


def _build(run: Run, settings: dict[str, Any], steps: int, demos) -> tuple[Any, int]:
    """The run's model, built right before it trains (its seed's state is its training stream's start), and its
    number of gradient steps."""
    from sb3_mbil import ALGORITHMS

    return ALGORITHMS[run.algo]("MlpPolicy", run.env, expert_data=demos, seed=run.seed, **settings), steps


def _result_row(run: Run, model, steps: int, train_seconds: float, n_episodes: int, overrides, commit, n_eval_envs: int,
                pool, protocol) -> dict[str, Any]:
    from sb3_mbil.common.evaluation import evaluate

    returns = evaluate(model, run.env, n_episodes, seed=1_000_000 + run.seed, n_envs=n_eval_envs)
    diagnostics = model.diagnostics()
    fit_seconds = diagnostics.pop("fit_seconds", 0.0)
    return {
        **asdict(run),
        "mean_return": float(np.mean(returns)),
        "std_return": float(np.std(returns)),
        "n_episodes": len(returns),
        "train_seconds": round(train_seconds, 1),
        "flow_fit_seconds": round(fit_seconds, 1),  # MBIL's flows, MBIL-C's P and T
        "gradient_steps": steps,
        "settings": settings_column(run.algo, run.env, overrides, pool, protocol),
        "commit": commit or git_commit(),
        "protocol": protocol,
        **diagnostics,
    }
