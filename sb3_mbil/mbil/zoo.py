"""The RL Zoo's Optuna sampler and converter of this algorithm (mbil); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params

FLOW_HIDDEN = {"small": [32, 32], "medium": [64, 64], "large": [128, 128]}


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for MBIL: balance and BC weights, policy learning rate and size, flow noise and size, estimator."""
    params = common_params(trial)
    params["alpha"] = trial.suggest_float("alpha", 1e-3, 10.0, log=True)
    params["beta"] = trial.suggest_float("beta", 1e-3, 10.0, log=True)
    params["noise"] = trial.suggest_categorical("noise", ["auto", 0.01, 0.03, 0.1, 0.3])
    params["flow_hidden"] = trial.suggest_categorical("flow_hidden", list(FLOW_HIDDEN))
    params["flow_transforms"] = trial.suggest_int("flow_transforms", 2, 6)
    params["estimator"] = trial.suggest_categorical("estimator", ["factored", "joint"])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as MBIL's constructor arguments."""
    out = convert_policy_params(params)
    noise = out.pop("noise", "auto")
    if noise != "auto":
        out["noise_grid"] = [float(noise)]
    if isinstance(out.get("flow_hidden"), str):
        out["flow_hidden"] = FLOW_HIDDEN[out["flow_hidden"]]
    return out
