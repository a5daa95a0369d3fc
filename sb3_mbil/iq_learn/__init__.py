from sb3_mbil.iq_learn.iq_learn import IQLearn
from sb3_mbil.iq_learn.policies import MlpPolicy

__all__ = ["IQLearn", "MlpPolicy"]
