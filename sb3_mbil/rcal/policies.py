"""Networks of RCAL: the policy, whose logits are the score function Q(s, .)."""

from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpPolicy"]
