"""What each study of a sphere scene must provide (frames only): shared by the planner,
the scene computation and the family members, which therefore import it, not each other."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from creatio.pipeline.config import Resolved
from creatio.studies.schema import Output

__all__ = ["RunNeed", "needs"]


@dataclass(frozen=True)
class RunNeed:
    """What one study of a sphere scene must provide: outputs, frame interval, step, span."""

    study: str
    outputs: tuple[str, ...]
    interval: float
    dt: float
    duration: float

    @property
    def frames(self) -> int:
        """Number of frame times, both ends included."""
        return round(self.duration / self.interval) + 1

    def changes(self) -> dict[str, Any]:
        """The config changes that make a study run compute exactly this
        (:func:`creatio.studies.schema.vary`)."""
        return {"study.outputs": [Output(o) for o in self.outputs],
                "solver.output_interval": self.interval}


def needs(resolved: Resolved) -> list[RunNeed]:
    """What each study of a sphere scene must provide (empty for the kinematic scenes)."""
    if not resolved.entry.kind.runs:
        return []
    s = resolved.obj.scene
    outputs = ("trajectory", "rotation") if s.rotation else ("trajectory",)
    out = []
    for name in s.studies:
        base = resolved.obj.bases[name]
        out.append(RunNeed(name, outputs, s.playback.interval, base.solver.dt,
                           base.study.duration))
    return out
