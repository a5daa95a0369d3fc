from sb3_mbil.dsfn.dsfn import DSFN
from sb3_mbil.dsfn.policies import DSFNState, MlpPolicy

__all__ = ["DSFN", "DSFNState", "MlpPolicy"]
