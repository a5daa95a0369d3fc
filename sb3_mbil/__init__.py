"""sb3_mbil: Markov Balance-based Imitation Learning and imitation baselines for Stable-Baselines3."""

from sb3_mbil.avril import AVRIL
from sb3_mbil.bc import BC
from sb3_mbil.common.demonstrations import Demonstrations, Trajectory, as_demonstrations, load_demonstrations
from sb3_mbil.common.heldout import ValidationCallback, split_blocks
from sb3_mbil.common.lockstep import learn_lockstep, train_seeds
from sb3_mbil.dsfn import DSFN
from sb3_mbil.edm import EDM
from sb3_mbil.export import export_policy
from sb3_mbil.iq_learn import IQLearn
from sb3_mbil.mbil import MBIL
from sb3_mbil.mbil_c import MBILC
from sb3_mbil.odice import ODICE
from sb3_mbil.rcal import RCAL
from sb3_mbil.valuedice import ValueDICE
from sb3_mbil.version import __version__

#: The one registry: the RL Zoo registration, the benchmark, the speed script and the tests read it.
ALGORITHMS = {"mbil": MBIL, "mbil_c": MBILC, "bc": BC, "edm": EDM, "avril": AVRIL, "rcal": RCAL, "dsfn": DSFN, "iq_learn": IQLearn,
              "valuedice": ValueDICE, "odice": ODICE}

__all__ = [
    "ALGORITHMS",
    "AVRIL",
    "BC",
    "DSFN",
    "EDM",
    "IQLearn",
    "MBIL",
    "MBILC",
    "ODICE",
    "RCAL",
    "Demonstrations",
    "Trajectory",
    "ValueDICE",
    "ValidationCallback",
    "__version__",
    "as_demonstrations",
    "export_policy",
    "learn_lockstep",
    "load_demonstrations",
    "split_blocks",
    "train_seeds",
]
