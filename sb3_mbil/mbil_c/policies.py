"""Networks of MBIL-C: the policy pi_theta (shared with BC and MBIL) and the balance model (P_eta and T_psi).

* ``P_eta(a' | s, a, s')``: a categorical (Discrete) or a diagonal Gaussian in raw action units (Box);
  the policy's distribution has the same form, so KL(P_eta || pi) is exact and in closed form.
* ``T_psi(s' | s, a)``: a diagonal Gaussian over the next state in raw units; its samples are the states
  beyond the data at which the balance equation is also imposed.

Both are MLPs (not flows): MBIL-C needs P's whole conditional over a' and samples of T, not a
log-density at the data, and a small MLP is fitted in a fraction of a second.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch as th
from gymnasium import spaces
from torch import nn

from sb3_mbil.common.flows import ConditionalCategorical, ConditionalGaussian, TupleInputs
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["BalanceModel", "ImitationPolicy", "MlpPolicy"]


class BalanceModel(TupleInputs):
    """P_eta(a' | s, a, s') and T_psi(s' | s, a).

    :param obs_dim: flat observation dimension
    :param action_space: Discrete or Box
    :param hidden: hidden sizes of both MLPs
    :param residual_transition: T models the change s' - s (a Gaussian whose mean is added to s), as model-based RL and
        CCIL do, instead of s' itself: the identity part of the dynamics is then exact, not learned
    """

    def __init__(self, obs_dim: int, action_space: spaces.Space, hidden: Sequence[int] = (64, 64),
                 residual_transition: bool = False):
        super().__init__(obs_dim, action_space)
        self.hidden = tuple(hidden)
        self.residual_transition = bool(residual_transition)
        self.next_action = self.make_next_action()
        self.transition = self.make_transition()
        self.register_buffer("fitted", th.tensor(False))

    def make_next_action(self) -> nn.Module:
        """A fresh P_eta(a' | s, a, s')."""
        c_dim = 2 * self.obs_dim + self.act_in
        if self.discrete:
            return ConditionalCategorical(self.n_actions, c_dim, self.hidden)
        return ConditionalGaussian(self.act_in, c_dim, self.hidden)

    def make_transition(self) -> ConditionalGaussian:
        """A fresh T_psi(s' | s, a)."""
        return ConditionalGaussian(self.obs_dim, self.obs_dim + self.act_in, self.hidden)

    def transition_inputs(self, s: th.Tensor, a: th.Tensor, s_next: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """(x, c) of T: x = s' (or s' - s with ``residual_transition``; a translation, so the density is the same),
        c = (s, a)."""
        x, c = super().transition_inputs(s, a, s_next)
        return (x - s, c) if self.residual_transition else (x, c)

    def transition_mean_std(self, s: th.Tensor, a: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """T_psi's mean and std of s' given (s, a), in raw units (``a`` as given to :meth:`encode_action`)."""
        mean, std = self.transition.mean_std(th.cat([s, self.encode_action(a)], dim=1))
        return (s + mean if self.residual_transition else mean), std

    @th.no_grad()
    def next_action_distribution(self, s: th.Tensor, a: th.Tensor, s_next: th.Tensor) -> tuple[th.Tensor, ...]:
        """P_eta(. | s, a, s'): ``(log_probs,)`` (Discrete) or ``(mean, log_std)`` in raw units (Box)."""
        c = th.cat([s, self.encode_action(a), s_next], dim=1)
        if self.discrete:
            return (self.next_action.log_probs(c),)
        mean, std = self.next_action.mean_std(c)
        return mean, std.log()

    @th.no_grad()
    def sample_next_states(self, s: th.Tensor, a: th.Tensor, k: int, scale: float, generator: th.Generator) -> th.Tensor:
        """``k`` draws of s' ~ T_psi(. | s, a) per row with the std multiplied by ``scale``: shape (len(s) * k, obs_dim),
        row-major (the draws of row i are rows i*k .. i*k+k-1)."""
        mean, std = self.transition_mean_std(s, a)
        mean, std = mean.repeat_interleave(k, 0), std.repeat_interleave(k, 0)
        eps = th.randn(mean.shape, generator=generator, device=mean.device)
        return mean + scale * std * eps
