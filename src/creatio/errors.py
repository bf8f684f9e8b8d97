"""The errors every layer raises for a refused request (a bad configuration value, a
release that cannot be made or read), and the one-line exit the workflow gives them."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["ConfigError", "ReleaseError", "one_line_errors"]


class ConfigError(ValueError):
    """A configuration value broke a rule; the message names key, value and rule."""

    def __init__(self, key: str, value: Any, rule: str) -> None:
        self.key, self.value, self.rule = key, value, rule
        super().__init__(f"invalid config: {key}={value!r}: {rule}")


class ReleaseError(Exception):
    """A release cannot be made, found or read; the message says why and what to do."""


def one_line_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    """For what the Snakefile calls: a bad config, sweep or release request ends Snakemake
    with creatio's one-line message and exit status 2 instead of an InputFunctionException
    and its traceback. (Planning happens before any job runs or any lock is taken.)"""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except (ConfigError, ReleaseError) as e:
            sys.stderr.write(f"creatio: {e}\n")
            sys.stderr.flush()
            os._exit(2)

    return wrapper
