"""What the algorithms' RL Zoo samplers share (each algorithm's own sampler and converter live in its folder's
``zoo.py``): the network sizes a trial picks from, the common settings, and the conversion of a picked size."""

from __future__ import annotations

from typing import Any

NET_ARCH = {"small": [64, 64], "medium": [256, 256]}


def common_params(trial, lr_range: tuple[float, float] = (1e-4, 3e-3)) -> dict[str, Any]:
    """Learning rate, batch size and network size, as every sampler proposes them."""
    return {
        "learning_rate": trial.suggest_float("learning_rate", *lr_range, log=True),
        "batch_size": trial.suggest_categorical("batch_size", [32, 64, 128, 256]),
        "net_arch": trial.suggest_categorical("net_arch", list(NET_ARCH)),
    }


def convert_policy_params(params: dict[str, Any]) -> dict[str, Any]:
    """A trial's parameters as constructor arguments: the picked network size into ``policy_kwargs``."""
    out = dict(params)
    if isinstance(out.get("net_arch"), str):
        out["policy_kwargs"] = {"net_arch": NET_ARCH[out.pop("net_arch")]}
    return out
