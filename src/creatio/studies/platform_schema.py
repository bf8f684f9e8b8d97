"""The config schema of a microgravity platform (conf/platform/<name>.yaml, docs/aerospace.md):
its microgravity window, its quasi-steady residual acceleration (magnitude in g and
direction in the structure's frame) and the ceiling of the preload a demonstrator on it may
use (the pull P / m, in g).

Plain dataclasses and their rules, like creatio.studies.schema. ``check`` raises ConfigError
naming the key, the value and the rule, in one line, before anything runs. The shipped
values (drop tower, parabolic flight, sounding rocket, space station) are illustrative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.studies.schema import MISSING, require

__all__ = ["PlatformConfig"]


@dataclass
class PlatformConfig:
    """One platform: the window (s; null: no limit), the residual acceleration (g) along
    ``residual_direction`` (need not be unit) and the preload ceiling (g)."""

    name: str = MISSING
    label: str = ""
    window_s: float | None = MISSING
    residual_g: float = MISSING
    residual_direction: list[float] = field(default_factory=lambda: [1.0, 0.0, 0.0])
    preload_max_g: float = MISSING

    def check(self, path: str = "platform") -> None:
        """A name; window > 0 or null; residual in [0, 1) g; a finite nonzero direction of 3
        components; 0 < preload_max_g <= 100."""
        require(isinstance(self.name, str) and self.name not in ("", MISSING),
                f"{path}.name", self.name, "must be a non-empty name")
        if self.window_s is not None:
            require(_number(self.window_s) and math.isfinite(self.window_s)
                    and self.window_s > 0.0, f"{path}.window_s", self.window_s,
                    "must be > 0 s (null: no window limit)")
        require(_number(self.residual_g) and 0.0 <= self.residual_g < 1.0,
                f"{path}.residual_g", self.residual_g,
                "must lie in [0, 1) g (a quasi-steady residual of microgravity)")
        d = self.residual_direction
        require(len(d) == 3, f"{path}.residual_direction", list(d),
                "must have 3 components (x, y, z in the structure's frame)")
        for i, c in enumerate(d):
            require(_number(c) and math.isfinite(c), f"{path}.residual_direction[{i}]", c,
                    "must be a finite number")
        require(any(c != 0.0 for c in d), f"{path}.residual_direction", list(d),
                "must not be the zero vector")
        require(_number(self.preload_max_g) and 0.0 < self.preload_max_g <= 100.0,
                f"{path}.preload_max_g", self.preload_max_g,
                "must lie in (0, 100] g (the pull P / (m g) a magnet may give)")

    def unit_direction(self) -> tuple[float, float, float]:
        """The residual's direction as a unit vector."""
        x, y, z = (float(c) for c in self.residual_direction)
        n = math.sqrt(x * x + y * y + z * z)
        return x / n, y / n, z / n


def _number(value: object) -> bool:
    """A real number that is not a bool."""
    return isinstance(value, int | float) and not isinstance(value, bool)
