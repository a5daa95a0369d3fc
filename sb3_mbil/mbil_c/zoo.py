"""The RL Zoo's Optuna sampler and converter of this algorithm (mbil_c); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for MBIL-C: balance weights at data and model states, BC weight, model draws and their spread."""
    params = common_params(trial)
    params["alpha"] = trial.suggest_float("alpha", 1e-2, 10.0, log=True)
    params["alpha_model"] = trial.suggest_categorical("alpha_model", [0.0, 0.1, 0.3, 1.0, 3.0])
    params["beta"] = trial.suggest_float("beta", 1e-1, 10.0, log=True)
    params["n_model_states"] = trial.suggest_categorical("n_model_states", [1, 4, 16])
    params["model_state_scale"] = trial.suggest_categorical("model_state_scale", [0.5, 1.0, 2.0, 4.0])
    params["weight_decay"] = trial.suggest_categorical("weight_decay", [0.0, 1e-4, 1e-3])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of mbil_c."""
    return convert_policy_params(params)
