from sb3_mbil.edm.edm import EDM
from sb3_mbil.edm.policies import MlpPolicy, SGLDBuffer

__all__ = ["EDM", "MlpPolicy", "SGLDBuffer"]
