"""Callbacks for training expert agents with rl_zoo3."""

from __future__ import annotations

import os
from pathlib import Path

import gymnasium as gym
import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize, sync_envs_normalization, unwrap_vec_normalize


class StopTrainingOnReturn(BaseCallback):
    """Evaluate every ``eval_freq`` calls; stop training once the mean return reaches ``min_return`` (and, with
    ``min_full_fraction``, once that share of the evaluation episodes runs to the time limit without falling).

    Usable from rl_zoo3's ``callback`` hyperparameter, e.g.
    ``--hyperparams "callback:[{'sb3_mbil.common.callbacks.StopTrainingOnReturn': {'min_return': 3000}}]"``.

    :param min_return: mean return over ``n_eval_episodes`` that ends training
    :param eval_freq: calls between evaluations (env steps for one env)
    :param n_eval_episodes: deterministic evaluation episodes
    :param min_full_fraction: share of the evaluation episodes that must reach the env's time limit (not end in a
        terminal state) before training stops; 0 checks the return alone. The episodes run in chunks of
        ``chunk_episodes``, and a check stops as soon as more episodes have fallen than this share allows (it has
        failed whatever the rest do).
    :param chunk_episodes: episodes per chunk of that check
    """

    def __init__(self, min_return: float, eval_freq: int = 10_000, n_eval_episodes: int = 10,
                 min_full_fraction: float = 0.0, chunk_episodes: int = 10, verbose: int = 1):
        super().__init__(verbose)
        if int(chunk_episodes) < 1:
            raise ValueError(f"chunk_episodes: expected an integer >= 1, found {chunk_episodes!r}")
        self.chunk_episodes = int(chunk_episodes)
        self.last_eval_episodes = 0
        self.min_return = float(min_return)
        self.min_full_fraction = float(min_full_fraction)
        self.last_full_fraction: float | None = None
        self.eval_freq = int(eval_freq)
        self.n_eval_episodes = int(n_eval_episodes)
        self.last_mean_return: float | None = None

    def _init_callback(self) -> None:
        env_id = self.training_env.get_attr("spec")[0].id
        eval_env = DummyVecEnv([lambda: Monitor(gym.make(env_id))])
        train_norm = unwrap_vec_normalize(self.training_env)
        if train_norm is not None:
            eval_env = VecNormalize(eval_env, training=False, norm_reward=False)
        if self.model.seed is not None:
            eval_env.seed(self.model.seed)  # the same evaluation episodes on every machine and every run
        self.eval_env = eval_env
        self.time_limit = gym.spec(env_id).max_episode_steps

    def _on_step(self) -> bool:
        if self.n_calls % self.eval_freq != 0:
            return True
        sync_envs_normalization(self.training_env, self.eval_env)
        # episodes in chunks: once more episodes have fallen than min_full_fraction allows, the check has failed
        # and the rest is not run (a 100-episode check of a model that falls often costs a chunk or two)
        allowed_falls = int(np.floor(self.n_eval_episodes * (1.0 - self.min_full_fraction) + 1e-9))
        returns: list[float] = []
        falls = 0
        while len(returns) < self.n_eval_episodes:
            n = min(self.chunk_episodes, self.n_eval_episodes - len(returns))
            chunk_returns, lengths = evaluate_policy(self.model, self.eval_env, n, deterministic=True,
                                                     return_episode_rewards=True)
            returns += [float(r) for r in chunk_returns]
            falls += int(np.sum(np.asarray(lengths) < self.time_limit)) if self.time_limit else 0
            if self.min_full_fraction > 0 and falls > allowed_falls:
                break
        self.last_eval_episodes = len(returns)
        self.last_mean_return = float(np.mean(returns))
        self.last_full_fraction = 1.0 - falls / len(returns)
        self.logger.record("eval/stop_check_return", self.last_mean_return)
        self.logger.record("eval/stop_check_full_fraction", self.last_full_fraction)
        if self.last_mean_return >= self.min_return and self.last_full_fraction >= self.min_full_fraction:
            if self.verbose:
                print(f"Stopping: mean return {self.last_mean_return:.1f} >= {self.min_return}, "
                      f"{self.last_full_fraction:.0%} of the episodes to the time limit at {self.num_timesteps} steps")
            return False
        return True


class ResumableCheckpoint(CheckpointCallback):
    """SB3's CheckpointCallback with the replay buffer and VecNormalize statistics, written so that a
    checkpoint is whole or absent, keeping only the newest ``keep`` checkpoints.

    Each file is written under a temporary name and renamed; the model zip comes last, so a
    ``rl_model_<steps>_steps.zip`` means its replay buffer is complete (what a continuation with
    rl_zoo3's ``-i`` needs). Older checkpoints are deleted: a SAC replay buffer of 1e6 transitions
    is hundreds of MB per checkpoint.

    :param save_freq: calls between checkpoints (env steps for one env)
    :param save_path: folder of the checkpoints
    :param keep: how many of the newest checkpoints to keep
    """

    def __init__(self, save_freq: int, save_path: str, keep: int = 2, name_prefix: str = "rl_model", verbose: int = 0):
        super().__init__(save_freq, save_path, name_prefix, save_replay_buffer=True, save_vecnormalize=True, verbose=verbose)
        if keep < 1:
            raise ValueError(f"keep: expected an integer >= 1, found {keep!r}")
        self.keep = int(keep)

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq != 0:
            return True
        writers = []
        if getattr(self.model, "replay_buffer", None) is not None:
            writers.append((self._checkpoint_path("replay_buffer_", extension="pkl"), self.model.save_replay_buffer))
        if self.model.get_vec_normalize_env() is not None:
            writers.append((self._checkpoint_path("vecnormalize_", extension="pkl"), self.model.get_vec_normalize_env().save))
        writers.append((self._checkpoint_path(extension="zip"), self.model.save))  # last: it marks the checkpoint whole
        for path, save in writers:
            final = Path(path)
            tmp = final.with_name(f"tmp_{final.name}")
            save(str(tmp))
            os.replace(tmp, final)
            if self.verbose >= 2:
                print(f"Saving checkpoint file to {final}")
        self._prune()
        return True

    def _prune(self) -> None:
        folder = Path(self.save_path)
        prefix = f"{self.name_prefix}_"
        steps = sorted(int(p.stem[len(prefix):-len("_steps")]) for p in folder.glob(f"{prefix}*_steps.zip")
                       if p.stem[len(prefix):-len("_steps")].isdigit())
        for old in steps[:-self.keep]:
            for name in (f"{prefix}{old}_steps.zip", f"{prefix}replay_buffer_{old}_steps.pkl", f"{prefix}vecnormalize_{old}_steps.pkl"):
                (folder / name).unlink(missing_ok=True)
