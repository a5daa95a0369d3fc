"""Shared by the library's tests (tests/) and the harness's (benchmarks/tests/): fixtures, tests/ helpers on the
path (the harness is the checkout's ``benchmarks`` package)."""

import os
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch as th

_REPO = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(_REPO, "tests"))
sys.path.insert(0, _REPO)
os.environ.setdefault("HF_HUB_OFFLINE", "1")

#: fixtures of tests/ helpers that both suites use
pytest_plugins = ["toy_algorithm"]
th.set_num_threads(1)


def cartpole_expert(obs):
    return int(obs[2] + 0.5 * obs[3] > 0)


def pendulum_expert(obs):
    cos, sin, vel = obs
    theta = np.arctan2(sin, cos)
    return np.clip([-8.0 * theta - 1.5 * vel], -2.0, 2.0).astype(np.float32)


def rollouts(env_id, policy, n, seed=0, max_steps=None):
    env = gym.make(env_id)
    out = []
    for ep in range(n):
        obs, _ = env.reset(seed=seed + ep)
        observations, actions = [obs], []
        while True:
            action = policy(obs)
            obs, _, terminated, truncated, _ = env.step(action)
            observations.append(obs)
            actions.append(action)
            if terminated or truncated or (max_steps and len(actions) >= max_steps):
                break
        out.append((np.array(observations), np.array(actions)))
    return out


@pytest.fixture(scope="session")
def cartpole_data():
    return rollouts("CartPole-v1", cartpole_expert, 2, max_steps=200)


@pytest.fixture(scope="session")
def pendulum_data():
    return rollouts("Pendulum-v1", pendulum_expert, 2, max_steps=100)
