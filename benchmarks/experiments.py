"""Small experiment drivers shared by the scripts: train algorithms on the same expert data and score them."""

from __future__ import annotations

from typing import Any

import numpy as np

from sb3_mbil.common.demonstrations import load_demonstrations


def compare(
    env_id: str,
    n_trajectories: int = 1,
    seed: int = 0,
    eval_episodes: int = 300,
    algos: tuple[str, ...] = ("mbil", "bc"),
    steps: int | None = None,
    pool: str | None = None,
) -> dict[str, Any]:
    """Draw ``n_trajectories`` from the env's expert pool with ``seed``, train each algorithm on them with its
    settings from ``zoo_hyperparams/`` and evaluate it: one benchmark run per algorithm (the same code as the grid).

    Every algorithm gets the same full trajectories. ``steps`` overrides the settings' gradient steps. ``pool``:
    a ``.npz`` path, shipped pool name or ``minari:<id>`` to draw from instead of the env's shipped pool (an env
    without zoo settings then runs with the constructor's defaults and 10 000 gradient steps).
    """
    from benchmarks.harness.grid import Run, run_one

    source = pool
    pool_data = load_demonstrations(pool or env_id)
    demos = pool_data.sample(n_trajectories, seed=seed)
    overrides = {a: {"n_timesteps": steps} for a in algos} if steps else None
    return {
        "env": env_id,
        "n_trajectories": n_trajectories,
        "seed": seed,
        "expert_pool": str(source or env_id),
        "expert_pool_mean_return": float(np.nanmean(pool_data.episode_returns)) if np.isfinite(pool_data.episode_returns).any() else float("nan"),
        "data_mean_return": float(demos.episode_returns.mean()),
        "results": {a: run_one(Run(a, env_id, n_trajectories, seed), eval_episodes, overrides, pool=source) for a in algos},
    }
