from sb3_mbil.avril.avril import AVRIL
from sb3_mbil.avril.policies import MlpPolicy

__all__ = ["AVRIL", "MlpPolicy"]
