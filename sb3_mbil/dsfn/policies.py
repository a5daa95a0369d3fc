"""Networks of DSFN: the policy (warm start: a BC classifier; then the batch DQN's Q(s, .)), the frozen
feature network phi, the successor-feature network psi and the method's state (mu_E, mu_bar, w, margins)."""

from __future__ import annotations

import torch as th
from torch import nn

from sb3_mbil.common.networks import MlpCritic as SuccessorFeatures
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["DSFNState", "ImitationPolicy", "MlpPolicy", "SuccessorFeatures"]

PHASES = ("warm_start", "successor_features", "dqn", "done")


class DSFNState(nn.Module):
    """Where the method stands, as buffers so that ``save``/``load`` continue it.

    :param n_features: k, the size of phi(s, a)
    :param max_iterations: the most apprenticeship iterations
    """

    def __init__(self, n_features: int, max_iterations: int):
        super().__init__()
        self.register_buffer("phase", th.tensor(0))  # index into PHASES
        self.register_buffer("phase_step", th.tensor(0))
        self.register_buffer("iteration", th.tensor(0))  # 0: the uniform policy pi_0
        self.register_buffer("mu_expert", th.zeros(n_features))
        self.register_buffer("mu_bar", th.zeros(n_features))
        self.register_buffer("w", th.zeros(n_features))
        self.register_buffer("margins", th.full((max_iterations + 1,), float("nan")))
        self.register_buffer("best_distance", th.tensor(float("inf")))
        self.register_buffer("distances", th.full((max_iterations + 1,), float("nan")))  # ||mu_E - mu_i||

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        # files saved before ``distances`` existed load with it unknown (NaN), not with a missing-key error
        state_dict.setdefault(prefix + "distances", th.full_like(self.distances, float("nan")))
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    @property
    def phase_name(self) -> str:
        return PHASES[int(self.phase)]

    def enter(self, phase: str) -> None:
        self.phase.fill_(PHASES.index(phase))
        self.phase_step.zero_()
