"""Helpers shared by the command lines: option types that check their range (argparse turns their
``ArgumentTypeError`` into one line naming the option)."""

from __future__ import annotations

import argparse
import math


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, found {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, found {value}")
    return value


def seed(text: str) -> int:
    """A seed: an integer in [0, 2**32 - 1]."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer seed >= 0, found {text!r}") from None
    if not 0 <= value < 2**32:
        raise argparse.ArgumentTypeError(f"expected an integer seed in [0, 2**32 - 1], found {value}")
    return value


def finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a finite number, found {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, found {text!r}")
    return value


def fraction(text: str) -> float:
    """A number in (0, 1)."""
    value = finite_float(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), found {text!r}")
    return value


def parse_seeds(text: str) -> list[int]:
    """``"0-9"``, ``"0,3,5"`` or ``"0-4,10"`` -> list of seeds (each >= 0, ranges increasing)."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        try:
            first, last = seed(lo), (seed(hi) if hi else None)
        except argparse.ArgumentTypeError:
            raise argparse.ArgumentTypeError(f"expected seeds like 0-9, 0,3,5 or 0-4,10, found {text!r}") from None
        if last is not None and last < first:
            raise argparse.ArgumentTypeError(f"expected increasing seed ranges like 0-9, found {part!r}")
        out += list(range(first, last + 1)) if last is not None else [first]
    return out
