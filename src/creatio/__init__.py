"""creatio: regenerate the CREATIO notebook studies from configuration alone."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("creatio")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"
