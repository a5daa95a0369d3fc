from sb3_mbil.rcal.policies import MlpPolicy
from sb3_mbil.rcal.rcal import RCAL

__all__ = ["RCAL", "MlpPolicy"]
