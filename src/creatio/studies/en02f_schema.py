"""The config schema of EN-02F (docs/studies.md, docs/model.md s.11): flight and impact
settings, the cycle lengths and restitutions, the drop test; the run is en02f.py."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from creatio.dynamics import problem as core
from creatio.dynamics.problem import MAX_IMPACT_CAP, MAX_RHS_EVALS, SphereProblem
from creatio.model.laws import Law
from creatio.model.numerics import steps_in
from creatio.model.surface import Motion
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    DynamicStudy,
    count,
    culprit,
    require,
    require_runs,
    require_samples,
    with_cycle,
)

__all__ = ["ContactLoss", "DropConfig", "En02fConfig", "En02fStudy", "FlightConfig"]


class ContactLoss(StrEnum):
    """What a run does where the normal reaction would go negative (docs/model.md s.11):
    ``stop`` with status contact_lost (every published study), or continue in ``flight``."""

    stop = "stop"
    flight = "flight"


@dataclass
class FlightConfig:
    """Separation, flight and impact (docs/model.md s.11)."""

    contact_loss: ContactLoss = ContactLoss.stop
    restitution: float = 0.0
    resume_speed: float = 1e-4
    impact_cap: float = 100.0

    def check(self, path: str) -> None:
        """e in [0, 1], resumption speed >= 0, impact cap in [1, MAX_IMPACT_CAP] per second
        (the event table holds 3 x cap x duration rows)."""
        require(0.0 <= self.restitution <= 1.0, f"{path}.restitution", self.restitution,
                "must be in [0, 1]")
        require(math.isfinite(self.resume_speed) and self.resume_speed >= 0.0,
                f"{path}.resume_speed", self.resume_speed, "must be finite and >= 0 m/s")
        require(math.isfinite(self.impact_cap) and 1.0 <= self.impact_cap <= MAX_IMPACT_CAP,
                f"{path}.impact_cap", self.impact_cap,
                f"must be between 1 and {MAX_IMPACT_CAP:g} per second (the event table holds "
                "3 x impact_cap x duration rows)")

    def to_events(self) -> core.Events:
        """The numeric-core events of these settings."""
        return core.Events(self.contact_loss is ContactLoss.flight, float(self.restitution),
                           float(self.resume_speed), float(self.impact_cap))


@dataclass
class DropConfig:
    """The drop test of docs/model.md s.11: flat, still surface, sphere dropped at rest."""

    height: float = 0.1
    restitution: float = 0.5
    duration: float = 1.0
    dt: float = 0.001

    def check(self, path: str) -> None:
        """Height, duration and dt > 0, e in (0, 1] (the apex ratio needs bounces)."""
        for name in ("height", "duration", "dt"):
            v = getattr(self, name)
            require(math.isfinite(v) and v > 0.0, f"{path}.{name}", v, "must be > 0")
        require(0.0 < self.restitution <= 1.0, f"{path}.restitution", self.restitution,
                "must be in (0, 1]")
        require(steps_in(self.duration, self.dt) is not None, f"{path}.duration",
                self.duration, f"must be an integer multiple of {path}.dt = {self.dt}")
        require_samples(f"{path}.duration", self.duration,
                        self.duration / self.output_interval(),
                        f"history rows ({path}.duration / {self.output_interval():g} s)")
        steps = self.duration / self.dt
        key = culprit(self, ["duration", "dt"], lambda x: x.duration / x.dt <= MAX_RHS_EVALS)
        require(steps <= MAX_RHS_EVALS, f"{path}.{key}", getattr(self, key),
                f"asks for {count(steps)} steps of the drop test ({path}.duration / {path}.dt), "
                f"more than {MAX_RHS_EVALS:,} (the runs' default budget of evaluations)")

    def output_interval(self) -> float:
        """The drop test's history interval: the multiple of dt nearest 0.01 s."""
        return self.dt * max(1, round(0.01 / self.dt))


@dataclass
class En02fStudy(DynamicStudy):
    """EN-02F: EN-02 at each cycle length T (one cycle each) and restitution e, with flight,
    plus the drop test."""

    cycles_s: list[float] = MISSING
    restitutions: list[float] = MISSING
    drop: DropConfig = field(default_factory=DropConfig)

    def check(self, path: str) -> None:
        """The EN-02 rules, at least one T > 0 and one e in [0, 1], the drop test in range."""
        super().check(path)
        for name in ("cycles_s", "restitutions"):
            values = getattr(self, name)
            require(len(values) >= 1, f"{path}.{name}", list(values), "needs at least 1 value")
        for i, T in enumerate(self.cycles_s):
            require(math.isfinite(T) and T > 0.0, f"{path}.cycles_s[{i}]", T, "must be > 0 s")
        for i, e in enumerate(self.restitutions):
            require(0.0 <= e <= 1.0, f"{path}.restitutions[{i}]", e, "must be in [0, 1]")
        longer = max(("cycles_s", "restitutions"), key=lambda n: len(getattr(self, n)))
        require_runs(f"{path}.{longer}", f"[{len(getattr(self, longer)):,} values]",
                     2 * len(self.cycles_s) * len(self.restitutions),
                     "runs (cycles_s x restitutions, at dt and dt / refine)")
        self.drop.check(f"{path}.drop")


@dataclass
class En02fConfig(DynamicConfig):
    """Root schema of EN-02F (docs/studies.md): the study sets T and e per run."""

    study: En02fStudy = field(default_factory=En02fStudy)
    flight: FlightConfig = field(default_factory=FlightConfig)

    def check(self) -> None:
        """The sphere studies' rules, the flight settings, and every run's duration a
        multiple of a fixed dt."""
        self.flight.check("flight")  # first: the other rules build problems from it
        require(not (self.solver.dense_output and self.flight.contact_loss is ContactLoss.flight),
                "solver.dense_output", self.solver.dense_output,
                "is not available with flight.contact_loss = flight (the flight loop takes "
                "its own steps to every event)")
        # the runs' own values before the rules that build their problems (the stability
        # limit): a cycle that is no multiple of dt reached the problem's ValueError, keyless
        self.study.check("study")
        self.solver.check("solver")
        for i, T in enumerate(self.study.cycles_s):
            require(self.solver.adaptive or steps_in(T, self.solver.dt) is not None,
                    f"study.cycles_s[{i}]", T,
                    f"must be an integer multiple of solver.dt = {self.solver.dt}")
        super().check()

    def durations(self) -> list[float]:
        """The default run's length and each cycle's (one run per cycle)."""
        return [self.study.duration, *self.study.cycles_s]

    def duration_keys(self) -> list[tuple[str, Any]]:
        """study.duration, then study.cycles_s[i] for each cycle."""
        return [("study.duration", self.study.duration),
                *((f"study.cycles_s[{i}]", T) for i, T in enumerate(self.study.cycles_s))]

    def run_problems(self, dt: float | None = None
                     ) -> list[tuple[float, float, SphereProblem]]:
        """(T, e, problem) of every run: one cycle of length T, restitution e."""
        base = self.sphere_problem(dt)
        out = []
        for T in self.study.cycles_s:
            motion = with_cycle(base.model.motion, float(T))
            for e in self.study.restitutions:
                out.append((float(T), float(e), base.replace(motion=motion, t_end=float(T),
                                                            restitution=float(e))))
        return out

    def drop_problem(self) -> SphereProblem:
        """The drop test: A = 0 and still phases, dropped from study.drop.height, flight on."""
        d = self.study.drop
        still = Law.constant(0.0)
        return self.sphere_problem(d.dt).replace(
            A=0.0, motion=Motion(still, still, still), t_end=d.duration,
            interval=d.output_interval(), method="rk4", fixed_step=False,
            flight=True, restitution=float(d.restitution), height=d.height)

    def run_events(self) -> core.Events:
        """Flight as configured (flight.contact_loss)."""
        return self.flight.to_events()

    def stability_problems(self) -> list[SphereProblem]:
        """Every (T, e) run of the study."""
        return [p for _, _, p in self.run_problems()]
