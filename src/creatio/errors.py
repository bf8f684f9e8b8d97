"""The one error every layer raises for a bad configuration value."""

from __future__ import annotations

from typing import Any

__all__ = ["ConfigError"]


class ConfigError(ValueError):
    """A configuration value broke a rule; the message names key, value and rule."""

    def __init__(self, key: str, value: Any, rule: str) -> None:
        self.key, self.value, self.rule = key, value, rule
        super().__init__(f"invalid config: {key}={value!r}: {rule}")
