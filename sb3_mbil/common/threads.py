"""How many intra-op threads torch uses while an algorithm of this package trains.

The networks here (64-256 units, minibatches of 64-256) gain nothing from torch's intra-op threads, and on a machine
whose cores are shared the default (one thread per core) runs many times slower than one thread: threads spin
waiting for each other. So ``learn`` (and every fit it runs: MBIL's flows, MBIL-C's models) runs with
:data:`TRAINING_THREADS` intra-op threads and gives the caller's setting back when it returns, also on an error.

Change it for every algorithm with the environment variable ``SB3_MBIL_TORCH_THREADS`` (an integer >= 1, or ``0``
to leave torch's own setting alone), or per model by setting ``model.torch_threads`` before ``learn``.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

import torch as th

#: intra-op threads while training, unless ``SB3_MBIL_TORCH_THREADS`` says otherwise (0: torch's own setting)
TRAINING_THREADS = 1


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
