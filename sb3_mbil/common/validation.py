"""One way to check arguments: each check returns the value in its canonical type or raises a
``ValueError`` that names the field, what was expected and what was found.

Booleans are not numbers here (``True`` is refused where a number is expected), and numbers
must be finite.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np


def fail(name: str, expected: str, found: Any) -> None:
    raise ValueError(f"{name}: expected {expected}, found {found!r}")


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


def check_real(name: str, value: Any, *, low: float | None = None, high: float | None = None,
               low_open: bool = False, high_open: bool = False) -> float:
    """A finite real number in [low, high] (``low_open`` / ``high_open``: the bound excluded)."""
    lo = "" if low is None else (f"> {low:g}" if low_open else f">= {low:g}")
    hi = "" if high is None else (f"< {high:g}" if high_open else f"<= {high:g}")
    expected = "a finite number" + (f" {lo}" if lo else "") + (" and" if lo and hi else "") + (f" {hi}" if hi else "")
    if not _is_number(value) or not math.isfinite(float(value)):
        fail(name, expected, value)
    v = float(value)
    if low is not None and (v < low or (low_open and v == low)):
        fail(name, expected, value)
    if high is not None and (v > high or (high_open and v == high)):
        fail(name, expected, value)
    return v


def check_int(name: str, value: Any, *, low: int | None = None, high: int | None = None) -> int:
    """An integer in [low, high] (a float with an integral value is refused: 1e4 in YAML is a float; use int(...))."""
    expected = "an integer" + (f" >= {low}" if low is not None else "") + (f" <= {high}" if high is not None else "")
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
        fail(name, expected, value)
    v = int(value)
    if (low is not None and v < low) or (high is not None and v > high):
        fail(name, expected, value)
    return v


def check_bool(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        fail(name, "True or False", value)
    return bool(value)


def check_choice(name: str, value: Any, choices: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        fail(name, "one of " + ", ".join(repr(c) for c in choices), value)
    return value


def check_sizes(name: str, value: Any, *, min_len: int = 1) -> list[int]:
    """A list of positive integers (layer sizes)."""
    expected = f"a list of {min_len} or more positive integers"
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        fail(name, expected, value)
    if len(value) < min_len or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in value):
        fail(name, expected, value)
    return [int(v) for v in value]


def check_levels(name: str, value: Any, *, low: float = 0.0) -> list[float]:
    """A non-empty list of finite numbers >= low."""
    expected = f"a non-empty list of finite numbers >= {low:g}"
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) == 0:
        fail(name, expected, value)
    if not all(_is_number(v) and math.isfinite(float(v)) and float(v) >= low for v in value):
        fail(name, expected, value)
    return [float(v) for v in value]


def check_learning_rate(name: str, value: Any) -> Any:
    """A finite number >= 0, or a schedule (a callable of the remaining progress). 0 is allowed: rl_zoo3's
    ``enjoy`` loads models with ``learning_rate=0.0``."""
    if callable(value):
        return value
    return check_real(name, value, low=0.0)


def check_seed(name: str, value: Any) -> int | None:
    if value is None:
        return None
    return check_int(name, value, low=0, high=2**32 - 1)


def check_policy_kwargs(policy_class: type, value: Any) -> dict:
    """``policy_kwargs`` checked as strictly as a constructor argument: known keys of ``policy_class`` only, and each
    of the shared policy's settings of the right kind. The optimiser's weight decay is the algorithm's
    ``weight_decay`` argument, so ``optimizer_kwargs`` may not set it too."""
    import inspect

    import torch as th

    if value is None:
        return {}
    if not isinstance(value, dict):
        fail("policy_kwargs", "a dict", value)
    known = [p for p in inspect.signature(policy_class.__init__).parameters
             if p not in ("self", "observation_space", "action_space", "lr_schedule")]
    for key in value:
        if key not in known:
            fail("policy_kwargs", f"keys among {known}", key)
    out = dict(value)
    if "net_arch" in out and out["net_arch"] is not None:
        arch = out["net_arch"]
        if isinstance(arch, dict):
            fail("policy_kwargs.net_arch", "a list of layer sizes (one network; not SB3's dict(pi=..., vf=...))", arch)
        if not isinstance(arch, (list, tuple)):
            fail("policy_kwargs.net_arch", "a list of layer sizes", arch)
        out["net_arch"] = [check_int(f"policy_kwargs.net_arch[{i}]", n, low=1) for i, n in enumerate(arch)]
    if "activation_fn" in out and not (isinstance(out["activation_fn"], type)
                                       and issubclass(out["activation_fn"], th.nn.Module)):
        fail("policy_kwargs.activation_fn", "a torch module class such as nn.ReLU or nn.ELU (the class, not a string "
             "or an instance)", out["activation_fn"])
    if "optimizer_class" in out and not (isinstance(out["optimizer_class"], type)
                                         and issubclass(out["optimizer_class"], th.optim.Optimizer)):
        fail("policy_kwargs.optimizer_class", "a torch optimizer class such as th.optim.Adam", out["optimizer_class"])
    for key in ("normalize_observations", "bounded_mean"):
        if key in out:
            out[key] = check_bool(f"policy_kwargs.{key}", out[key])
    if "optimizer_kwargs" in out and out["optimizer_kwargs"] is not None:
        opt = out["optimizer_kwargs"]
        if not isinstance(opt, dict):
            fail("policy_kwargs.optimizer_kwargs", "a dict", opt)
        if "weight_decay" in opt:
            fail("policy_kwargs.optimizer_kwargs.weight_decay", "no entry (the algorithm's weight_decay argument sets "
                 "the optimiser's weight decay)", opt["weight_decay"])
        if "lr" in opt:
            fail("policy_kwargs.optimizer_kwargs.lr", "no entry (the algorithm's learning_rate argument sets it)", opt["lr"])
    if "log_std_bounds" in out:
        b = out["log_std_bounds"]
        if not isinstance(b, (list, tuple)) or len(b) != 2:
            fail("policy_kwargs.log_std_bounds", "(low, high)", b)
        low = check_real("policy_kwargs.log_std_bounds[0]", b[0])
        high = check_real("policy_kwargs.log_std_bounds[1]", b[1])
        if not low < high:
            fail("policy_kwargs.log_std_bounds", "(low, high) with low < high", b)
    return out


class CheckedSchedule:
    """A learning-rate schedule whose every value is checked: a finite number >= 0, or a ValueError naming the
    progress at which the schedule returned something else."""

    def __init__(self, name: str, schedule):
        self.name = name
        self.schedule = schedule

    def __call__(self, progress_remaining: float) -> float:
        value = self.schedule(progress_remaining) if callable(self.schedule) else self.schedule
        if not _is_number(value) or not math.isfinite(float(value)) or float(value) < 0:
            fail(self.name, f"a schedule returning finite numbers >= 0 (at progress_remaining={progress_remaining:g})",
                 value)
        return float(value)
