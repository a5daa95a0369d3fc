"""Expert agents (RL Zoo: the Hugging Face Hub or local rl_zoo3 training) and the demonstrations generated with them.

The expert table (:mod:`sb3_mbil.experts.specs`) is imported at once; the rest (:mod:`sb3_mbil.experts.generate`,
which needs the demonstrations module) when first used, so that the pools' lookup can read the table without an
import cycle.
"""

from sb3_mbil.experts.specs import EXPERTS, OTHER_SPECS, SECOND_EXPERTS, ExpertSpec, expert_spec

_GENERATE = ("Expert", "evaluate_expert", "export_zoo_checkpoint", "generate_demonstrations", "get_expert",
             "import_zoo_checkpoint", "load_expert_file", "load_hub_expert", "rollout", "train_zoo_expert")


def __getattr__(name: str):
    if name in _GENERATE:
        from sb3_mbil.experts import generate

        return getattr(generate, name)
    raise AttributeError(f"module 'sb3_mbil.experts' has no attribute {name!r}")


__all__ = ["EXPERTS", "OTHER_SPECS", "SECOND_EXPERTS", "ExpertSpec", "expert_spec", *_GENERATE]
