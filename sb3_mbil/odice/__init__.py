from sb3_mbil.odice.odice import ODICE
from sb3_mbil.odice.policies import MlpPolicy

__all__ = ["ODICE", "MlpPolicy"]
