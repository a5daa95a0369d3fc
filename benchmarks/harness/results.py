"""Result rows in a CSV: one row per finished run, appended (and flushed) as soon as it finishes."""

from __future__ import annotations

import contextlib
import csv
import fcntl
import io
import logging
import os
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from sb3_mbil.common.files import write_text  # noqa: F401  (re-exported: the harness writes its reports with it)

logger = logging.getLogger("sb3_mbil.results")


def read_result_rows(path: str | os.PathLike) -> list[dict]:
    """Every row of a results CSV, refusing a malformed one: a ``ValueError`` with the path and line number
    (a row whose number of fields differs from the header's, or a last line without its newline)."""
    path = Path(path)
    text = path.read_text()
    if "\x00" in text:
        n = text[: text.index("\x00")].count("\n") + 1
        raise ValueError(f"{path}:{n}: expected text, found a NUL byte (a damaged file: restore it from git, or drop "
                         "that row so that its run is redone)")
    if text and not text.endswith("\n"):
        n = text.count("\n") + 1
        raise ValueError(f"{path}:{n}: expected complete lines, found an unterminated last line (an interrupted write; "
                         "rerunning the grid drops it and redoes that run)")
    reader = csv.reader(io.StringIO(text, newline=""))
    header = next(reader, None)
    if header is None:
        return []
    rows = []
    for row in reader:
        if len(row) != len(header):
            raise ValueError(f"{path}:{reader.line_num}: expected {len(header)} fields (the header's), found {len(row)}")
        rows.append(dict(zip(header, row)))
    return rows


@contextlib.contextmanager
def locked(path: str | os.PathLike, mode: str) -> Iterator[IO[str]]:
    """The file opened in ``mode`` under an exclusive lock. A file replaced while this waited for the lock (by
    :func:`add_columns`) is opened again, so nothing is written to the replaced copy."""
    while True:
        f = open(path, mode, newline="")
        try:
            fcntl.flock(f, fcntl.LOCK_EX)
            try:
                same = os.fstat(f.fileno()).st_ino == os.stat(path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                try:
                    yield f
                finally:
                    fcntl.flock(f, fcntl.LOCK_UN)
                return
            fcntl.flock(f, fcntl.LOCK_UN)
        finally:
            f.close()


def _records(text: str) -> list[tuple[int, list[str]]]:
    """The CSV records of ``text`` with the index of the physical line each starts on (a quoted field may span
    lines); a record that cannot be parsed ends the list with the fields None."""
    reader = csv.reader(io.StringIO(text, newline=""))
    out: list[tuple[int, list[str]]] = []
    start = 0
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return out
        except csv.Error:
            out.append((start, None))
            return out
        out.append((start, row))
        start = reader.line_num


def drop_incomplete_last_line(path: str | os.PathLike) -> str | None:
    """Cut an interrupted last record (no newline, a NUL byte, or fewer or more fields than the header) off the
    file, and say so. Records are parsed as CSV, so a quoted field that holds a newline is one record, not two.

    Only the last record can be cut by an interrupted append; the run it belonged to is then redone.
    Returns the dropped text, or None.
    """
    path = Path(path)
    if not path.is_file():
        return None
    with locked(path, "r+") as f:
        text = f.read()
        records = _records(text)
        if len(records) <= 1:
            return None  # empty, or a header only: nothing to drop
        header = records[0][1] or []
        start, last = records[-1]
        lines = text.split("\n")
        tail = "\n".join(lines[start:])
        if text.endswith("\n") and last is not None and len(last) == len(header) and "\x00" not in tail:
            return None
        keep = "\n".join(lines[:start]) + "\n"
        f.seek(0)
        f.truncate()
        f.write(keep)
        f.flush()
        os.fsync(f.fileno())
    logger.warning("%s: dropped an incomplete last line (an interrupted write), its run is redone: %r", path, tail[:80])
    return tail


def finished_keys(path: str | os.PathLike, key_columns: tuple[str, ...]) -> set[tuple[str, ...]]:
    """Keys of the rows already in the CSV (so an interrupted grid resumes where it stopped); an interrupted
    last line is dropped first, so its run is redone."""
    path = Path(path)
    if not path.is_file():
        return set()
    drop_incomplete_last_line(path)
    return {tuple(str(row[c]) for c in key_columns) for row in read_result_rows(path) if all(row.get(c) for c in key_columns)}


def append_row(path: str | os.PathLike, row: dict, columns: list[str]) -> None:
    """Append one complete line under an exclusive lock (header first if the file is new).

    An existing file keeps its own header: columns it lacks are left out of the new line.
    """
    append_rows(path, [row], columns)


def settings_by_cell(path: str | os.PathLike) -> dict[tuple[str, str], set[str]]:
    """The ``settings`` values of a results CSV's rows per (algo, env) (empty when the file does not exist): what the
    grid's and the curves' settings checks compare a new run's settings with."""
    out: dict[tuple[str, str], set[str]] = {}
    if Path(path).is_file():
        for row in read_result_rows(path):
            out.setdefault((row["algo"], row["env"]), set()).add(row["settings"])
    return out


def append_rows(path: str | os.PathLike, rows: list[dict], columns: list[str]) -> None:
    """Append complete lines in one write under an exclusive lock, so a run's rows land together
    (a run interrupted while saving leaves none of them, and is redone on resume). An interrupted last line
    already in the file is dropped first, so the new rows start on a fresh line."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    drop_incomplete_last_line(path)
    with locked(path, "a+") as f:
        buf = io.StringIO()
        f.seek(0, os.SEEK_END)
        if f.tell() == 0:
            csv.writer(buf).writerow(columns)
        else:
            f.seek(0)
            columns = next(csv.reader(f))
            f.seek(0, os.SEEK_END)
        writer = csv.DictWriter(buf, fieldnames=columns, extrasaction="ignore")
        for row in rows:
            writer.writerow({c: row.get(c, "") for c in columns})
        size = f.tell()
        try:
            f.write(buf.getvalue())
            f.flush()
            os.fsync(f.fileno())
        except OSError:  # e.g. a full disk: take back what was written, so the rows land whole or not at all
            with contextlib.suppress(OSError):
                os.ftruncate(f.fileno(), size)
            raise


def add_columns(path: str | os.PathLike, columns: list[str]) -> list[str]:
    """Give an existing results CSV the ``columns`` its header lacks (empty in its rows, appended at the end), the
    file rewritten whole or not at all, under the appenders' lock; returns the columns added. :func:`append_rows`
    keeps a file's own header and leaves out what it lacks, so a new column must be added before rows that use it."""
    path = Path(path)
    if not path.is_file():
        return []
    drop_incomplete_last_line(path)
    with locked(path, "r") as f:
        text = f.read()
        header = next(csv.reader(io.StringIO(text)), None)
        missing = [c for c in columns if header is not None and c not in header]
        if missing:
            rows = read_result_rows(path)
            buf = io.StringIO()
            writer = csv.DictWriter(buf, fieldnames=[*header, *missing])
            writer.writeheader()
            writer.writerows(rows)
            write_text(path, buf.getvalue())
    return missing


