"""Held-out validation without the env: hold out blocks of expert steps, score the model on them during
training, stop early and keep the best model (the offline counterpart of SB3's ``EvalCallback``).

With one expert trajectory the best point of training comes early and late training can collapse;
a return cannot be measured offline, the loss on held-out expert steps can.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback

from sb3_mbil.common.demonstrations import Demonstrations, Trajectory
from sb3_mbil.common.validation import check_int, check_real


def split_blocks(demos: Demonstrations, fraction: float, block_length: int = 50,
                 seed: int = 0) -> tuple[Demonstrations, Demonstrations]:
    """Cut every trajectory into blocks of ``block_length`` consecutive steps and hold out ``fraction`` of the
    blocks (at least one, never all), drawn with ``seed``.

    Returns (training, held-out) demonstrations whose trajectories are the contiguous runs of kept (or held-out)
    steps: each piece keeps its steps' true next observations, so (s, a, s') and (s, a, s', a') never join two
    pieces, and only a piece that ends where its episode ended keeps the episode's ``terminated``.
    """
    fraction = check_real("holdout_fraction", fraction, low=0.0, high=1.0, low_open=True, high_open=True)
    block_length = check_int("block_length", block_length, low=1)
    blocks = [(i, start) for i, t in enumerate(demos) for start in range(0, len(t), block_length)]
    if len(blocks) < 2:
        raise ValueError(f"expert_data: expected at least 2 blocks of {block_length} steps to hold one out, found "
                         f"{len(blocks)} ({demos.n_steps} steps); lower block_length")
    n_held = min(max(1, int(round(fraction * len(blocks)))), len(blocks) - 1)
    held = {blocks[k] for k in np.random.default_rng(seed).choice(len(blocks), size=n_held, replace=False)}
    train, heldout = [], []
    for i, t in enumerate(demos):
        mask = np.zeros(len(t), dtype=bool)
        for start in range(0, len(t), block_length):
            mask[start : start + block_length] = (i, start) in held
        # runs of equal mask value
        edges = np.flatnonzero(np.diff(mask.astype(np.int8))) + 1
        for lo, hi in zip(np.r_[0, edges], np.r_[edges, len(t)]):
            last = hi == len(t)
            n_obs = hi - lo + 1 if (not last or t.has_final_observation) else hi - lo
            piece = Trajectory(t.observations[lo : lo + n_obs], t.actions[lo:hi],
                               terminated=t.terminated and last, truncated=t.truncated and last)
            (heldout if mask[lo] else train).append(piece)
    meta = {**demos.metadata}
    return (Demonstrations(train, {**meta, "holdout": "training blocks"}),
            Demonstrations(heldout, {**meta, "holdout": "held-out blocks"}))


class ValidationCallback(BaseCallback):
    """Hold out blocks of the expert data, log the model's losses on them every ``eval_freq`` gradient steps, keep
    the best model and optionally stop early. Never touches the env.

    At the start of the first ``learn`` the model's expert data is split (:func:`split_blocks`); the model then
    trains on the training blocks only (set before anything is fitted, e.g. MBIL's flows). Logged:
    ``validation/<loss>`` for every loss of ``model.validation_losses`` (the behaviour-cloning loss; MBIL adds its
    balance loss) and ``validation/best_<monitor>``.

    :param holdout_fraction: share of the blocks held out
    :param eval_freq: gradient steps between validations
    :param block_length: steps per block (consecutive steps are correlated: hold out whole blocks)
    :param monitor: the loss that picks the best model (``"bc_loss"``; ``"balance_loss"`` for MBIL)
    :param patience: validations without an improvement of more than ``min_delta`` before training stops
        (``None``: never stop early)
    :param min_delta: the smallest decrease that counts as an improvement
    :param best_model_save_path: folder for ``best_model.zip`` (``None``: not saved)
    :param restore_best: at the end of training, put the best parameters back into the model
    :param seed: seed of the block draw
    :param verbose: 1 prints each validation
    """

    def __init__(self, holdout_fraction: float = 0.2, eval_freq: int = 500, block_length: int = 50,
                 monitor: str = "bc_loss", patience: int | None = None, min_delta: float = 0.0,
                 best_model_save_path: str | os.PathLike | None = None, restore_best: bool = False, seed: int = 0,
                 verbose: int = 0):
        super().__init__(verbose)
        self.holdout_fraction = check_real("holdout_fraction", holdout_fraction, low=0.0, high=1.0, low_open=True,
                                           high_open=True)
        self.eval_freq = check_int("eval_freq", eval_freq, low=1)
        self.block_length = check_int("block_length", block_length, low=1)
        self.monitor = monitor
        self.patience = None if patience is None else check_int("patience", patience, low=1)
        self.min_delta = check_real("min_delta", min_delta, low=0.0)
        self.best_model_save_path = None if best_model_save_path is None else Path(best_model_save_path)
        self.restore_best = bool(restore_best)
        self.seed = check_int("seed", seed, low=0)
        self.heldout: Demonstrations | None = None
        self.best = float("inf")
        self.best_step: int | None = None
        self.history: list[tuple[int, dict[str, float]]] = []
        self._best_state: dict | None = None
        self._bad_validations = 0

    def _on_training_start(self) -> None:
        if self.heldout is None:
            train, self.heldout = split_blocks(self.model.demonstrations(), self.holdout_fraction, self.block_length,
                                               self.seed)
            self.model.set_expert_data(train)

    def _on_step(self) -> bool:
        if self.n_calls % self.eval_freq != 0:
            return True
        losses = self.model.validation_losses(self.heldout)
        if self.monitor not in losses:
            raise ValueError(f"monitor: expected one of {sorted(losses)} for {type(self.model).__name__}, "
                             f"found {self.monitor!r}")
        self.history.append((self.num_timesteps, losses))
        for key, value in losses.items():
            self.logger.record(f"validation/{key}", value)
        value = losses[self.monitor]
        if value < self.best - self.min_delta:
            self.best, self.best_step, self._bad_validations = value, self.num_timesteps, 0
            self._best_state = {name: copy.deepcopy(module.state_dict()) for name, module in self.model.torch_modules().items()}
            if self.best_model_save_path is not None:
                self.model.save(self.best_model_save_path / "best_model.zip")
        else:
            self._bad_validations += 1
        self.logger.record(f"validation/best_{self.monitor}", self.best)
        if self.verbose >= 1:
            print(f"Validation num_timesteps={self.num_timesteps}, "
                  + ", ".join(f"{k}={v:.4g}" for k, v in losses.items()) + f" (best {self.best:.4g} at {self.best_step})")
        return self.patience is None or self._bad_validations < self.patience

    def _on_training_end(self) -> None:
        if self.restore_best and self._best_state is not None:
            for name, module in self.model.torch_modules().items():
                module.load_state_dict(self._best_state[name])
