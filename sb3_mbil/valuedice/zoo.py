"""The RL Zoo's Optuna sampler and converter of this algorithm (valuedice); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for ValueDICE: actor and nu learning rates, batch size, network size, orthogonal regulariser, gradient
    penalty."""
    params = common_params(trial, lr_range=(1e-6, 1e-4))
    params["nu_learning_rate"] = trial.suggest_float("nu_learning_rate", 1e-4, 1e-2, log=True)
    params["orthogonal_weight"] = trial.suggest_categorical("orthogonal_weight", [0.0, 1e-4, 1e-3])
    params["gradient_penalty"] = trial.suggest_categorical("gradient_penalty", [0.0, 1.0, 10.0])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of valuedice."""
    return convert_policy_params(params)
