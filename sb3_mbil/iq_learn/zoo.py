"""The RL Zoo's Optuna sampler and converter of this algorithm (iq_learn); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for IQ-Learn: learning rate, batch size, network size, temperature, chi^2 alpha, discount."""
    params = common_params(trial, lr_range=(1e-5, 1e-3))
    params["temperature"] = trial.suggest_categorical("temperature", [0.001, 0.01, 0.1])
    params["alpha"] = trial.suggest_categorical("alpha", [0.1, 0.5, 1.0])
    params["gamma"] = trial.suggest_categorical("gamma", [0.9, 0.99])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of iq_learn."""
    return convert_policy_params(params)
