"""Expert agents (RL Zoo: the Hugging Face Hub or local rl_zoo3 training) and the demonstrations generated with them."""

from sb3_mbil.experts.generate import (
    EXPERTS,
    SECOND_EXPERTS,
    Expert,
    ExpertSpec,
    evaluate_expert,
    export_zoo_checkpoint,
    generate_demonstrations,
    get_expert,
    import_zoo_checkpoint,
    load_expert_file,
    load_hub_expert,
    rollout,
    train_zoo_expert,
)

__all__ = [
    "EXPERTS",
    "SECOND_EXPERTS",
    "Expert",
    "ExpertSpec",
    "evaluate_expert",
    "export_zoo_checkpoint",
    "generate_demonstrations",
    "get_expert",
    "import_zoo_checkpoint",
    "load_expert_file",
    "load_hub_expert",
    "rollout",
    "train_zoo_expert",
]
