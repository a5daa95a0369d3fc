"""Networks of ValueDICE: the actor (a tanh-Gaussian for Box, a Gumbel-softmax over the logits for Discrete) and
the value function nu(s, a) (:class:`sb3_mbil.common.networks.MlpCritic`, its state input with an absorbing
indicator)."""

from sb3_mbil.common.networks import MlpCritic
from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpCritic", "MlpPolicy"]
