"""The config types every study shares: geometry, time laws, sphere, structure, solver,
outputs, the sphere studies' root (DynamicConfig), the probe's, the rules their values obey
(require, the size limits) and vary. Each study's own schema stands beside its run function
in ``<study>_schema.py`` (ct02_schema, en01_schema, en02g_schema, en02f_schema, en03_schema,
en03m_schema, en05_schema), importable without the compiler or xarray that the run module
loads, since every config is validated when a workflow is planned; the analyses keep theirs
in their own module, loaded only when one is asked for.

A study's config is a tree of these dataclasses (Hydra composes it from ``conf/``; the
pipeline merges it onto the schema and calls ``check``). Each ``check`` raises
:class:`~creatio.errors.ConfigError` naming the key, the value and the rule, before anything
is computed. Nothing here composes configs or imports Hydra: the schemas are plain data.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields, is_dataclass
from enum import Enum, StrEnum
from typing import Any

from creatio.dynamics import problem as core
from creatio.dynamics.problem import (
    MAX_RHS_EVALS,
    SphereProblem,
    UnstableStepError,
    check_stable,
    stability_limit,
)
from creatio.dynamics.solvers import METHODS
from creatio.errors import ConfigError
from creatio.model.cavity import cavity_radius
from creatio.model.control import Controller, outer_gains
from creatio.model.laws import Law, LawKind
from creatio.model.numerics import steps_in
from creatio.model.oscillation import still_cavity
from creatio.model.ribs import Ribs, rib_errors
from creatio.model.sphere import inertia
from creatio.model.surface import Motion, Surface

__all__ = [
    "check_bases",
    "AngleUnit",
    "Confinement",
    "ControlGroup",
    "DynamicConfig",
    "DynamicStudy",
    "GeometryConfig",
    "InitialConfig",
    "LawConfig",
    "MAX_ITEMS",
    "MAX_RUNS",
    "MAX_SAMPLES",
    "MAX_START_DEG",
    "MISSING",
    "Method",
    "NO_CYCLE",
    "OMIT_NULL",
    "Output",
    "PhasePairConfig",
    "PhasesConfig",
    "ProbeConfig",
    "Rung",
    "SolverConfig",
    "SphereConfig",
    "StructureConfig",
    "check_angle_deg",
    "check_finite",
    "check_grid",
    "check_inclinations",
    "check_inertia",
    "check_positive_list",
    "count",
    "culprit",
    "require",
    "require_runs",
    "require_samples",
    "still_cavity_k_alpha",
    "vary",
    "with_cycle",
]

#: A mandatory value (OmegaConf's marker for "must be set"), without importing OmegaConf.
MISSING: Any = "???"

#: Field metadata of an optional group that the canonical resolved text leaves out while it is
#: null (creatio.pipeline.config.omit_nulls): adding such a group keeps every config that does
#: not use it, its YAML and its sha256 (which key the outputs), byte for byte as they were.
OMIT_NULL = "omit_null"


#: Magnitudes a config number may take (besides 0): squares and products of a few of them stay
#: finite in double precision, so a validated value never overflows inside the model.
TINY, HUGE = 1e-30, 1e15


def check_finite(obj: Any, prefix: str = "") -> None:
    """Refuse NaN and infinities in every number of a config tree (lists included), and
    magnitudes outside [TINY, HUGE]: a number that cannot be finite is never meaningful here.
    A field may accept infinity where it means something (a fixed structure's inertia): it
    says so with the metadata ``{"infinite": True}``, or by being infinite by default."""
    for f in fields(obj):
        value = getattr(obj, f.name)
        key = f"{prefix}{f.name}"
        if is_dataclass(value):
            check_finite(value, f"{key}.")
            continue
        if isinstance(value, dict):
            for name, item in value.items():
                if is_dataclass(item):
                    check_finite(item, f"{key}.{name}.")
            continue
        default = f.default if f.default is not dataclasses.MISSING else (
            f.default_factory() if f.default_factory is not dataclasses.MISSING else None)
        infinite_ok = f.metadata.get("infinite", False) or _has_inf(default)
        items = value if isinstance(value, list) else [value]
        if isinstance(value, list):
            require(len(value) <= MAX_ITEMS, key, f"[{len(value):,} values]",
                    f"holds more than {MAX_ITEMS:,} values (each is a run or a sampled "
                    "point): use fewer")
        for i, item in enumerate(items):
            where = f"{key}[{i}]" if isinstance(value, list) else key
            if isinstance(item, float) and not math.isfinite(item):
                if math.isinf(item) and infinite_ok:
                    continue
                raise ConfigError(where, item, "must be a finite number")
            if isinstance(item, int | float) and not isinstance(item, bool) and item != 0 and (
                    not TINY <= abs(item) <= HUGE):
                raise ConfigError(where, item, f"must be 0 or between {TINY:g} and {HUGE:g} "
                                  "in magnitude (beyond, the model's squares and products "
                                  "overflow or divide by zero)")


def _has_inf(default: Any) -> bool:
    items = default if isinstance(default, list) else [default]
    return any(isinstance(x, float) and math.isinf(x) for x in items)


def vary(cfg: Any, changes: Mapping[str, Any]) -> Any:
    """A copy of a validated config tree with dotted keys set (``{"sphere.mu": 0.3}``),
    checked again: how an analysis or a sweep varies a base config without composing it.

    Values are converted to the field's type (int, float, bool, str or an Enum; a list of
    numbers item by item); a key the schema does not have, or a value its type refuses,
    raises ConfigError like validation, and so do a non-finite number and a magnitude
    outside [TINY, HUGE] (check_finite), then the rules (``check``): every point of a
    sweep meets the checks of a single run.
    Interpolations were resolved at validation, so a key that others follow must be varied
    with them (``phases.T`` with ``study.duration``).
    """
    out = copy.deepcopy(cfg)
    for key, value in changes.items():
        *path, name = key.split(".")
        node = out
        for part in path:
            if not (is_dataclass(node) and hasattr(node, part)):
                raise ConfigError(key, value, "unknown key (not in this study's config)")
            node = getattr(node, part)
        types = {f.name: f.type for f in fields(node)} if is_dataclass(node) else {}
        if name not in types:
            raise ConfigError(key, value, "unknown key (not in this study's config)")
        setattr(node, name, _coerce(key, value, getattr(node, name)))
    check_finite(out)
    out.check()
    return out


def _coerce(key: str, value: Any, current: Any) -> Any:
    """value converted to the type of the field's current value."""
    try:
        if isinstance(current, Enum):
            return type(current)(value)
        if isinstance(current, bool):
            if not isinstance(value, bool):
                raise TypeError("not a bool")
            return value
        if isinstance(current, int):
            if isinstance(value, bool) or float(value) != int(value):
                raise TypeError("not an integer")
            return int(value)
        if isinstance(current, float):
            if isinstance(value, bool):
                raise TypeError("not a number")
            return float(value)
        if isinstance(current, list):
            if isinstance(value, str | bytes) or not isinstance(value, Sequence):
                raise TypeError("not a list")
            kinds = {type(x) for x in current}
            if len(kinds) == 1 and kinds <= {int, float}:  # numbers: each meets the type
                return [_coerce(f"{key}[{i}]", x, current[0]) for i, x in enumerate(value)]
            return list(value)
        return value
    except (TypeError, ValueError, OverflowError) as e:  # int(inf): OverflowError
        raise ConfigError(key, value, f"has the wrong type ({e})") from None


class AngleUnit(StrEnum):
    """Unit of the angle-valued parameters of a law (converted to radians once)."""

    rad = "rad"
    deg = "deg"


#: Integration scheme of the sphere studies: one member per method of the registry
#: (creatio.dynamics.solvers.METHODS), so a registered method is a valid config value.
Method = StrEnum("Method", {name: name for name in METHODS})
Method.__doc__ = "Integration scheme of the sphere studies (creatio.dynamics.solvers.METHODS)."


class Output(StrEnum):
    """What a sphere run is asked to report (and so to integrate)."""

    trajectory = "trajectory"
    rotation = "rotation"
    energy = "energy"


def with_cycle(motion: Motion, T: float) -> Motion:
    """The motion with every law's cycle length set to T (EN-02F's cycle sweep)."""
    return Motion(*(dataclasses.replace(law, T=T)
                    for law in (motion.phi_r, motion.phi_a, motion.gamma)))


def require(ok: bool, key: str, value: Any, rule: str) -> None:
    """Raise ConfigError(key, value, rule) unless ok."""
    if not ok:
        raise ConfigError(key, value, rule)


#: The most samples one array of a run may hold (grid points, history rows, a scene's
#: slider stops x mesh points): each sample carries tens of float64 figures, so 2 million
#: keep a run within about a GB (the defaults use 28,224 at most, EN-01's regularity grid).
#: The size is computed from the config and refused before anything is allocated: a step
#: of 1e-6 degrees passed validation and died in a MemoryError.
MAX_SAMPLES = 2_000_000


def require_samples(key: str, value: Any, n: float, what: str) -> None:
    """Refuse a config whose `what` would number n > MAX_SAMPLES, naming the key that sets
    it and the count."""
    require(n <= MAX_SAMPLES, key, value,
            f"asks for {count(n)} {what}, more than {MAX_SAMPLES:,} (memory): use fewer")


def count(n: float) -> str:
    """A size for a message: digits grouped up to 1e15, then 3 significant digits."""
    if not math.isfinite(n):
        return "an unbounded number of"
    return f"{n:,.0f}" if n < 1e15 else f"{n:.3g}"


#: The most runs (integrations, or fits) one study may ask for: the sweeps' default limit
#: (creatio.pipeline.sweep.MAX_POINTS). The defaults ask for 4,096 at most (EN-05's Sobol'
#: design, 512 x (6 inputs + 2)); a grid of 29 million controllers was accepted and ran.
MAX_RUNS = 200_000

#: The most values one list of a config may hold: each is a run, a grid line or a sampled
#: point (the defaults hold 22 at most), so a longer list is a mistake or a sweep.
MAX_ITEMS = 10_000


def check_bases(bases: Mapping[str, Any]) -> None:
    """Check every base config a study or scene holds under ``bases``, its refusal named
    under bases.<name> (bases.en02.sphere.mu, not sphere.mu)."""
    for name, base in bases.items():
        try:
            base.check()
        except ConfigError as e:
            raise ConfigError(f"bases.{name}.{e.key}", e.value, e.rule) from None


def require_runs(key: str, value: Any, n: float, what: str) -> None:
    """Refuse a config whose `what` would number n > MAX_RUNS runs, naming the key that
    sets it and the count."""
    require(n <= MAX_RUNS, key, value,
            f"asks for {count(n)} {what}, more than {MAX_RUNS:,} (time): use fewer")


def culprit(obj: Any, names: Sequence[str], fits: Callable[[Any], bool]) -> str:
    """The field of obj (a dataclass) among names whose default alone makes fits(obj) true:
    the key a size refusal names when several set the size (the first one otherwise)."""
    for name in names:
        f = next(f for f in fields(obj) if f.name == name)
        default = (f.default if f.default is not dataclasses.MISSING
                   else f.default_factory())  # type: ignore[misc]
        if fits(dataclasses.replace(obj, **{name: default})):
            return name
    return names[0]


#: The bound of a start angle in degrees: one turn either way. A start angle is bounded, not
#: reduced modulo 360 (a reduced value would key another config than the one typed); 1e15
#: degrees passed validation and lost every significant digit in its sine.
MAX_START_DEG = 360.0


def check_angle_deg(key: str, value: float) -> None:
    """Refuse a start angle in degrees outside [-MAX_START_DEG, MAX_START_DEG]."""
    require(-MAX_START_DEG <= value <= MAX_START_DEG, key, value,
            f"must lie in [-{MAX_START_DEG:g}, {MAX_START_DEG:g}] degrees (one turn either "
            "way; angles are bounded, not reduced)")


# --------------------------------------------------------------------------------- schemas
_USED = {
    LawKind.constant: {"phi0"},
    LawKind.linear: {"phi0", "rate"},
    LawKind.quintic: {"phi0", "delta"},
    LawKind.sinusoid: {"phi0", "amplitude", "omega"},
    LawKind.cosine_ramp: {"phi0", "delta"},
    LawKind.trapezoid: {"phi0", "delta", "rate"},  # rate: the trapezoid's cruise rate
}


@dataclass
class LawConfig:
    """A time law: phi0 + rate t + delta s(t/T) + amplitude sin(omega t), by kind (s the
    kind's step: quintic or cosine_ramp)."""

    kind: LawKind = LawKind.constant
    phi0: float = 0.0
    rate: float = 0.0
    delta: float = 0.0
    amplitude: float = 0.0
    omega: float = 0.0
    unit: AngleUnit = AngleUnit.rad

    def to_law(self, T: float = 1.0) -> Law:
        """Convert to a :class:`Law` in radians (T is the quintic cycle length; a trapezoid
        travels delta in T at the cruise rate ``rate``, which sets its ramp fraction)."""
        f = math.pi / 180.0 if self.unit is AngleUnit.deg else 1.0
        if self.kind is LawKind.trapezoid:
            ramp = 1.0 - abs(self.delta) / (abs(self.rate) * T) if self.rate else 0.0
            return Law.trapezoid(self.phi0 * f, self.delta * f, T, ramp)
        return Law(
            phi0=self.phi0 * f,
            rate=self.rate * f,
            delta=self.delta * f,
            T=T,
            amplitude=self.amplitude * f,
            omega=self.omega,
            kind=self.kind,
        )

    def check(
        self, path: str, inclination: bool = False, kinds: Sequence[LawKind] | None = None
    ) -> None:
        """Refuse parameters the kind does not use, negative amplitude, out-of-range gamma,
        and kinds the study cannot use (when ``kinds`` is given)."""
        if kinds is not None:
            require(self.kind in kinds, f"{path}.kind", self.kind.value,
                     f"this study takes only {', '.join(k.value for k in kinds)}")
        for name in ("phi0", "rate", "delta", "amplitude", "omega"):
            v = getattr(self, name)
            require(math.isfinite(v), f"{path}.{name}", v, "must be a finite number")
            if name not in _USED[self.kind]:
                require(v == 0.0, f"{path}.{name}", v, f"is not used by kind={self.kind.value}")
        require(self.amplitude >= 0.0, f"{path}.amplitude", self.amplitude, "must be >= 0")
        if inclination:
            lo, hi = self.to_law().bounds()
            require(
                -math.pi / 2 - 1e-12 <= lo and hi <= math.pi / 2 + 1e-12,
                f"{path}",
                f"range [{lo:.6g}, {hi:.6g}] rad",
                "an inclination must stay in [-pi/2, pi/2] (|gamma0| + G <= pi/2)",
            )


@dataclass
class GeometryConfig:
    """Surface shape: inner radius, width, amplitude, radial and angular cycle counts; and
    whether N ribs make it (docs/model.md s.14.4): ``ribs`` = N at alpha_j = 2 pi j / N with
    the periodic spline of degree ``rib_degree`` (5) between them, and with ``rib_seed``
    each rib's amplitude error e_j ~ N(0, rib_sigma_e) and phase offset d_j ~ N(0,
    rib_sigma_d_deg) (defaults 0.01 and 1 degree). Each is left out of the canonical text
    while null (ribs null: the ideal surface), so the existing configs keep their hashes."""

    R0: float = MISSING
    dR: float = MISSING
    A: float = MISSING
    Kr: int = MISSING
    Ka: int = MISSING
    ribs: int | None = field(default=None, metadata={OMIT_NULL: True})
    rib_degree: int | None = field(default=None, metadata={OMIT_NULL: True})
    rib_sigma_e: float | None = field(default=None, metadata={OMIT_NULL: True})
    rib_sigma_d_deg: float | None = field(default=None, metadata={OMIT_NULL: True})
    rib_seed: int | None = field(default=None, metadata={OMIT_NULL: True})

    def check(self, path: str) -> None:
        """R0 > 0, dR > 0, 0 <= A < R0, Kr and Ka positive integers."""
        require(self.R0 > 0.0, f"{path}.R0", self.R0, "must be > 0")
        require(self.dR > 0.0, f"{path}.dR", self.dR, "must be > 0")
        require(
            0.0 <= self.A < self.R0, f"{path}.A", self.A, f"must satisfy 0 <= A < R0 = {self.R0}"
        )
        require(self.Kr >= 1, f"{path}.Kr", self.Kr, "must be a positive integer")
        require(self.Ka >= 1, f"{path}.Ka", self.Ka, "must be a positive integer")
        self._check_ribs(path)

    def _check_ribs(self, path: str) -> None:
        """ribs an integer > 2 Ka, rib_degree 5, sigmas finite and >= 0, rib_seed an integer
        >= 0; the rib_* keys only with ribs."""
        if self.ribs is None:
            for name in ("rib_degree", "rib_sigma_e", "rib_sigma_d_deg", "rib_seed"):
                value = getattr(self, name)
                require(value is None, f"{path}.{name}", value,
                        f"needs {path}.ribs (the number of ribs; null: the ideal surface)")
            return
        Ka = self.Ka
        require(isinstance(self.ribs, int) and self.ribs > 2 * Ka, f"{path}.ribs", self.ribs,
                f"must be an integer > 2 Ka = {2 * Ka} (N <= 2 Ka ribs cannot carry the "
                "travelling wave)")
        require(self.rib_degree in (None, 5), f"{path}.rib_degree", self.rib_degree,
                "must be 5 (the quintic skin: C4, the offset surface reads third derivatives)")
        for name, what in (("rib_sigma_e", "the ribs' relative amplitude error"),
                           ("rib_sigma_d_deg", "the ribs' phase offset in degrees")):
            value = getattr(self, name)
            if value is not None:
                require(isinstance(value, int | float) and math.isfinite(value)
                        and value >= 0.0, f"{path}.{name}", value,
                        f"must be finite and >= 0 ({what})")
        if self.rib_seed is not None:
            require(isinstance(self.rib_seed, int) and self.rib_seed >= 0, f"{path}.rib_seed",
                    self.rib_seed, "must be an integer >= 0 (null: exact ribs)")

    def rib_set(self) -> Ribs | None:
        """The numeric core's ribs (None: the ideal surface), errors drawn from rib_seed."""
        if self.ribs is None:
            return None
        if self.rib_seed is None:
            return Ribs(self.ribs)
        sigma_e = 0.01 if self.rib_sigma_e is None else self.rib_sigma_e
        sigma_d = 1.0 if self.rib_sigma_d_deg is None else self.rib_sigma_d_deg
        e, d = rib_errors(self.ribs, sigma_e, math.radians(sigma_d), self.rib_seed)
        return Ribs(self.ribs, tuple(e), tuple(d))

    def surface(self) -> Surface:
        """The numeric-core surface (with its ribs when ribs is set)."""
        return Surface(self.R0, self.dR, self.A, self.Kr, self.Ka, ribs=self.rib_set())


NO_CYCLE = (LawKind.constant, LawKind.linear, LawKind.sinusoid)  # a step needs phases.T


@dataclass
class PhasePairConfig:
    """Radial and angular phase laws (the inclination is set by the study)."""

    r: LawConfig = field(default_factory=LawConfig)
    a: LawConfig = field(default_factory=LawConfig)

    def check(self, path: str) -> None:
        """Each law constant or linear: CT-02's helical pitch is defined for linear phases."""
        linear = (LawKind.constant, LawKind.linear)
        self.r.check(f"{path}.r", kinds=linear)
        self.a.check(f"{path}.a", kinds=linear)


@dataclass
class PhasesConfig:
    """Radial phase, angular phase and inclination laws; T is every quintic law's cycle."""

    T: float = 1.0
    r: LawConfig = field(default_factory=LawConfig)
    a: LawConfig = field(default_factory=LawConfig)
    gamma: LawConfig = field(default_factory=LawConfig)

    def check(self, path: str) -> None:
        """T > 0, each law valid, inclination within [-pi/2, pi/2]."""
        require(self.T > 0.0, f"{path}.T", self.T, "must be > 0")
        self.r.check(f"{path}.r")
        self.a.check(f"{path}.a")
        self.gamma.check(f"{path}.gamma", inclination=True)
        for name in ("r", "a", "gamma"):
            law = getattr(self, name)
            if law.kind is LawKind.trapezoid:
                D = abs(law.delta)
                require(D > 0.0 and law.rate * law.delta > 0.0
                        and D / self.T < abs(law.rate) <= 2.0 * D / self.T + 1e-12 * D,
                        f"{path}.{name}.rate", law.rate,
                        f"a trapezoid's cruise rate has delta's sign and a size in (|delta| / T, "
                        f"2 |delta| / T] = ({D / self.T:.6g}, {2 * D / self.T:.6g}] "
                        f"{law.unit.value}/s (its ramp fraction in (0, 1/2])")

    def switch_times(self) -> list[tuple[str, float]]:
        """(law, time) of every acceleration jump of the laws (the trapezoids' switches)."""
        return [(name, t) for name, law in zip(("r", "a", "gamma"), self.laws(), strict=True)
                for t in law.switch_times()]

    def laws(self) -> tuple[Law, Law, Law]:
        """(phi_r, phi_a, gamma) as numeric-core laws."""
        return self.r.to_law(self.T), self.a.to_law(self.T), self.gamma.to_law(self.T)


@dataclass
class SphereConfig:
    """The rigid sphere and its contact: mass, radius, gravity, friction, regularisation."""

    m: float = MISSING
    b: float = MISSING
    g: float = 9.81
    mu: float = MISSING
    eps: float = 0.01
    #: the membrane's mounting tilt: its plane off level by beta_deg toward the azimuth
    #: psi_deg (degrees; docs/model.md s.4); null: level (left out of the canonical text
    #: while null, so the level configs keep their hashes)
    beta_deg: float | None = field(default=None, metadata={OMIT_NULL: True})
    psi_deg: float | None = field(default=None, metadata={OMIT_NULL: True})

    def check(self, path: str) -> None:
        """m > 0, b > 0, g >= 0, mu >= 0, eps > 0, 0 <= beta_deg < 90, psi_deg finite."""
        require(self.m > 0.0, f"{path}.m", self.m, "must be > 0")
        require(self.b > 0.0, f"{path}.b", self.b, "must be > 0")
        require(self.g >= 0.0, f"{path}.g", self.g, "must be >= 0")
        require(self.mu >= 0.0, f"{path}.mu", self.mu, "must be >= 0")
        require(self.eps > 0.0, f"{path}.eps", self.eps, "must be > 0")
        if self.beta_deg is not None:
            require(0.0 <= self.beta_deg < 90.0, f"{path}.beta_deg", self.beta_deg,
                    "must lie in [0, 90) degrees (the membrane's tilt off level)")
        if self.psi_deg is not None:
            require(math.isfinite(self.psi_deg), f"{path}.psi_deg", self.psi_deg,
                    "must be finite (the tilt's azimuth in degrees)")

    def sphere(self) -> core.Sphere:
        """The numeric core's sphere, the tilt in radians (null: level, azimuth 0)."""
        return core.Sphere(self.m, self.b, self.g, self.mu, self.eps,
                           math.radians(self.beta_deg or 0.0), math.radians(self.psi_deg or 0.0))


@dataclass(frozen=True)
class Rung:
    """One run of a study's convergence pair, each job solver.dt once did in a field of its
    own: ``label`` names the run's datasets (``en02_dt0.002.nc``), ``step`` is the constant
    step of a fixed-step run (None: adaptive), ``h0`` the first step of an adaptive run (None:
    a fixed step), ``rtol``/``atol`` the tolerances it runs at (an adaptive run's error
    control; an implicit method's Newton stop at a fixed step; unused by RK4). ``dt`` is the
    value the run is named and looked up by (creatio.studies.registry passes it to the run)."""

    dt: float
    label: str
    step: float | None
    h0: float | None
    rtol: float
    atol: float


@dataclass
class SolverConfig:
    """Time integration: method, step, refinement for the convergence pair, output sampling.

    Each study runs a convergence pair, one :class:`Rung` per run (:meth:`rungs`): the run
    named by dt and its partner named by dt / refine (datasets ``<id>_dt0.002.nc``,
    ``<id>_dt0.001.nc``). rk4 (and any method with fixed_step) takes the constant step dt,
    and its partner dt / refine. The adaptive methods control the local error to rtol/atol,
    and their partner runs at the tolerances divided by refine**order (the error ratio a dt /
    refine pair of that order gives when the global error is proportional to the tolerance);
    their first step is h0, or while h0 is null the run's dt (dt, then dt / refine: the
    behaviour before h0 existed). h0 is refused for a fixed step. dense_output samples the
    output grid from each step's interpolant instead of cutting steps to land on it (then a
    fixed dt need not divide output_interval). max_rhs_evals is each run's budget of
    right-hand-side evaluations: a run that spends it stops with status budget_exceeded.
    """

    method: Method = Method.rk4
    dt: float = 0.002
    #: The first step of an adaptive method (s); null: each run's dt. Left out of the
    #: canonical text while null, so every config without it keeps its hash.
    h0: float | None = field(default=None, metadata={OMIT_NULL: True})
    refine: int = 2
    output_interval: float = 0.1
    allow_unstable: bool = False
    rtol: float = 1e-8
    atol: float = 1e-10
    fixed_step: bool = False
    dense_output: bool = False
    max_rhs_evals: int = MAX_RHS_EVALS

    @property
    def adaptive(self) -> bool:
        """Whether the step is set by error control rather than by dt."""
        return METHODS[str(self.method)].adaptive and not self.fixed_step

    def check(self, path: str) -> None:
        """dt > 0, h0 finite and > 0 for an adaptive method only, refine >= 2, tolerances > 0
        (the partner's too), a budget >= 1, output_interval a multiple of a fixed dt."""
        require(self.dt > 0.0, f"{path}.dt", self.dt, "must be > 0")
        self._check_h0(path)
        require(self.max_rhs_evals >= 1, f"{path}.max_rhs_evals", self.max_rhs_evals,
                "must be a positive integer (right-hand-side evaluations per run)")
        require(self.refine >= 2, f"{path}.refine", self.refine, "must be an integer >= 2")
        require(math.isfinite(self.rtol) and self.rtol > 0.0, f"{path}.rtol", self.rtol,
                 "must be finite and > 0")
        require(math.isfinite(self.atol) and self.atol > 0.0, f"{path}.atol", self.atol,
                 "must be finite and > 0")
        if self.adaptive:
            finest = self.rungs()[-1].rtol
            require(finest >= 100 * sys.float_info.epsilon, f"{path}.rtol", self.rtol,
                     f"divided by refine**order (the convergence partner) gives {finest:.3g}, "
                     f"below 100 x machine epsilon = 2.2e-14: raise it or lower solver.refine")
        require(not (self.fixed_step and not METHODS[str(self.method)].adaptive),
                f"{path}.fixed_step", self.fixed_step,
                f"applies to the adaptive methods; {self.method} always takes a fixed step")
        if self.adaptive or self.dense_output:
            require(
                self.output_interval > 0.0, f"{path}.output_interval", self.output_interval,
                "must be > 0",
            )
            return
        require(
            steps_in(self.output_interval, self.dt) is not None,
            f"{path}.output_interval",
            self.output_interval,
            f"must be a positive integer multiple of solver.dt = {self.dt}",
        )

    def _check_h0(self, path: str) -> None:
        """h0 null, or a finite positive first step of an adaptive method: a fixed step has no
        first step of its own (every step is dt), so h0 there is refused, never ignored."""
        if self.h0 is None:
            return
        require(math.isfinite(self.h0) and self.h0 > 0.0, f"{path}.h0", self.h0,
                "must be finite and > 0 s (the first step of an adaptive method; null: dt)")
        fixed = ("solver.fixed_step=true makes every step solver.dt" if self.fixed_step
                 else f"{self.method} takes the constant step solver.dt")
        require(self.adaptive, f"{path}.h0", self.h0,
                f"applies to adaptive methods only: {fixed}; leave h0 null")

    def rung(self, dt: float) -> Rung:
        """The run named by dt: its label, its fixed step (dt) or its first step (h0, or dt
        while h0 is null), and tolerances scaled by (dt / solver.dt)**order (the partner's
        are rtol, atol / refine**order)."""
        dt = float(dt)
        scale = (dt / self.dt) ** METHODS[str(self.method)].order
        adaptive = self.adaptive
        return Rung(dt=dt, label=f"dt{dt!r}", step=None if adaptive else dt,
                    h0=(dt if self.h0 is None else self.h0) if adaptive else None,
                    rtol=self.rtol * scale, atol=self.atol * scale)

    def rungs(self) -> list[Rung]:
        """The convergence pair: the run named by dt, then its partner named by dt / refine."""
        return [self.rung(self.dt), self.rung(self.dt / self.refine)]

    def tolerances(self, dt: float) -> tuple[float, float]:
        """(rtol, atol) of the run named by dt (:meth:`rung`), for the datasets' attributes."""
        r = self.rung(dt)
        return r.rtol, r.atol

    def timesteps(self) -> list[float]:
        """The values that name the convergence pair's runs: dt and dt / refine."""
        return [r.dt for r in self.rungs()]


def check_positive_list(path: str, values: Sequence[float], minimum: int = 1) -> None:
    require(len(values) >= minimum, path, list(values), f"needs at least {minimum} value(s)")
    for i, v in enumerate(values):
        require(v > 0.0 and math.isfinite(v), f"{path}[{i}]", v, "must be > 0")


def check_inclinations(path: str, values: Sequence[float]) -> None:
    require(len(values) >= 1, path, list(values), "needs at least 1 value")
    for i, v in enumerate(values):
        require(-90.0 <= v <= 90.0, f"{path}[{i}]", v, "must lie in [-90, 90] degrees")


def check_grid(path: str, n_radii: int, n_angles: int, per: int = 1) -> None:
    """Both counts positive, and the grid (times `per` evaluations of it at once) within
    MAX_SAMPLES."""
    require(n_radii >= 2, f"{path}.n_radii", n_radii, "must be >= 2 (both ends are sampled)")
    require(n_angles >= 1, f"{path}.n_angles", n_angles, "must be >= 1")
    name, value = ("n_angles", n_angles) if n_angles > n_radii else ("n_radii", n_radii)
    require_samples(f"{path}.{name}", value, n_radii * n_angles * per,
                    f"grid points ({n_radii} x {n_angles}" + (f" x {per})" if per > 1 else ")"))


@dataclass
class ControlGroup:
    """The closed loop of docs/model.md s.12.2 on a sphere study (group ``control``): phi_a
    becomes a state driven toward the lead that a position/velocity outer loop with a speed
    limit commands. Angles in degrees, rates in rad/s; the outer gains follow the design rule
    from omega_c, zeta_c and the still cavity's k_alpha (:meth:`DynamicConfig.controller`)."""

    omega_max: float = 2.0          # speed limit of the sphere's alpha (rad/s)
    delta_max_deg: float = 10.0     # lead limit (deg), below half a cavity 180 / Ka
    omega_c: float = 3.0            # outer loop's pole frequency (rad/s)
    zeta_c: float = 1.0             # outer loop's damping
    omega_n: float = 20.0           # servo frequency (rad/s)
    zeta: float = 1.0               # servo damping
    u_max: float | None = None      # servo acceleration limit (rad/s^2 of phi_a); None: none
    theta_goal_deg: float = -360.0  # commanded travel of the contact angle (deg)
    arrival_tol_deg: float = 2.0    # arrival: first time |theta - goal| <= this (deg)

    def check(self, path: str, Ka: int) -> None:
        """Gains and limits positive (zeta >= 0), delta_max in [0, 180 / Ka), u_max > 0 or
        null, a nonzero goal, a positive arrival tolerance."""
        for name in ("omega_max", "omega_c", "zeta_c", "omega_n"):
            v = getattr(self, name)
            require(v > 0.0, f"{path}.{name}", v, "must be > 0 (a gain or a limit)")
        require(self.zeta >= 0.0, f"{path}.zeta", self.zeta, "must be >= 0 (a damping)")
        half = 180.0 / Ka
        require(0.0 <= self.delta_max_deg < half, f"{path}.delta_max_deg", self.delta_max_deg,
                f"must lie in [0, 180 / Ka = {half:g}) deg: at half a cavity the commanded "
                "lead names the next cavity")
        require(self.u_max is None or self.u_max > 0.0, f"{path}.u_max", self.u_max,
                "must be > 0 rad/s^2 (null: no limit)")
        require(self.theta_goal_deg != 0.0, f"{path}.theta_goal_deg", self.theta_goal_deg,
                "must be a nonzero travel (deg)")
        require(self.arrival_tol_deg > 0.0, f"{path}.arrival_tol_deg", self.arrival_tol_deg,
                "must be > 0 deg")


@dataclass
class InitialConfig:
    """Initial contact point and its rates (the sphere starts with zero spin)."""

    R: float = MISSING
    alpha_deg: float = MISSING
    Rdot: float = 0.0
    alphadot: float = 0.0


@dataclass
class DynamicStudy:
    """EN-02 family: duration, initial state, and the outputs asked for.

    outputs: ``trajectory`` alone integrates rotation only where friction or an initial spin
    couples it to the path (mu > 0), and skips the energy bookkeeping; ``rotation`` and
    ``energy`` ask for spin/orientation and for the energy balance.
    """

    id: str = MISSING
    title: str = ""
    duration: float = MISSING
    initial: InitialConfig = field(default_factory=InitialConfig)
    outputs: list[Output] = field(
        default_factory=lambda: [Output.trajectory, Output.rotation, Output.energy]
    )

    def check(self, path: str) -> None:
        """Duration positive; outputs include the trajectory; the start angle bounded."""
        require(self.duration > 0.0, f"{path}.duration", self.duration, "must be > 0")
        check_angle_deg(f"{path}.initial.alpha_deg", self.initial.alpha_deg)
        require(Output.trajectory in self.outputs, f"{path}.outputs",
                 [o.value for o in self.outputs], "must include trajectory")


@dataclass
class DynamicConfig:
    """Root schema of the sphere studies (EN-02, EN-02R)."""

    study: DynamicStudy = field(default_factory=DynamicStudy)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)
    phases: PhasesConfig = field(default_factory=PhasesConfig)
    sphere: SphereConfig = field(default_factory=SphereConfig)
    solver: SolverConfig = field(default_factory=SolverConfig)
    #: the closed loop (docs/model.md s.12.2); null: every phase follows its law (left out
    #: of the canonical text while null, so the prescribed configs keep their hashes)
    control: ControlGroup | None = field(default=None, metadata={OMIT_NULL: True})

    def check(self) -> None:
        """Validate every group, then the cross-group rules (start inside the annulus)."""
        self.geometry.check("geometry")
        self.phases.check("phases")
        self.sphere.check("sphere")
        self.solver.check("solver")
        self.study.check("study")
        if self.control is not None:
            self.control.check("control", self.geometry.Ka)
        self._check_rows()
        R = self.study.initial.R
        require(
            0.0 <= R <= self.geometry.dR,
            "study.initial.R",
            R,
            f"must lie in [0, geometry.dR = {self.geometry.dR}]",
        )
        require(
            self.solver.adaptive or self.solver.dense_output
            or steps_in(self.study.duration, self.solver.dt) is not None,
            "study.duration",
            self.study.duration,
            f"must be an integer multiple of solver.dt = {self.solver.dt}",
        )
        if not (self.solver.adaptive or self.solver.dense_output):
            # a fixed step lands on every jump of a law's acceleration (docs/model.md s.2)
            for name, t in self.phases.switch_times():
                require(steps_in(t, self.solver.dt) is not None, f"phases.{name}", f"{t:.9g} s",
                        f"the trapezoid's switch times must be multiples of solver.dt = "
                        f"{self.solver.dt} s (its steps land on them)")
        self._check_stability()

    def durations(self) -> list[float]:
        """The simulated time of each run of the study (one run here)."""
        return [self.study.duration]

    def _check_rows(self) -> None:
        """The longest run's history (one row every solver.output_interval) within
        MAX_SAMPLES rows, and a fixed step's finest run (at dt / refine) within the run's
        budget of evaluations (solver.max_rhs_evals): refused by the key that sets it."""
        sv, default = self.solver, SolverConfig()
        durations = self.durations()
        longest = max(durations)
        # the key named: the solver setting whose default would fit, else the duration
        where = self.duration_keys()[durations.index(longest)]
        key, value = (("solver.output_interval", sv.output_interval)
                      if longest / default.output_interval <= MAX_SAMPLES else where)
        require_samples(key, value, longest / sv.output_interval,
                        f"history rows ({longest:g} s / solver.output_interval)")
        if not sv.adaptive:  # a fixed step: the finest run's steps, each >= 1 evaluation
            steps = longest / min(r.step for r in sv.rungs() if r.step is not None)
            key, value = (("solver.refine", sv.refine) if longest / sv.dt <= sv.max_rhs_evals
                          else ("solver.dt", sv.dt)
                          if longest / default.dt * sv.refine <= sv.max_rhs_evals else where)
            require(steps <= sv.max_rhs_evals, key, value,
                    f"asks for {count(steps)} steps of the finest run ({longest:g} s / "
                    f"(solver.dt / solver.refine)), more than solver.max_rhs_evals = "
                    f"{sv.max_rhs_evals:,} (each step takes at least one evaluation)")

    def duration_keys(self) -> list[tuple[str, Any]]:
        """(key, value) that sets each of :meth:`durations`, for a refusal to name."""
        return [("study.duration", self.study.duration)]

    def _check_stability(self) -> None:
        """Refuse a fixed dt beyond the explicit scheme's limit for the regularised friction
        (docs/model.md s.6.3) in any run of the study, with the rule and message of
        creatio.dynamics.problem.check_stable; adaptive and L-stable methods have no limit.
        Building the runs' problems is the last check: a value the rules above let through
        but a problem refuses is named by its config key, never a bare ValueError."""
        try:
            problems = self.stability_problems()
        except ValueError as e:
            raise self._refused(e) from None
        for problem in problems:
            try:
                check_stable(problem)
            except UnstableStepError as e:
                raise ConfigError("solver.dt", self.solver.dt, f"{e}; set solver.allow_unstable"
                                  "=true to run anyway (with a warning)") from None

    def _refused(self, e: ValueError) -> ConfigError:
        """A problem's ValueError as a ConfigError naming the config key of the field its
        message begins with (_PROBLEM_KEYS); a refusal of the controlled phase names the
        ``control`` group."""
        if "controlled phase" in str(e):
            return ConfigError("control", "on", f"the run refuses it: {e}")
        field_name = str(e).split()[0].split("=")[0].rstrip(":")
        key = _PROBLEM_KEYS.get(field_name, "study")
        value: Any = self
        for part in key.split("."):
            value = getattr(value, part, None)
        return ConfigError(key, plain_value(value), f"the run refuses it: {e}")

    def sphere_problem(self, dt: float | None = None) -> SphereProblem:
        """The numeric-core problem of this config at timestep dt (default solver.dt), built
        once per process for a given config and dt: validation checks the problem the run
        then uses."""
        dt = self.solver.dt if dt is None else float(dt)
        key = (repr(self), dt)
        problem = _PROBLEMS.get(key)
        if problem is None:
            if len(_PROBLEMS) >= _MAX_PROBLEMS:
                _PROBLEMS.clear()
            problem = _PROBLEMS[key] = self._build_problem(dt)
        return problem

    def _build_problem(self, dt: float) -> SphereProblem:
        """The problem of this config at timestep dt: model, start, solver, output, events."""
        ph, sp, sv, st = self.phases, self.sphere, self.solver, self.study
        rung = sv.rung(dt)
        phi_r, phi_a, gamma = ph.laws()
        problem = SphereProblem(
            model=core.Model(surface=self.geometry.surface(),
                             motion=Motion(phi_r=phi_r, phi_a=phi_a, gamma=gamma),
                             sphere=sp.sphere(), structure=self.run_structure()),
            start=core.Start(R=st.initial.R, alpha=math.radians(st.initial.alpha_deg),
                             Rdot=st.initial.Rdot, alphadot=st.initial.alphadot),
            # h0 stays None while solver.h0 is null: the first step then follows dt, also
            # through problem.replace(dt=...), as it always has
            solver=core.Solver(method=str(sv.method), dt=rung.dt, rtol=rung.rtol,
                               atol=rung.atol, h0=None if sv.h0 is None else rung.h0,
                               fixed_step=sv.fixed_step, dense_output=sv.dense_output,
                               allow_unstable=sv.allow_unstable,
                               max_rhs_evals=sv.max_rhs_evals),
            output=core.Output(t_end=st.duration, interval=sv.output_interval,
                               rotation=True if Output.rotation in st.outputs else None,
                               energy=Output.energy in st.outputs),
            events=self.run_events(),
        )
        ctl = self.controller(problem)
        return problem if ctl is None else problem.replace(control=ctl)

    def controller(self, problem: SphereProblem) -> Controller | None:
        """The closed loop's controller on problem's start (None without the group): gains
        by the design rule of docs/model.md s.12.2 (:func:`still_cavity_k_alpha`)."""
        c = self.control
        if c is None:
            return None
        k_theta, k_omega = outer_gains(c.omega_c, c.zeta_c, still_cavity_k_alpha(problem))
        return Controller(goal=math.radians(c.theta_goal_deg), alpha0=problem.start_point[1],
                          k_theta=k_theta, k_omega=k_omega, omega_max=c.omega_max,
                          delta_max=math.radians(c.delta_max_deg), omega_n=c.omega_n,
                          zeta=c.zeta, u_max=math.inf if c.u_max is None else c.u_max)

    def run_structure(self) -> core.Structure:
        """The structure of the runs: fixed, as in EN-02 (EN-03 sets its own)."""
        return core.Structure()

    def run_events(self) -> core.Events:
        """What the runs do at events: stop at contact loss (EN-02F sets flight)."""
        return core.Events()

    def stability_problems(self) -> list[SphereProblem]:
        """The runs whose fixed step the friction stability rule bounds (at solver.dt)."""
        return [self.sphere_problem()]

    def step_limit(self) -> float:
        """Largest stable fixed step (s) of this configuration's explicit scheme over its runs
        (inf without friction, for an adaptive method and for radau5)."""
        return min((stability_limit(p) for p in self.stability_problems()), default=math.inf)


def still_cavity_k_alpha(problem: SphereProblem) -> float:
    """k_alpha of the design rule (docs/model.md s.12.2-12.3): the square of the rolling
    sphere's small-oscillation frequency along alpha at the bottom of the still cavity whose
    cell the problem starts in (its radial branch at the phases of t = 0); the value of
    creatio.studies.en04.closed_forms, from the problem the run uses."""
    model = problem.model
    surface, sphere = model.surface, model.sphere
    n, _ = problem.cavity_cell()
    R_c = cavity_radius(model.motion.phi_r.scalar(0.0)[0], model.k, n)
    forms = still_cavity(surface.A, model.k, surface.Ka, surface.R0 + R_c, sphere.b, sphere.g,
                         inertia(sphere.m, sphere.b) / (sphere.m * sphere.b ** 2))
    return forms.roll_alpha ** 2


#: Problems built by DynamicConfig.sphere_problem, by (config, dt): a run and its validation
#: share one construction (bounded: a sweep builds a problem per point).
_PROBLEMS: dict[tuple[str, float], SphereProblem] = {}
_MAX_PROBLEMS = 256


#: The config key behind each field of a run's SphereProblem (the first word of its
#: ValueError), for a refusal that only building the problem finds.
_PROBLEM_KEYS = {
    "R0": "geometry.R0", "dR": "geometry.dR", "A": "geometry.A", "Kr": "geometry.Kr",
    "Ka": "geometry.Ka", "m": "sphere.m", "b": "sphere.b", "eps": "sphere.eps",
    "g": "sphere.g", "mu": "sphere.mu", "dt": "solver.dt", "h0": "solver.h0",
    "rtol": "solver.rtol", "atol": "solver.atol", "max_rhs_evals": "solver.max_rhs_evals",
    "interval": "solver.output_interval", "t_end": "study.duration",
    "phi_r": "phases.r", "phi_a": "phases.a", "gamma": "phases.gamma",
    "rotation": "study.outputs", "equilibrium": "sphere.g", "inertia": "structure.inertia",
    "confinement": "structure.confinement", "force": "structure.force",
    "restitution": "flight.restitution", "resume_speed": "flight.resume_speed",
    "impact_cap": "flight.impact_cap", "height": "study.drop.height",
    "beta": "sphere.beta_deg", "psi": "sphere.psi_deg", "ribs": "geometry.ribs",
}


def plain_value(value: Any) -> Any:
    """A config value as the user wrote it (enums as their text, dataclasses by name)."""
    if isinstance(value, Enum):
        return value.value
    if is_dataclass(value):
        return type(value).__name__
    return value


@dataclass
class ProbeConfig:
    """`creatio probe`: one point (alpha in degrees, R, t) of a configured surface."""

    geometry: GeometryConfig = field(default_factory=GeometryConfig)
    phases: PhasesConfig = field(default_factory=PhasesConfig)
    alpha: float = 0.0
    R: float = 0.0
    t: float = 0.0

    def check(self) -> None:
        """Geometry and phases valid; the point finite."""
        self.geometry.check("geometry")
        self.phases.check("phases")
        for name in ("alpha", "R", "t"):
            v = getattr(self, name)
            require(math.isfinite(v), name, v, "must be a finite number")
        check_angle_deg("alpha", self.alpha)


# ------------------------------------------ structure (EN-03, EN-03M, the analyses)
class Confinement(StrEnum):
    """What holds the sphere on the membrane besides gravity (docs/model.md s.10)."""

    none = "none"
    normal = "normal"
    base = "base"


def check_inertia(path: str, value: float) -> None:
    require(value > 0.0, path, value, "must be > 0 kg m^2 (.inf: a fixed structure)")


@dataclass
class StructureConfig:
    """The structure that carries the membrane (docs/model.md s.9-10): its moment of inertia
    about z (``.inf``: fixed, as in EN-02) and a confining force of constant magnitude."""

    inertia: float = math.inf
    confinement: Confinement = Confinement.none
    force: float = 0.0

    def check(self, path: str) -> None:
        """inertia > 0 (inf allowed), force finite and >= 0, a force only with a confinement."""
        check_inertia(f"{path}.inertia", self.inertia)
        require(math.isfinite(self.force) and self.force >= 0.0, f"{path}.force", self.force,
                "must be finite and >= 0 N")
        require(self.confinement is not Confinement.none or self.force == 0.0, f"{path}.force",
                self.force, f"needs {path}.confinement=normal or base")

    def to_structure(self) -> core.Structure:
        """The numeric-core structure."""
        return core.Structure(float(self.inertia), self.confinement.value, float(self.force))


