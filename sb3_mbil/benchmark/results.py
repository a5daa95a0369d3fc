"""Result rows in a CSV: one row per finished run, appended (and flushed) as soon as it finishes."""

from __future__ import annotations

import csv
import fcntl
import os
from pathlib import Path


def finished_keys(path: str | os.PathLike, key_columns: tuple[str, ...]) -> set[tuple[str, ...]]:
    """Keys of the rows already in the CSV (so an interrupted grid resumes where it stopped)."""
    path = Path(path)
    if not path.is_file():
        return set()
    with open(path, newline="") as f:
        return {tuple(str(row[c]) for c in key_columns) for row in csv.DictReader(f) if all(row.get(c) for c in key_columns)}


def append_row(path: str | os.PathLike, row: dict, columns: list[str]) -> None:
    """Append one complete line under an exclusive lock (header first if the file is new)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    line = {c: row.get(c, "") for c in columns}
    with open(path, "a", newline="") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            if f.tell() == 0:
                csv.writer(f).writerow(columns)
            csv.DictWriter(f, fieldnames=columns).writerow(line)
            f.flush()
            os.fsync(f.fileno())
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)
