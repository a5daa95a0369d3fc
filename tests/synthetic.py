"""Synthetic MDPs whose dynamics T and expert policy pi_D are known in closed form.

* ``LinearGaussianMDP``: s' = A s + B a + N(0, sigma_s^2 I), pi_D(a|s) = N(K s, sigma_a^2 I).
* ``DiscreteActionMDP``: s' = A s + B[:, a] + N(0, sigma_s^2 I), pi_D(a|s) = softmax(W s).

Each gives a gymnasium env (for the spaces), expert trajectories and the true
log T(s'|s,a) and log pi_D(a|s).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

LOG_2PI = math.log(2 * math.pi)


def _normal_logpdf(x: np.ndarray, mean: np.ndarray, std: float) -> np.ndarray:
    z = (x - mean) / std
    return (-0.5 * z**2 - math.log(std) - 0.5 * LOG_2PI).sum(axis=-1)


class _SpacesEnv(gym.Env):
    def __init__(self, observation_space, action_space, mdp):
        self.observation_space = observation_space
        self.action_space = action_space
        self.mdp = mdp
        self._s = None

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._s = self.np_random.normal(size=self.observation_space.shape).astype(np.float32)
        return self._s, {}

    def step(self, action):
        self._s = self.mdp.step(self._s, action, self.np_random).astype(np.float32)
        return self._s, 0.0, False, False, {}


class _MDP:
    action_dtype = np.float32

    def trajectories(self, n: int, length: int, seed: int):
        """n expert trajectories of ``length`` steps, s_0 ~ N(0, I)."""
        rng = np.random.default_rng(seed)
        out = []
        for _ in range(n):
            s = rng.normal(size=2)
            obs, acts = [s], []
            for _ in range(length):
                a = self.expert_action(s, rng)
                s = self.step(s, a, rng)
                obs.append(s)
                acts.append(a)
            out.append((np.array(obs, dtype=np.float32), np.array(acts, dtype=self.action_dtype)))
        return out


class LinearGaussianMDP(_MDP):
    A = np.array([[0.9, 0.2], [-0.2, 0.8]])
    B = np.array([[0.0], [0.6]])
    K = np.array([[0.3, -0.6]])
    sigma_s = 0.2
    sigma_a = 0.3

    def make_env(self) -> gym.Env:
        obs = spaces.Box(-np.inf, np.inf, (2,), np.float32)
        act = spaces.Box(-10.0, 10.0, (1,), np.float32)
        return _SpacesEnv(obs, act, self)

    def step(self, s, a, rng):
        return self.A @ s + self.B @ np.atleast_1d(a) + self.sigma_s * rng.normal(size=2)

    def expert_action(self, s, rng):
        return self.K @ s + self.sigma_a * rng.normal(size=1)

    def log_t(self, s, a, s_next):
        mean = s @ self.A.T + a.reshape(len(a), -1) @ self.B.T
        return _normal_logpdf(s_next, mean, self.sigma_s)

    def log_pi(self, s, a):
        return _normal_logpdf(a.reshape(len(a), -1), s @ self.K.T, self.sigma_a)



class DiscreteActionMDP(_MDP):
    action_dtype = np.int64
    A = np.array([[0.85, 0.25], [-0.25, 0.85]])
    B = np.array([[0.5, -0.5, 0.0], [0.0, 0.0, 0.6]])
    W = np.array([[2.0, 0.0], [-2.0, 0.5], [0.0, -1.5]])
    sigma_s = 0.2

    def make_env(self) -> gym.Env:
        obs = spaces.Box(-np.inf, np.inf, (2,), np.float32)
        return _SpacesEnv(obs, spaces.Discrete(3), self)

    def step(self, s, a, rng):
        return self.A @ s + self.B[:, int(a)] + self.sigma_s * rng.normal(size=2)

    def probs(self, s):
        logits = np.atleast_2d(s) @ self.W.T
        logits -= logits.max(axis=1, keepdims=True)
        p = np.exp(logits)
        return p / p.sum(axis=1, keepdims=True)

    def log_t(self, s, a, s_next):
        mean = s @ self.A.T + self.B[:, a.astype(int).reshape(-1)].T
        return _normal_logpdf(s_next, mean, self.sigma_s)

    def log_pi(self, s, a):
        return np.log(self.probs(s)[np.arange(len(s)), a.astype(int).reshape(-1)])

    def expert_action(self, s, rng):
        return int(rng.choice(3, p=self.probs(s)[0]))
