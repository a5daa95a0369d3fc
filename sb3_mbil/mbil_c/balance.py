"""MBIL-C's balance term: the divergences D(P || pi), and the targets P's fitted conditionals give the policy, in
one typed record computed once per fitted models and data."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import torch as th

from sb3_mbil.common.policies import ImitationPolicy

DIVERGENCES = ("auto", "kl", "w2")


def balance_w2(target: Sequence[th.Tensor], heads: Sequence[th.Tensor]) -> th.Tensor:
    """Squared 2-Wasserstein distance between diagonal Gaussians P(. | s, a, s') and pi(. | s') per row:
    ``|mean_P - mean_pi|^2 + |std_P - std_pi|^2``. Zero exactly where KL is, but in the action's units, like
    the MSE behaviour-cloning term (KL weighs the mean gap by 1 / std_pi^2, which a near-deterministic expert
    makes huge)."""
    mean_p, log_std_p = target
    mean_pi, log_std_pi = heads
    return ((mean_p - mean_pi).pow(2) + (log_std_p.exp() - log_std_pi.exp()).pow(2)).sum(dim=1)


def balance_divergence(kind: str, policy: ImitationPolicy, target: Sequence[th.Tensor], heads: Sequence[th.Tensor]) -> th.Tensor:
    """D( P(. | s, a, s') || pi(. | s') ) per row: ``"kl"`` or ``"w2"`` (Box only)."""
    return balance_kl(policy, target, heads) if kind == "kl" else balance_w2(target, heads)


def balance_kl(policy: ImitationPolicy, target: Sequence[th.Tensor], heads: Sequence[th.Tensor]) -> th.Tensor:
    """KL( P(. | s, a, s') || pi(. | s') ) per row, exact: categorical against categorical (Discrete), diagonal
    Gaussian against diagonal Gaussian in raw action units (Box). ``target`` is P's ``(log_probs,)`` or
    ``(mean, log_std)``, ``heads`` the policy's at s'."""
    if policy.discrete:
        (log_p,) = target
        log_pi = th.log_softmax(heads[0], dim=-1)
        return (log_p.exp() * (log_p - log_pi)).sum(dim=1)
    mean_p, log_std_p = target
    mean_pi, log_std_pi = heads
    ratio = th.exp(2.0 * (log_std_p - log_std_pi))
    gap = (mean_p - mean_pi) * th.exp(-log_std_pi)
    return (log_std_pi - log_std_p + 0.5 * (ratio + gap.pow(2) - 1.0)).sum(dim=1)


@dataclass
class BalanceTargets:
    """What the policy is fitted to, computed once per fitted models and data (:meth:`MBILC.balance_targets`).

    At the data, per expert pair (s', a'): P(. | s, a, s') of its predecessor tuple (s, a, s'), zero where the pair
    opens a trajectory (``has_target`` False; ``weight`` is ``has_target`` divided by its mean, so the balance term
    is the mean over the pairs that have a predecessor). Orphans are tuples whose s' is no expert pair's state
    (subsampled data); model states are T's draws s~' (or corrective states).
    """

    has_target: th.Tensor
    weight: th.Tensor
    #: share of the tuples whose s' is an expert pair's state (the rest are orphans)
    inner_share: float
    #: P(. | s, a, s') per expert pair: ``(log_probs,)`` (Discrete) or ``(mean, log_std)`` (Box)
    data: tuple[th.Tensor, ...]
    #: (Discrete) P's probabilities at the data (0 without a predecessor) and sum P log P per pair
    probs: th.Tensor | None = None
    neg_entropy: th.Tensor | None = None
    #: (Discrete) beta * onehot(a) + alpha * w * P, and the (alpha, beta) it was made with
    soft_labels: th.Tensor | None = None
    label_weights: tuple[float, float] | None = None
    #: the orphans' s' and P(. | s, a, s') there
    orphan_states: th.Tensor | None = None
    orphan_target: tuple[th.Tensor, ...] | None = None
    #: model states: T's draws s~' (``model_labels="balance"``) or corrective states s~ (``"corrective"``)
    states: th.Tensor | None = None
    #: P(. | s, a, s~') at the model states (``"balance"``)
    model: tuple[th.Tensor, ...] | None = None
    #: (``"corrective"``) the perturbed actions a~ and the tuple each kept label came from
    model_actions: th.Tensor | None = None
    model_tuples: th.Tensor | None = None


class Draws(NamedTuple):
    """One update's rows, gathered from :class:`BalanceTargets` (tensors only, ``None`` for what the update does not
    use), so that the loss reads nothing of the model's caches and seeds can train in lockstep."""

    states: th.Tensor  # expert states s_i
    actions: th.Tensor  # their actions a_i
    #: (Discrete, KL, no model or orphan states) beta * onehot(a_i) + alpha * w_i * P(. | s, a, s_i): the fused update
    soft_labels: th.Tensor | None
    weight: th.Tensor | None  # w_i: 0 where s_i opens a trajectory, mean 1
    probs: th.Tensor | None  # (Discrete) P(. | s, a, s_i)
    neg_entropy: th.Tensor | None  # (Discrete) sum P log P
    data: tuple[th.Tensor, ...] | None  # P(. | s, a, s_i) as ``(log_probs,)`` or ``(mean, log_std)``
    model_states: th.Tensor | None  # model states s~_j
    model: tuple[th.Tensor, ...] | None  # P(. | s, a, s~_j) (``model_labels="balance"``)
    model_actions: th.Tensor | None  # a~_j (``model_labels="corrective"``)
    orphan_states: th.Tensor | None  # orphans' s'_k
    orphan_target: tuple[th.Tensor, ...] | None  # P(. | s, a, s'_k)
    inner_share: th.Tensor | None  # (with orphans) the share of the tuples that are not orphans
