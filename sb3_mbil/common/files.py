"""Files written whole or not at all: a temporary file beside the target, renamed into place.

The temporary file is created exclusively (``O_EXCL``, :func:`tempfile.mkstemp`) under a name that
cannot be predicted (``.NAME.PID.RANDOM.tmp``), so a link planted in the target's folder is never
followed and never overwritten through. A process killed mid-write cannot remove its own; the next
write to the same target removes every temporary of a process that no longer runs, so a crash
leaves the old file intact and, after the next write, no stray temporary. The file that replaces the
target gets the permissions a new file would (``0o666`` less the umask), not ``mkstemp``'s ``0o600``.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_temporaries(target: Path) -> list[Path]:
    """Remove the temporaries of ``target`` left by processes that are gone; return them."""
    removed = []
    for tmp in target.parent.glob(f".{target.name}.*.tmp"):
        pid = tmp.name[len(target.name) + 2 : -len(".tmp")].split(".")[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)):
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()
                removed.append(tmp)
    return removed


def _new_file_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_write(target: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``target`` (fsynced), on failure it is removed.

    The temporary is a new, empty regular file created exclusively in the target's folder; a target that is a
    symlink is replaced by the file, not written through.
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        if tmp.is_symlink() or not tmp.is_file():
            raise OSError(f"{tmp}: expected the regular file this write created, found it replaced")
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, _new_file_mode())
        os.replace(tmp, target)
    finally:
        if tmp.is_symlink() or tmp.exists():
            tmp.unlink()


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write a whole text file or nothing (a temporary file in the same folder, then renamed)."""
    with atomic_write(path) as tmp:
        tmp.write_text(text)
