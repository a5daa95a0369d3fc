"""Networks that several baselines share: critics (Q and V) with target copies, and the soft policy over Q.

For Discrete actions the imitation policy's logits *are* a Q-function in EDM, AVRIL, RCAL, DSFN and
IQ-Learn (pi = softmax(Q / t)); :func:`soft_q` turns Q-values into that policy's log-probabilities
and its soft value. The critics here read the same standardised observations as the policy
(:meth:`ImitationPolicy.features`), so one set of expert statistics serves every network.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import torch as th
from stable_baselines3.common.torch_layers import create_mlp
from stable_baselines3.common.utils import polyak_update
from torch import nn


class MlpCritic(nn.Module):
    """Q(s, .) (``n_outputs`` values per state, Discrete), Q(s, a) (``action_dim`` > 0, Box) or V(s).

    :param obs_dim: flat observation dimension
    :param n_outputs: outputs per state (the number of actions for Q(s, .), 1 for V or Q(s, a))
    :param action_dim: size of an action input (Box Q(s, a)); 0 for none
    :param net_arch: hidden layer sizes
    :param activation_fn: hidden activation
    :param n_critics: independent copies (twin critics); ``forward`` stacks them on dim 0
    """

    def __init__(self, obs_dim: int, n_outputs: int = 1, action_dim: int = 0, net_arch: Sequence[int] = (64, 64),
                 activation_fn: type[nn.Module] = nn.ReLU, n_critics: int = 1):
        super().__init__()
        self.action_dim = int(action_dim)
        self.nets = nn.ModuleList(
            nn.Sequential(*create_mlp(obs_dim + self.action_dim, n_outputs, list(net_arch), activation_fn))
            for _ in range(n_critics)
        )

    def forward(self, features: th.Tensor, actions: th.Tensor | None = None) -> th.Tensor:
        """Shape (n_critics, batch, n_outputs)."""
        x = features if self.action_dim == 0 else th.cat([features, actions.float().view(len(features), -1)], dim=1)
        return th.stack([net(x) for net in self.nets])


def make_target(module: nn.Module) -> nn.Module:
    """A frozen copy (no gradients, eval mode) to be tracked with :func:`soft_update`."""
    target = copy.deepcopy(module)
    target.requires_grad_(False)
    return target.eval()


def soft_update(target: nn.Module, source: nn.Module, tau: float) -> None:
    """target <- tau * source + (1 - tau) * target, parameters and buffers (SB3's ``polyak_update``)."""
    with th.no_grad():
        polyak_update(list(source.parameters()) + list(source.buffers()),
                      list(target.parameters()) + list(target.buffers()), tau)


def soft_q(q: th.Tensor, temperature: float = 1.0) -> tuple[th.Tensor, th.Tensor]:
    """The soft policy and value of Q(s, .): ``log pi = log_softmax(Q / t)`` and ``V = t logsumexp(Q / t)``."""
    scaled = q / temperature
    return th.log_softmax(scaled, dim=-1), temperature * th.logsumexp(scaled, dim=-1)


def q_at(q: th.Tensor, actions: th.Tensor) -> th.Tensor:
    """Q(s, a) from Q(s, .) and integer actions."""
    return q.gather(-1, actions.long().view(-1, 1)).squeeze(-1)
