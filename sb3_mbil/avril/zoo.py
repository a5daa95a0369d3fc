"""The RL Zoo's Optuna sampler and converter of this algorithm (avril); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for AVRIL: learning rate, batch size, network size, TD-likelihood weight, discount."""
    params = common_params(trial, lr_range=(1e-5, 1e-3))
    params["reward_weight"] = trial.suggest_float("reward_weight", 0.1, 10.0, log=True)
    params["gamma"] = trial.suggest_categorical("gamma", [0.9, 0.99, 1.0])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of avril."""
    return convert_policy_params(params)
