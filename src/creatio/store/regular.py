"""Files read as data are regular files, checked before a byte is read: a named pipe (FIFO)
planted where a record, a manifest or a dataset should be blocked every reader that opened
it (`creatio ls`, `creatio release verify`, `creatio diff` hung), and a device such as
/dev/zero never ends. Each file is opened without blocking, then its open descriptor is
checked with fstat (no race between the check and the read), then read as usual."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["NotRegularFile", "check_regular", "open_regular", "read_bytes", "read_json",
           "read_text"]

#: What each kind of non-regular file is called in a message.
_KINDS = ((stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISDIR, "a directory"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


class NotRegularFile(OSError):
    """A path the project would read as data names something else than a regular file."""

    def __init__(self, path: str | Path, kind: str) -> None:
        super().__init__(errno.EINVAL, f"is {kind}, not a regular file (creatio reads "
                         "data only from regular files)", str(path))
        self.kind = kind

    def __str__(self) -> str:
        return f"{self.filename}: {self.strerror}"


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a file")


@contextlib.contextmanager
def _descriptor(path: str | Path) -> Iterator[int]:
    """A read-only descriptor of path, opened without blocking and known to be a regular
    file (NotRegularFile otherwise; FileNotFoundError and the like as the system says)."""
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as e:
        if e.errno == errno.ENXIO:  # a socket, or a FIFO that cannot be opened
            raise NotRegularFile(path, "a socket") from None
        raise
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise NotRegularFile(path, _kind(mode))
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
        yield fd
    except BaseException:
        os.close(fd)
        raise


def open_regular(path: str | Path, mode: str = "rb", **kwargs: Any) -> IO[Any]:
    """Open a regular file for reading (mode "r" or "rb", open()'s keyword arguments), never
    blocking on what is not one: NotRegularFile names it instead."""
    if any(c in mode for c in "wax+"):
        raise ValueError(f"open_regular reads only, not mode {mode!r}")
    with _descriptor(path) as fd:
        return os.fdopen(fd, mode, **kwargs)


def check_regular(path: str | Path) -> None:
    """Check that path is a regular file before a library opens it by name (netCDF4, HDF5)
    and would block on a FIFO: NotRegularFile or the system's error if not."""
    with _descriptor(path) as fd:
        os.close(fd)


def read_bytes(path: str | Path) -> bytes:
    """The bytes of a regular file (Path.read_bytes that refuses a FIFO or a device)."""
    with open_regular(path, "rb") as fh:
        return fh.read()


def read_text(path: str | Path, encoding: str = "utf-8") -> str:
    """The text of a regular file (Path.read_text that refuses a FIFO or a device)."""
    with open_regular(path, "r", encoding=encoding) as fh:
        return fh.read()


def read_json(path: str | Path) -> Any:
    """The parsed JSON of a regular file (ValueError when it is not JSON)."""
    return json.loads(read_text(path))
