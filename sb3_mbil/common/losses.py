"""The behaviour-cloning loss L_BC(pi, D), shared by BC and MBIL (the beta term), and the logit penalty of BC and MBIL-C."""

from __future__ import annotations

from collections.abc import Sequence

import torch as th
from gymnasium import spaces

from sb3_mbil.common.policies import ImitationPolicy
from sb3_mbil.common.validation import check_real

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


def bc_loss(policy: ImitationPolicy, heads: Sequence[th.Tensor], actions: th.Tensor, kind: str,
            log_prob: th.Tensor | None = None) -> th.Tensor:
    """L_BC from the policy's outputs at the expert states (``policy.heads(s)``).

    ``"nll"``: -E[log pi(a|s)] (pass ``log_prob`` if already computed); ``"mse"`` (Box actions):
    E[(mean(s) - a)^2].
    """
    if kind == "nll":
        return -(policy.log_prob_from_heads(heads, actions) if log_prob is None else log_prob).mean()
    return (heads[0] - actions.view_as(heads[0])).pow(2).mean()


def check_logit_penalty(value: float, action_space: spaces.Space) -> float:
    """The weight of :func:`logit_penalty`: a finite number >= 0, and 0 unless the actions are Discrete."""
    value = check_real("logit_penalty", value, low=0.0)
    if value > 0 and not isinstance(action_space, spaces.Discrete):
        raise ValueError(f"logit_penalty: expected 0 for {type(action_space).__name__} actions (it penalises a "
                         f"categorical policy's logits), found {value}")
    return value


def logit_penalty(heads: Sequence[th.Tensor]) -> th.Tensor:
    """d3rlpy's DiscreteBC regulariser: the mean over the minibatch and the actions of the squared logits."""
    return heads[0].pow(2).mean()
