"""The RL Zoo's Optuna sampler and converter of this algorithm (dsfn); ``sb3_mbil.zoo`` reads them."""

from __future__ import annotations

from typing import Any

from sb3_mbil.common.zoo_params import common_params, convert_policy_params


def sample_params(trial, n_actions: int, n_envs: int, additional_args: dict) -> dict[str, Any]:
    """Sampler for DSFN: learning rate, batch size, network size, discount, DQN and successor-feature steps."""
    params = common_params(trial)
    params["gamma"] = trial.suggest_categorical("gamma", [0.9, 0.95, 0.99])
    params["dqn_steps"] = trial.suggest_categorical("dqn_steps", [10_000, 30_000])
    params["sf_steps"] = trial.suggest_categorical("sf_steps", [10_000, 50_000])
    return convert_params(params)


def convert_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as the constructor arguments of dsfn."""
    return convert_policy_params(params)
