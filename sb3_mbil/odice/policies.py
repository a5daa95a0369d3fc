"""Networks of ODICE: the policy (a Gaussian with its mean bounded into the action box) and the twin value
function V(s) (:class:`sb3_mbil.common.networks.MlpCritic`) with its EMA target."""

from sb3_mbil.common.networks import MlpCritic
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpCritic", "MlpPolicy"]
