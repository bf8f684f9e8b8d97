"""Files written whole or not at all: a writer writes a temporary sibling and renames it over
the target, so that a killed or failed writer never leaves a partial or empty file; the
temporaries a dead process left are removed by the next writer of the same path. A path
that cannot hold a file at all (a directory of /proc, a read-only filesystem, a file where a
directory should be) is refused in one line naming the real cause (Unwritable), before
anything is written: the libraries' own reports ("HDF error") read as a full disk."""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError

__all__ = ["Unwritable", "atomic_path", "atomic_save", "atomic_write", "check_destination",
           "clean_stale"]

#: Errors that say a path cannot hold a new file (not that the disk is full): the cause
#: as a user reads it. ENOENT in an existing directory is a filesystem without files (/proc).
_REFUSALS = {
    errno.EROFS: "{dir} is on a read-only filesystem",
    errno.EACCES: "permission denied: {dir} is not writable by this user",
    errno.EPERM: "the filesystem does not allow a new file in {dir}",
    errno.ENOTDIR: "a part of {dir} is not a directory",
    errno.EEXIST: "a part of {dir} is not a directory",
    errno.EISDIR: "it is a directory",
    errno.ENAMETOOLONG: "the name is too long for the filesystem",
    errno.EINVAL: "the filesystem refuses this name",
    errno.ENOENT: "the filesystem refuses a new file in {dir}",
}


class Unwritable(ConfigError, OSError):
    """An output path that cannot hold a file: the user named a wrong place (exit 2, one
    line, nothing written), not a failure of the run; an OSError for those who catch one."""

    def __init__(self, path: str | Path, code: int, reason: str) -> None:
        OSError.__init__(self, code, reason, str(path))
        self.key, self.value, self.rule = "output", str(path), reason

    def __str__(self) -> str:
        return (f"cannot write {self.filename}: {self.strerror}: write somewhere writable "
                "(another output path, or another working directory)")


def _virtual(directory: Path) -> bool:
    """Whether directory lies on a filesystem without storage (proc, sysfs: no blocks)."""
    try:
        return os.statvfs(directory).f_blocks == 0
    except OSError:
        return False


def _refused(path: Path, error: OSError) -> OSError:
    """Unwritable for an error that says path cannot hold a file; error itself otherwise
    (a full disk, a failing device: the run's failure, said as the system says it)."""
    code = error.errno or 0
    if code not in _REFUSALS:
        return error
    directory = Path(os.path.abspath(path)).parent  # "." says nothing in a message
    while not directory.exists() and directory != directory.parent:
        directory = directory.parent
    if not directory.is_dir():
        reason = f"{directory} is a file, not a directory"
    elif code == errno.ENOENT and _virtual(directory):
        reason = (f"{directory} is on a virtual filesystem (such as /proc or /sys) that "
                  "holds no files")
    else:
        reason = _REFUSALS[code].format(dir=directory)
    return Unwritable(path, code, reason)


def _prepare(path: Path) -> None:
    """Make the directory of path (and its parents): Unwritable if a file cannot go there."""
    if path.is_dir():
        raise Unwritable(path, errno.EISDIR, "it is a directory")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise _refused(path, e) from None


def _create(tmp: Path, path: Path) -> None:
    """Create the empty temporary tmp of path, so that a refusal names its real cause before
    a library writes to it (netCDF4 says "HDF error", matplotlib what it likes)."""
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666))
    except OSError as e:
        raise _refused(path, e) from None


def check_destination(path: str | Path) -> Path:
    """Check, before a long computation, that a file can be written at path (its directory
    is made, a temporary is created and removed): Unwritable in one line if not."""
    path = Path(path)
    _prepare(path)
    tmp = atomic_path(path, ".probe")
    try:
        _create(tmp, path)
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
    return path


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
    _prepare(path)
    clean_stale(path)
    tmp = atomic_path(path)
    try:
        try:
            fh = tmp.open(mode, **kwargs)
        except OSError as e:
            raise _refused(path, e) from None
        with fh:
            yield fh
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_save(path: str | Path, save: Any) -> Path:
    """Call save(temporary path) (a figure's savefig, say) and rename the result over path."""
    path = Path(path)
    _prepare(path)
    clean_stale(path)
    tmp = atomic_path(path, path.suffix)  # keeps the format
    try:
        _create(tmp, path)
        save(tmp)
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise OSError(errno.EIO, "nothing was written", str(path))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
