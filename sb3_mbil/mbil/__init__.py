from sb3_mbil.mbil.mbil import MBIL
from sb3_mbil.mbil.policies import MarkovBalanceModel, MlpPolicy

__all__ = ["MBIL", "MarkovBalanceModel", "MlpPolicy"]
