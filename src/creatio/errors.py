"""The errors every layer raises for a refused request (a bad configuration value, a
release that cannot be made or read), and the one-line exit the workflow gives them."""

from __future__ import annotations

import argparse
import functools
import os
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["ConfigError", "Parser", "ReleaseError", "interrupted", "one_line_errors"]


class ConfigError(ValueError):
    """A configuration value broke a rule; the message names key, value and rule."""

    def __init__(self, key: str, value: Any, rule: str) -> None:
        self.key, self.value, self.rule = key, value, rule
        super().__init__(f"invalid config: {key}={value!r}: {rule}")


class ReleaseError(Exception):
    """A release cannot be made, found or read; the message says why and what to do."""


class Parser(argparse.ArgumentParser):
    """An argument parser whose refusal is one line (what is wrong, and where --help is),
    exit 2, instead of argparse's usage block; subcommands inherit it."""

    def error(self, message: str) -> Any:  # argparse's hook: must not return
        """Print ``PROG: MESSAGE (see PROG --help)`` on stderr and exit 2."""
        sys.stderr.write(f"{self.prog}: {message} (see {self.prog} --help)\n")
        sys.stderr.flush()
        raise SystemExit(2)


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


def interrupted(error: BaseException) -> bool:
    """Whether an error is a Ctrl-C in disguise: a KeyboardInterrupt, or what a compiled
    (numba) call raises when the interrupt arrives inside it, a SystemError "returned a
    result with an exception set" chained to the KeyboardInterrupt."""
    seen: set[int] = set()
    e: BaseException | None = error
    while e is not None and id(e) not in seen:
        seen.add(id(e))
        if isinstance(e, KeyboardInterrupt) or (
                isinstance(e, SystemError) and "with an exception set" in str(e)):
            return True
        e = e.__cause__ or e.__context__
    return False
