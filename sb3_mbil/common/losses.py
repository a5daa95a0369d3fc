"""The behaviour-cloning loss L_BC(pi, D), shared by BC and MBIL (the beta term), and the logit penalty of BC and MBIL-C."""

from __future__ import annotations

from collections.abc import Sequence

import torch as th
from gymnasium import spaces

from sb3_mbil.common.policies import LOG_2PI, ImitationPolicy
from sb3_mbil.common.validation import check_real

BC_LOSSES = ("nll", "mse", "tanh_nll")
#: the actions' distance from the bounds, in units of the half range, below which ``"tanh_nll"`` clips them (atanh is
#: infinite at the bounds, where a SAC expert's actions often sit; google-research's BC clips at the same margin)
TANH_NLL_MARGIN = 1e-4


def resolve_bc_loss(kind: str, action_space: spaces.Space, allowed: Sequence[str] = BC_LOSSES,
                    bounded_mean: bool = False) -> str:
    """``"auto"``: negative log-likelihood for Discrete, MSE of the mean action for Box (the paper's choice).
    ``allowed``: the losses the algorithm implements; ``bounded_mean``: the policy's (``"tanh_nll"`` needs it)."""
    if kind == "auto":
        return "nll" if isinstance(action_space, spaces.Discrete) else "mse"
    if kind not in allowed:
        raise ValueError(f"bc_loss: expected one of 'auto', {', '.join(map(repr, allowed))}, found {kind!r}")
    if kind in ("mse", "tanh_nll") and isinstance(action_space, spaces.Discrete):
        raise ValueError(f"bc_loss: expected 'nll' or 'auto' for Discrete actions, found {kind!r}")
    if kind == "tanh_nll" and not bounded_mean:
        raise ValueError("policy_kwargs: bc_loss='tanh_nll' is the likelihood of a tanh-squashed Gaussian, expected "
                         "bounded_mean=True, found bounded_mean=False")
    return kind


def tanh_gaussian_log_prob(policy: ImitationPolicy, raw_heads: Sequence[th.Tensor], actions: th.Tensor) -> th.Tensor:
    """log pi(a | s) of the tanh-squashed Gaussian a = center + half_range * tanh(u), u ~ N(raw mean, std) (SAC's and
    ValueDICE's actor; ``raw_heads = policy.raw_heads(s)``): the Gaussian log-density of u = atanh(y),
    y = (a - center) / half_range clipped to [-1 + margin, 1 - margin], minus the log-Jacobian sum log(half_range (1 - y^2))."""
    raw_mean, log_std = raw_heads
    y = ((actions.view_as(raw_mean) - policy.action_center) / policy.action_half_range).clamp(
        -1.0 + TANH_NLL_MARGIN, 1.0 - TANH_NLL_MARGIN)
    z = (th.atanh(y) - raw_mean) * th.exp(-log_std)
    log_jacobian = th.log(policy.action_half_range * (1.0 - y.pow(2)))
    return (-0.5 * z.pow(2) - log_std - 0.5 * LOG_2PI - log_jacobian).sum(dim=1)


def bc_heads(policy: ImitationPolicy, observations: th.Tensor, kind: str) -> tuple[th.Tensor, ...]:
    """The policy outputs :func:`bc_loss` of ``kind`` reads: ``policy.raw_heads(s)`` for ``"tanh_nll"`` (the squashed
    Gaussian's likelihood is written in its pre-squash parameters), ``policy.heads(s)`` otherwise."""
    return policy.raw_heads(observations) if kind == "tanh_nll" else policy.heads(observations)


def bc_loss(policy: ImitationPolicy, heads: Sequence[th.Tensor], actions: th.Tensor, kind: str,
            log_prob: th.Tensor | None = None) -> th.Tensor:
    """L_BC from the policy's outputs at the expert states (``policy.heads(s)``).

    ``"nll"``: -E[log pi(a|s)] (pass ``log_prob`` if already computed); ``"mse"`` (Box actions):
    E[(mean(s) - a)^2]; ``"tanh_nll"`` (Box, ``bounded_mean``): -E[log pi(a|s)] of the tanh-squashed Gaussian, with
    ``heads = policy.raw_heads(s)``.
    """
    if kind == "tanh_nll":
        return -tanh_gaussian_log_prob(policy, heads, actions).mean()
    if kind == "nll":
        if log_prob is None and policy.discrete:  # torch's fused op: the same gradient, bit for bit, in fewer ops
            return th.nn.functional.cross_entropy(heads[0], actions.long().view(-1))
        return -(policy.log_prob_from_heads(heads, actions) if log_prob is None else log_prob).mean()
    return (heads[0] - actions.view_as(heads[0])).pow(2).mean()


def check_discrete_weight(name: str, value: float, action_space: spaces.Space, high: float | None = None) -> float:
    """The weight of a term of a categorical policy (:func:`logit_penalty`, BC's label smoothing): a finite number
    >= 0 (and <= ``high``), and 0 unless the actions are Discrete."""
    value = check_real(name, value, low=0.0, high=high)
    if value > 0 and not isinstance(action_space, spaces.Discrete):
        raise ValueError(f"{name}: expected 0 for {type(action_space).__name__} actions (a term of a categorical "
                         f"policy), found {value}")
    return value


def check_logit_penalty(value: float, action_space: spaces.Space) -> float:
    """The weight of :func:`logit_penalty`: a finite number >= 0, and 0 unless the actions are Discrete."""
    return check_discrete_weight("logit_penalty", value, action_space)


def uniform_cross_entropy(heads: Sequence[th.Tensor]) -> th.Tensor:
    """E_s[-mean_b log pi(b|s)]: the cross-entropy of a categorical policy against the uniform label (the part of
    label smoothing that the observed action does not carry)."""
    return -th.log_softmax(heads[0], dim=-1).mean()


def logit_penalty(heads: Sequence[th.Tensor]) -> th.Tensor:
    """d3rlpy's DiscreteBC regulariser: the mean over the minibatch and the actions of the squared logits."""
    return heads[0].pow(2).mean()
