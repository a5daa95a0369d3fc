"""Small experiment drivers shared by the scripts: train algorithms on the same expert data and score them."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import torch as th

from sb3_mbil.common.demonstrations import load_demonstrations
from sb3_mbil.common.evaluation import evaluate


def compare(
    env_id: str,
    n_trajectories: int = 1,
    seed: int = 0,
    steps: int = 10_000,
    eval_episodes: int = 100,
    algos: tuple[str, ...] = ("mbil", "bc"),
    hyperparams: dict[str, dict[str, Any]] | None = None,
    pool: str | None = None,
) -> dict[str, Any]:
    """Draw ``n_trajectories`` from the env's expert pool with ``seed``, train each algorithm on them, evaluate.

    Every algorithm gets the same full trajectories.
    """
    from sb3_mbil import ALGORITHMS

    th.set_num_threads(1)
    demos = load_demonstrations(pool or env_id).sample(n_trajectories, seed=seed)
    out: dict[str, Any] = {
        "env": env_id,
        "n_trajectories": n_trajectories,
        "seed": seed,
        "expert_pool_mean_return": float(load_demonstrations(pool or env_id).episode_returns.mean()),
        "data_mean_return": float(demos.episode_returns.mean()),
        "results": {},
    }
    for name in algos:
        kwargs = dict((hyperparams or {}).get(name, {}))
        t0 = time.process_time()
        model = ALGORITHMS[name]("MlpPolicy", env_id, expert_data=demos, seed=seed, **kwargs)
        model.learn(steps)
        seconds = time.process_time() - t0
        returns = evaluate(model, env_id, eval_episodes, seed=10_000 + seed)
        out["results"][name] = {"mean_return": float(np.mean(returns)), "std_return": float(np.std(returns)),
                                "train_cpu_seconds": round(seconds, 1)}
    return out
