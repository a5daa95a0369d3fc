from sb3_mbil.bc.bc import BC
from sb3_mbil.bc.policies import MlpPolicy

__all__ = ["BC", "MlpPolicy"]
