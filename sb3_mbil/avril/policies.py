"""Networks of AVRIL: the policy (its logits are Q(s, .)) and the reward encoder q(R | s)."""

from sb3_mbil.common.networks import MlpCritic as RewardEncoder
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpPolicy", "RewardEncoder"]
