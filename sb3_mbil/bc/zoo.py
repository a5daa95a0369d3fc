"""The RL Zoo's Optuna sampler and converter of this algorithm (bc); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for BC: learning rate, batch size, network size, weight decay."""
    params = common_params(trial)
    params["weight_decay"] = trial.suggest_categorical("weight_decay", [0.0, 1e-4, 1e-3, 1e-2])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of bc."""
    return convert_policy_params(params)
