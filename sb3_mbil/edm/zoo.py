"""The RL Zoo's Optuna sampler and converter of this algorithm (edm); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for EDM: learning rate, batch size, network size, energy weight, SGLD steps."""
    params = common_params(trial)
    params["energy_weight"] = trial.suggest_float("energy_weight", 0.1, 10.0, log=True)
    params["sgld_steps"] = trial.suggest_categorical("sgld_steps", [10, 20, 40])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of edm."""
    return convert_policy_params(params)
