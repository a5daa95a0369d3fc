"""Expert agents (RL Zoo: the Hugging Face Hub or local rl_zoo3 training) and the demonstrations generated with them.

The expert table (:mod:`sb3_mbil.experts.specs`) is imported at once; the agents (:mod:`~sb3_mbil.experts.agents`),
their local training (:mod:`~sb3_mbil.experts.zoo_training`) and the rollouts (:mod:`~sb3_mbil.experts.generate`),
which need the demonstrations module and SB3's algorithms, when first used, so that the pools' lookup can read the
table without an import cycle and without importing rl_zoo3.
"""

import importlib

from sb3_mbil.experts.specs import EXPERTS, OTHER_SPECS, SECOND_EXPERTS, ExpertSpec, expert_spec

_LAZY = {"Expert": "agents", "load_expert_file": "agents", "load_hub_expert": "agents",
         "train_zoo_expert": "zoo_training", "export_zoo_checkpoint": "zoo_training",
         "import_zoo_checkpoint": "zoo_training",
         "evaluate_expert": "generate", "generate_demonstrations": "generate", "get_expert": "generate",
         "rollout": "generate"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(f"sb3_mbil.experts.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'sb3_mbil.experts' has no attribute {name!r}")


__all__ = ["EXPERTS", "OTHER_SPECS", "SECOND_EXPERTS", "ExpertSpec", "expert_spec", *_LAZY]
