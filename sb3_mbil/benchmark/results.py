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
    """Append one complete line under an exclusive lock (header first if the file is new).

    An existing file keeps its own header: columns it lacks are left out of the new line.
    """
    append_rows(path, [row], columns)


def append_rows(path: str | os.PathLike, rows: list[dict], columns: list[str]) -> None:
    """Append complete lines in one write under an exclusive lock, so a run's rows land together
    (a run interrupted while saving leaves none of them, and is redone on resume)."""
    import io

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+", newline="") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            buf = io.StringIO()
            if f.tell() == 0:
                csv.writer(buf).writerow(columns)
            else:
                f.seek(0)
                columns = next(csv.reader(f))
                f.seek(0, os.SEEK_END)
            writer = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore")
            for row in rows:
                writer.writerow({c: row.get(c, "") for c in columns})
            f.write(buf.getvalue())
            f.flush()
            os.fsync(f.fileno())
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write a whole text file or nothing (a temporary file in the same folder, then renamed)."""
    from sb3_mbil.common.files import atomic_write

    with atomic_write(path) as tmp:
        tmp.write_text(text)
