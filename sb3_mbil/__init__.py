"""sb3_mbil: Markov Balance-based Imitation Learning and imitation baselines for Stable-Baselines3."""

from sb3_mbil.bc import BC
from sb3_mbil.common.demonstrations import Demonstrations, Trajectory, as_demonstrations, load_demonstrations
from sb3_mbil.mbil import MBIL
from sb3_mbil.version import __version__

ALGORITHMS = {"mbil": MBIL, "bc": BC}

__all__ = [
    "ALGORITHMS",
    "BC",
    "MBIL",
    "Demonstrations",
    "Trajectory",
    "__version__",
    "as_demonstrations",
    "load_demonstrations",
]
