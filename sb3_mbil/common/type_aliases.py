"""Typed expert data and minibatches (in the spirit of SB3's ``ReplayBufferSamples``).

Each is a ``NamedTuple`` of tensors on the algorithm's device: observations flat float32, Discrete
actions int64 of shape (n,), Box actions float32 of shape (n, action_dim). The whole dataset and a
minibatch have the same type; :func:`take` draws the minibatch.
"""

from __future__ import annotations

from typing import NamedTuple, TypeVar

import torch as th


class PairSamples(NamedTuple):
    """Expert (s, a) pairs: every step of every trajectory."""

    observations: th.Tensor
    actions: th.Tensor


class TransitionSamples(NamedTuple):
    """Expert (s, a, s') inside each trajectory; ``dones`` (float 0/1) marks a terminal s' (the episode
    ended by termination, not by a time limit), where nothing is bootstrapped."""

    observations: th.Tensor
    actions: th.Tensor
    next_observations: th.Tensor
    dones: th.Tensor


class TupleSamples(NamedTuple):
    """Consecutive expert (s, a, s', a') inside each trajectory (the last step of a trajectory has no a')."""

    observations: th.Tensor
    actions: th.Tensor
    next_observations: th.Tensor
    next_actions: th.Tensor


Samples = TypeVar("Samples", PairSamples, TransitionSamples, TupleSamples)


def take(samples: Samples, index: th.Tensor) -> Samples:
    """The rows ``index`` of every field."""
    return type(samples)(*(field[index] for field in samples))
