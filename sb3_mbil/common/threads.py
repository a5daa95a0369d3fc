"""How torch uses the CPU while an algorithm of this package trains: its intra-op threads and subnormal floats.

The networks here (64-256 units, minibatches of 64-256) gain nothing from torch's intra-op threads, and on a machine
whose cores are shared the default (one thread per core) runs many times slower than one thread: threads spin
waiting for each other. So ``learn`` (and every fit it runs: MBIL's flows, MBIL-C's models, also when a user calls
``fit_flows`` or ``fit_models`` directly) runs with
:data:`TRAINING_THREADS` intra-op threads and gives the caller's setting back when it returns, also on an error.

Change it for every algorithm with the environment variable ``SB3_MBIL_TORCH_THREADS`` (an integer >= 1, or ``0``
to leave torch's own setting alone), or per model by setting ``model.torch_threads`` before ``learn``.

Subnormal floats (magnitudes below 1.2e-38 in float32) are flushed to zero while training. Weight decay drives the
weights the loss barely moves, and their Adam moments, towards zero through the subnormal range, where the CPU
computes many times slower: MBIL-C with ``weight_decay=1e-3`` on Walker2d-v4 gathered thousands of subnormal
parameters, and 10 000 updates took 2.6x as long as with them flushed (``python -m benchmarks.probe_subnormals``,
docs/results.md). Flushing changes only values that small. Turn it off with ``SB3_MBIL_FLUSH_SUBNORMALS=0`` (``1``,
the default: on). It applies to the thread that trains (with one intra-op thread, all of training); the caller's
mode is restored when ``learn`` returns.
"""

from __future__ import annotations

import contextlib
import functools
import os
from collections.abc import Callable, Iterator
from typing import TypeVar

import torch as th

_Method = TypeVar("_Method", bound=Callable)

#: intra-op threads while training, unless ``SB3_MBIL_TORCH_THREADS`` says otherwise (0: torch's own setting)
TRAINING_THREADS = 1
#: the smallest normal float32; below it (and above zero) a float is subnormal
_TINY = th.finfo(th.float32).tiny


def training_threads() -> int:
    """The thread count ``learn`` uses by default (``SB3_MBIL_TORCH_THREADS`` or :data:`TRAINING_THREADS`)."""
    text = os.environ.get("SB3_MBIL_TORCH_THREADS")
    if text is None or text.strip() == "":
        return TRAINING_THREADS
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise ValueError(f"SB3_MBIL_TORCH_THREADS: expected an integer >= 0 (0: torch's own setting), found {text!r}")
    return value


@contextlib.contextmanager
def torch_threads(n: int | None) -> Iterator[None]:
    """Run the block with ``n`` intra-op threads (``None`` or 0: unchanged), then restore the caller's count."""
    previous = th.get_num_threads()
    if not n or n == previous:
        yield
        return
    th.set_num_threads(n)
    try:
        yield
    finally:
        th.set_num_threads(previous)


def flush_subnormals_enabled() -> bool:
    """Whether ``learn`` flushes subnormal floats to zero (``SB3_MBIL_FLUSH_SUBNORMALS``: ``1``, the default, or ``0``)."""
    text = os.environ.get("SB3_MBIL_FLUSH_SUBNORMALS")
    if text is None or text.strip() == "":
        return True
    if text.strip() not in ("0", "1"):
        raise ValueError(f"SB3_MBIL_FLUSH_SUBNORMALS: expected 0 or 1, found {text!r}")
    return text.strip() == "1"


def flushing_subnormals() -> bool:
    """Whether this thread's CPU flushes subnormal floats to zero now (torch has no getter: a subnormal product tells)."""
    return float((th.full((1,), _TINY / 4) * th.ones(1)).item()) == 0.0


@contextlib.contextmanager
def flush_subnormals(on: bool) -> Iterator[None]:
    """Run the block with subnormal floats flushed to zero (``on``; where the CPU supports it), then restore the
    caller's mode."""
    previous = flushing_subnormals()
    if not on or previous:
        yield
        return
    th.set_flush_denormal(True)
    try:
        yield
    finally:
        th.set_flush_denormal(previous)


@contextlib.contextmanager
def training_cpu(model) -> Iterator[None]:
    """The CPU settings ``learn`` trains ``model`` with: its intra-op threads (``model.torch_threads``, default
    :func:`training_threads`) and subnormal floats flushed (:func:`flush_subnormals_enabled`)."""
    threads = getattr(model, "torch_threads", None)
    with torch_threads(training_threads() if threads is None else threads), flush_subnormals(flush_subnormals_enabled()):
        yield


def on_training_cpu(method: _Method) -> _Method:
    """Run a model's method (a fit a user may call outside ``learn``: MBIL's ``fit_flows``, MBIL-C's
    ``fit_models``) under :func:`training_cpu`, as ``learn`` runs it."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        with training_cpu(self):
            return method(self, *args, **kwargs)

    return wrapper  # type: ignore[return-value]
