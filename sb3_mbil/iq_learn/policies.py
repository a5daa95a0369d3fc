"""Networks of IQ-Learn: the policy (Discrete: its logits are the soft Q(s, .); Box: the actor) and, for Box
actions, the critic Q(s, a) (:class:`sb3_mbil.common.networks.MlpCritic`) with its target copy."""

from sb3_mbil.common.networks import MlpCritic
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpCritic", "MlpPolicy"]
