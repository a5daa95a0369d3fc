"""The behaviour-cloning loss L_BC(pi, D), shared by BC and MBIL (the beta term)."""

from __future__ import annotations

import torch as th
from gymnasium import spaces

from sb3_mbil.common.policies import ImitationPolicy

BC_LOSSES = ("nll", "mse")


def resolve_bc_loss(kind: str, action_space: spaces.Space) -> str:
    """``"auto"``: negative log-likelihood for Discrete, MSE of the mean action for Box (the paper's choice)."""
    if kind == "auto":
        return "nll" if isinstance(action_space, spaces.Discrete) else "mse"
    if kind not in BC_LOSSES:
        raise ValueError(f"bc_loss: expected one of 'auto', {', '.join(map(repr, BC_LOSSES))}, found {kind!r}")
    if kind == "mse" and isinstance(action_space, spaces.Discrete):
        raise ValueError("bc_loss: expected 'nll' or 'auto' for Discrete actions, found 'mse'")
    return kind


def bc_loss(policy: ImitationPolicy, observations: th.Tensor, actions: th.Tensor, kind: str) -> th.Tensor:
    """L_BC: -E[log pi(a|s)] (``"nll"``) or E[||mean(s) - a||^2] (``"mse"``, Box actions)."""
    if kind == "nll":
        return -policy.log_prob(observations, actions).mean()
    return (policy.mean_action(observations) - actions).pow(2).mean()
