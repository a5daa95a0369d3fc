"""Networks of EDM: the policy f(s) (its logits; the joint energy reads the same logits) and the SGLD sample buffer."""

from __future__ import annotations

import torch as th
from torch import nn

from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpPolicy", "SGLDBuffer"]


class SGLDBuffer(nn.Module):
    """Persistent SGLD chains in standardised state coordinates z = (s - mean) / std (JEM's replay buffer).

    Saved with the model (buffers), so training continued after ``load`` continues the same chains.

    :param obs_dim: flat observation dimension
    :param size: number of stored chains
    """

    def __init__(self, obs_dim: int, size: int):
        super().__init__()
        self.register_buffer("samples", th.rand(size, obs_dim) * 2 - 1)
        self.register_buffer("obs_mean", th.zeros(obs_dim))
        self.register_buffer("obs_std", th.ones(obs_dim))
        self.register_buffer("stats_set", th.tensor(False))

    @th.no_grad()
    def set_stats(self, observations: th.Tensor, std_floor: float = 1e-3) -> None:
        self.obs_mean.copy_(observations.mean(0))
        self.obs_std.copy_(observations.std(0, unbiased=False).clamp(min=std_floor))
        self.stats_set.fill_(True)

    def to_raw(self, z: th.Tensor) -> th.Tensor:
        """States in the env's units from standardised coordinates."""
        return self.obs_mean + self.obs_std * z
