"""Helpers shared by the command lines: option types that check their range (argparse turns their
``ArgumentTypeError`` into one line naming the option), :func:`run` (errors as one line, the extra to install
named) and :func:`check_output` (committed files are replaced only with ``--overwrite``)."""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any


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


# ---------------------------------------------------------------------- running a script
#: the extra that installs a module a script may need
EXTRA_OF = {"ray": "benchmark", "rliable": "benchmark", "scipy": "benchmark", "matplotlib": "benchmark", "onnx": "export",
            "onnxscript": "export", "minari": "minari", "tensorboard": "tensorboard", "mujoco": "mujoco",
            "imitation": "imitation"}


def is_committed(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a file tracked by the git repository it lies in (False without git or a repository)."""
    path = Path(path).resolve()
    if not path.is_file():
        return False
    try:
        return subprocess.run(["git", "ls-files", "--error-unmatch", path.name], cwd=path.parent,
                              capture_output=True).returncode == 0
    except OSError:
        return False


def check_output(path: str | os.PathLike | None, overwrite: bool, option: str) -> None:
    """Refuse to replace a committed file unless ``--overwrite`` was given (one-line error naming the option)."""
    if path is not None and not overwrite and is_committed(path):
        raise ValueError(f"{option}: {path} is a committed file; pass --overwrite to replace it")


def run(main: Callable[[], Any]) -> Any:
    """Run a script's ``main``: bad input, a missing file or a missing extra is one line on stderr and exit code 1,
    not a traceback."""
    prog = Path(sys.argv[0]).name
    try:
        return main()
    except ImportError as e:
        name = (e.name or "").split(".")[0]
        extra = EXTRA_OF.get(name)
        hint = f": pip install 'sb3_mbil[{extra}]'" if extra else ""
        sys.exit(f"{prog}: needs {name or 'a module that is not installed'}{hint} ({e})")
    except (ValueError, FileNotFoundError, RuntimeError) as e:
        sys.exit(f"{prog}: {e}")
