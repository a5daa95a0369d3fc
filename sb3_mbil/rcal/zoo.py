"""The RL Zoo's Optuna sampler and converter of this algorithm (rcal); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for RCAL: learning rate, batch size, network size, sparsity weight, classification loss."""
    params = common_params(trial)
    params["reward_weight"] = trial.suggest_float("reward_weight", 1e-3, 1.0, log=True)
    params["classification_loss"] = trial.suggest_categorical("classification_loss", ["cross_entropy", "margin"])
    params["soft_max"] = trial.suggest_categorical("soft_max", [True, False])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of rcal."""
    return convert_policy_params(params)
