"""The RL Zoo's Optuna sampler and converter of this algorithm (odice); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for ODICE: learning rates, batch size, network size, lambda, eta."""
    params = common_params(trial, lr_range=(1e-5, 1e-3))
    params["value_learning_rate"] = trial.suggest_float("value_learning_rate", 1e-5, 1e-3, log=True)
    params["lambda_"] = trial.suggest_categorical("lambda_", [0.2, 0.4, 0.6, 0.8])
    params["eta"] = trial.suggest_categorical("eta", [0.5, 1.0, 2.0])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of odice."""
    return convert_policy_params(params)
