"""Evaluation of a policy on many episodes with vectorised envs and batched inference (SB3's evaluate_policy)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv


def evaluate(model: BaseAlgorithm, env_id: str, n_episodes: int = 100, seed: int = 0, n_envs: int = 10) -> np.ndarray:
    """Returns of the deterministic policy over ``n_episodes`` episodes (``n_envs`` envs stepped together)."""
    n_envs = max(1, min(n_envs, n_episodes))
    env = DummyVecEnv([lambda: Monitor(gym.make(env_id)) for _ in range(n_envs)])
    env.seed(seed)
    returns, _ = evaluate_policy(model, env, n_eval_episodes=n_episodes, deterministic=True, return_episode_rewards=True)
    env.close()
    return np.asarray(returns, dtype=np.float64)
