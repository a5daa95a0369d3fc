"""Evaluation steps only the envs that still owe episodes, and returns exactly what SB3's evaluate_policy does."""

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv

from sb3_mbil import BC, load_demonstrations
from sb3_mbil.common.evaluation import evaluate
from sb3_mbil.experts.controllers import controller_demonstrations


def sb3_returns(model, env_id, n_episodes, seed, n_envs):
    env = DummyVecEnv([lambda: Monitor(gym.make(env_id)) for _ in range(n_envs)])
    env.seed(seed)
    returns, _ = evaluate_policy(model, env, n_eval_episodes=n_episodes, deterministic=True, return_episode_rewards=True)
    return np.asarray(returns, dtype=np.float64)


@pytest.mark.parametrize("env_id, n_episodes, n_envs", [("CartPole-v1", 7, 3), ("LunarLander-v3", 5, 5),
                                                         ("Pendulum-v1", 4, 3)])
def test_returns_equal_sb3s_evaluate_policy(env_id, n_episodes, n_envs):
    data = controller_demonstrations("Pendulum-v1", 1, seed=0) if env_id == "Pendulum-v1" else \
        load_demonstrations(env_id).sample(1, seed=0)
    model = BC("MlpPolicy", env_id, expert_data=data, seed=0).learn(200)
    ours = evaluate(model, env_id, n_episodes, seed=11, n_envs=n_envs)
    np.testing.assert_array_equal(ours, sb3_returns(model, env_id, n_episodes, 11, n_envs))


def test_finished_envs_are_not_stepped(monkeypatch):
    model = BC("MlpPolicy", "CartPole-v1", expert_data=load_demonstrations("CartPole-v1").sample(1, seed=0), seed=0)
    steps = {"n": 0}
    real = Monitor.step

    def counting(self, action):
        steps["n"] += 1
        return real(self, action)

    monkeypatch.setattr(Monitor, "step", counting)
    returns = evaluate(model, "CartPole-v1", 3, seed=0, n_envs=3)  # one episode each: no step after an episode ends
    assert steps["n"] == int(returns.sum())  # CartPole pays 1 per step
