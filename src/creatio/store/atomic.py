"""Files written whole or not at all: a writer writes a temporary sibling and renames it over
the target, so that a killed or failed writer never leaves a partial or empty file; the
temporaries a dead process left are removed by the next writer of the same path."""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["atomic_path", "atomic_save", "atomic_write", "clean_stale"]


def atomic_path(path: Path, tag: str = "") -> Path:
    """A temporary sibling of path, to be renamed over it once complete (tag ends its name:
    a suffix that keeps the format, a part's number); clean_stale knows it by its pid."""
    return path.with_name(f".{path.name}.tmp-{os.getpid()}{tag}")


def clean_stale(path: Path) -> None:
    """Remove temporary siblings of path left by a process that no longer runs (a kill)."""
    for tmp in path.parent.glob(f".{path.name}.tmp-*"):
        m = re.match(r".*\.tmp-(\d+)", tmp.name)
        if m and int(m.group(1)) != os.getpid() and not _alive(int(m.group(1))):
            with contextlib.suppress(OSError):
                if tmp.is_dir():
                    shutil.rmtree(tmp)
                else:
                    tmp.unlink()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[Any]:
    """Open a temporary sibling of path for writing and rename it over path when the block
    ends without error: a killed or failed writer never leaves a partial or empty file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(path)
    tmp = atomic_path(path)
    try:
        with tmp.open(mode, **kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_save(path: str | Path, save: Any) -> Path:
    """Call save(temporary path) (a figure's savefig, say) and rename the result over path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(path)
    tmp = atomic_path(path, path.suffix)  # keeps the format
    try:
        save(tmp)
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise OSError(errno.EIO, "nothing was written", str(path))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
