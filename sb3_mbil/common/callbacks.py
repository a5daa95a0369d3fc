"""Callbacks for training expert agents with rl_zoo3."""

from __future__ import annotations

import gymnasium as gym
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize, sync_envs_normalization, unwrap_vec_normalize


class StopTrainingOnReturn(BaseCallback):
    """Evaluate every ``eval_freq`` calls; stop training once the mean return reaches ``min_return``.

    Usable from rl_zoo3's ``callback`` hyperparameter, e.g.
    ``--hyperparams "callback:[{'sb3_mbil.common.callbacks.StopTrainingOnReturn': {'min_return': 3000}}]"``.

    :param min_return: mean return over ``n_eval_episodes`` that ends training
    :param eval_freq: calls between evaluations (env steps for one env)
    :param n_eval_episodes: deterministic evaluation episodes
    """

    def __init__(self, min_return: float, eval_freq: int = 10_000, n_eval_episodes: int = 10, verbose: int = 1):
        super().__init__(verbose)
        self.min_return = float(min_return)
        self.eval_freq = int(eval_freq)
        self.n_eval_episodes = int(n_eval_episodes)
        self.last_mean_return: float | None = None

    def _init_callback(self) -> None:
        env_id = self.training_env.get_attr("spec")[0].id
        eval_env = DummyVecEnv([lambda: Monitor(gym.make(env_id))])
        train_norm = unwrap_vec_normalize(self.training_env)
        if train_norm is not None:
            eval_env = VecNormalize(eval_env, training=False, norm_reward=False)
        self.eval_env = eval_env

    def _on_step(self) -> bool:
        if self.n_calls % self.eval_freq != 0:
            return True
        sync_envs_normalization(self.training_env, self.eval_env)
        self.last_mean_return, _ = evaluate_policy(self.model, self.eval_env, self.n_eval_episodes, deterministic=True)
        self.logger.record("eval/stop_check_return", self.last_mean_return)
        if self.last_mean_return >= self.min_return:
            if self.verbose:
                print(f"Stopping: mean return {self.last_mean_return:.1f} >= {self.min_return} at {self.num_timesteps} steps")
            return False
        return True
