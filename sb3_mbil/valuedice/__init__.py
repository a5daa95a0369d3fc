from sb3_mbil.valuedice.policies import MlpPolicy
from sb3_mbil.valuedice.valuedice import ValueDICE

__all__ = ["MlpPolicy", "ValueDICE"]
