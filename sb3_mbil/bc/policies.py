from sb3_mbil.common.policies import ImitationPolicy, MlpPolicy

__all__ = ["ImitationPolicy", "MlpPolicy"]
