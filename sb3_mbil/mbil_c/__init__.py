from sb3_mbil.mbil_c.mbil_c import MBILC
from sb3_mbil.mbil_c.policies import BalanceModel, MlpPolicy

__all__ = ["MBILC", "BalanceModel", "MlpPolicy"]
