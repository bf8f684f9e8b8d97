"""creatio: regenerate the CREATIO notebook studies from configuration alone."""

from __future__ import annotations

__all__ = ["__version__"]


def __getattr__(name: str) -> str:
    """``__version__`` read from the installed metadata on first use: importlib.metadata
    costs about 40 ms of every command's start (a job's client, ``creatio run``), and most
    commands never print or record the version."""
    if name != "__version__":
        raise AttributeError(f"module 'creatio' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("creatio")
    except PackageNotFoundError:  # running from a source tree that was never installed
        value = "0.0.0+unknown"
    globals()["__version__"] = value
    return value
