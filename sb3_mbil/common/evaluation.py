"""Evaluation of a policy on many episodes with batched inference.

The result is SB3's ``evaluate_policy`` on a ``DummyVecEnv`` of ``n_envs`` Monitor-wrapped envs seeded ``seed + i``
(env i runs ``(n_episodes + i) // n_envs`` episodes, the episode returns in the order the episodes end), with one
difference in cost: an env that has run its episodes is no longer stepped. SB3 steps every env until the last
episode ends, which on envs whose episodes differ in length (LunarLander, Hopper) is a good part of the work. The
policy still acts on the whole batch, so every action, and every return, is the one ``evaluate_policy`` gives.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.monitor import Monitor


def evaluate(model: BaseAlgorithm, env_id: str, n_episodes: int = 100, seed: int = 0, n_envs: int = 10) -> np.ndarray:
    """Returns of the deterministic policy over ``n_episodes`` episodes (``n_envs`` envs, batched actions)."""
    n_envs = max(1, min(n_envs, n_episodes))
    envs = [Monitor(gym.make(env_id)) for _ in range(n_envs)]
    targets = [(n_episodes + i) // n_envs for i in range(n_envs)]
    counts = [0] * n_envs
    dtype = envs[0].observation_space.dtype
    observations = [env.reset(seed=seed + i)[0] for i, env in enumerate(envs)]
    returns: list[float] = []
    try:
        while any(c < t for c, t in zip(counts, targets)):
            actions, _ = model.predict(np.stack(observations).astype(dtype, copy=False), deterministic=True)
            for i, env in enumerate(envs):
                if counts[i] >= targets[i]:
                    continue  # this env has run its episodes: not stepped again
                obs, _, terminated, truncated, info = env.step(actions[i])
                if terminated or truncated:
                    returns.append(info["episode"]["r"])
                    counts[i] += 1
                    obs, _ = env.reset()
                observations[i] = obs
    finally:
        for env in envs:
            env.close()
    return np.asarray(returns, dtype=np.float64)
