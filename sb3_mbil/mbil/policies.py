"""Networks of MBIL: the policy pi_theta and the Markov balance model (the flows P and T).

Markov balance equation of the expert's state-action chain (the paper, arXiv:2408.09125):

    P(s', a' | s, a) = pi_D(a' | s') * T(s' | s, a)

We write P through its own chain rule, P(s', a' | s, a) = T(s' | s, a) * P(a' | s, a, s'):
integrating the balance equation over a' shows that the s'-marginal of P *is* T, so one
flow T_psi(s' | s, a) serves as both that marginal and T, and a second model
P_eta(a' | s, a, s') carries the a' part. Then

    log P(s', a' | s, a) - log T(s' | s, a) = log P_eta(a' | s, a, s')

exactly, with the same measure as pi on a':

* Discrete actions: P_eta(a' | s, a, s') is a categorical (a probability mass, like pi).
  A flow over a noisy one-hot a' would be a density whose scale depends on the noise,
  a constant offset in the balance target.
* Box actions: P_eta(a' | s, a, s') is a conditional affine-coupling flow in the env's raw
  action units, like the policy's Gaussian.

Fitting two separate flows for the s' part of P and for T would leave the difference of
two estimates of the same density in the target (tens of nats with one trajectory).

The paper's literal estimator is kept as an option (``MBIL(estimator="joint")``): one flow
P_joint(s', a' | s, a) over the concatenated (s', a') (a' one-hot for Discrete actions, so P_joint is
a density in a', not a mass) and a separate flow T(s' | s, a); the target is their difference,
log P_joint - log T, with both estimation errors in it.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch as th
from gymnasium import spaces
from torch import nn

from sb3_mbil.common.flows import ConditionalCategorical, ConditionalFlow, TupleInputs
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MarkovBalanceModel", "MlpPolicy"]


class MarkovBalanceModel(TupleInputs):
    """T_psi(s' | s, a) and P_eta(a' | s, a, s'); P = T * P_eta.

    :param obs_dim: flat observation dimension
    :param action_space: Discrete or Box
    :param transforms: affine coupling blocks per flow
    :param hidden: hidden sizes of the coupling networks (and of the categorical model)
    :param embed_dim: output size of the conditioning network NN_c
    :param scale_limit: bound on each coupling block's |log scale|
    """

    def __init__(
        self,
        obs_dim: int,
        action_space: spaces.Space,
        transforms: int = 4,
        hidden: Sequence[int] = (64, 64),
        embed_dim: int = 32,
        scale_limit: float = 3.0,
        joint: bool = False,
    ):
        super().__init__(obs_dim, action_space)
        self._flow_args = dict(transforms=transforms, hidden=tuple(hidden), embed_dim=embed_dim, scale_limit=scale_limit)
        self.transition = self.make_transition()
        self.next_action = self.make_next_action()
        #: the paper's literal estimator: one flow over (s', a') given (s, a) (only with ``joint``)
        self.joint = self.make_joint() if joint else None
        self.register_buffer("fitted", th.tensor(False))

    def make_joint(self) -> ConditionalFlow:
        """A fresh P_joint(s', a' | s, a): one affine-coupling flow over the concatenated (s', a'), a' one-hot for
        Discrete actions."""
        return ConditionalFlow(self.obs_dim + self.act_in, self.obs_dim + self.act_in, **self._flow_args)

    def joint_inputs(self, s, a, s_next, a_next) -> tuple[th.Tensor, th.Tensor]:
        """(x, c) of P_joint: x = (s', a'), c = (s, a)."""
        return th.cat([s_next, self.encode_action(a_next)], dim=1), th.cat([s, self.encode_action(a)], dim=1)

    def log_p_joint(self, s, a, s_next, a_next) -> th.Tensor:
        """log P_joint(s', a' | s, a) from the joint flow (``joint`` only)."""
        if self.joint is None:
            raise RuntimeError("this model has no joint flow (MBIL(estimator='joint') builds one)")
        return self.joint.log_prob(*self.joint_inputs(s, a, s_next, a_next))

    def make_transition(self) -> ConditionalFlow:
        """A fresh T_psi(s' | s, a)."""
        return ConditionalFlow(self.obs_dim, self.obs_dim + self.act_in, **self._flow_args)

    def make_next_action(self) -> nn.Module:
        """A fresh P_eta(a' | s, a, s')."""
        if self.discrete:
            return ConditionalCategorical(self.n_actions, 2 * self.obs_dim + self.act_in, self._flow_args["hidden"])
        return ConditionalFlow(self.act_in, 2 * self.obs_dim + self.act_in, **self._flow_args)

    def log_t(self, s, a, s_next) -> th.Tensor:
        """log T(s' | s, a), a density in raw observation units."""
        return self.transition.log_prob(*self.transition_inputs(s, a, s_next))

    def log_p_next_action(self, s, a, s_next, a_next) -> th.Tensor:
        """log P(a' | s, a, s') = log P(s', a' | s, a) - log T(s' | s, a)."""
        return self.next_action.log_prob(*self.next_action_inputs(s, a, s_next, a_next))

    def log_p(self, s, a, s_next, a_next) -> th.Tensor:
        """log P(s', a' | s, a) = log T(s' | s, a) + log P(a' | s, a, s')."""
        return self.log_t(s, a, s_next) + self.log_p_next_action(s, a, s_next, a_next)
