"""The config schema of EN-06 (docs/materials.md): what the membrane must be made of. The
surfaces of EN-02 and EN-02R (their phase groups on one geometry), the materials (their
groups, conf/material/), and the grids of each part; the run is en06.py. The tolerance
parts (docs/materials.md s.8) vary EN-02's full config, ``bases.en02``, whose geometry is
the study's own: their groups are ``study.tolerances`` and ``study.tilt_check`` (the runs
are en06_tolerances.py).

Every size that sets an allocation or a count of evaluations is checked against
MAX_SAMPLES (or MAX_RUNS for runs) before anything runs, and refused in one line naming
the key. The rib part's group is ``study.ribs`` (the runs are en06_ribs.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from creatio.dynamics.solvers import METHODS
from creatio.errors import ConfigError
from creatio.studies.budget import Rung, ladder
from creatio.studies.material_schema import MaterialConfig
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    GeometryConfig,
    Method,
    PhasesConfig,
    check_bases,
    require,
    require_runs,
    require_samples,
    vary,
)

__all__ = ["AllocationConfig", "BASE", "BeyondGrid", "BudgetConfig", "En06Config", "En06Study",
           "FatigueCheckConfig", "FatigueGrid", "Interval", "JointConfig", "RibsConfig",
           "SobolConfig", "SpecConfig", "StrainGrid", "TiltCheckConfig", "ToleranceInput",
           "TolerancesConfig"]

#: The study whose transport the tolerance parts vary (its full config: bases.en02).
BASE = "en02"
#: The tilt's azimuth key: the allocation checks every azimuth of a grid instead of one.
AZIMUTH_KEY = "sphere.psi_deg"
#: Most halvings of a bisection (2^-60 of a cap is below double precision).
MAX_HALVINGS = 60

#: Most halvings a maximum's refinement may take (each halves the spacing: 2^-60 is far
#: below double precision of any coordinate).
MAX_LEVELS = 60


def _check_sizes(path: str, n_alpha: int, n_R: int, n_t: int, what: str,
                 min_t: int = 2) -> None:
    """n_alpha >= 3, n_R >= 2, n_t >= min_t, and their product within MAX_SAMPLES (named by
    the largest of the three)."""
    require(n_alpha >= 3, f"{path}.n_alpha", n_alpha, "must be >= 3")
    require(n_R >= 2, f"{path}.n_R", n_R, "must be >= 2 (both edges are sampled)")
    require(n_t >= min_t, f"{path}.n_t", n_t, f"must be >= {min_t}")
    sizes = {"n_alpha": n_alpha, "n_R": n_R, "n_t": n_t}
    name = max(sizes, key=lambda k: sizes[k])
    require_samples(f"{path}.{name}", sizes[name], n_alpha * n_R * n_t,
                    f"{what} ({n_alpha} x {n_R} x {n_t})")


@dataclass
class StrainGrid:
    """The base grid of the maximum (and of the map and the envelope along R): alpha_i =
    2 pi i / n_alpha, R_j = dR j / (n_R - 1), n_t times over [0, T] with both ends; the
    refinement's tolerance, candidates and most halvings (creatio.model.strain.maximum)."""

    n_alpha: int = 192
    n_R: int = 33
    n_t: int = 241
    rtol: float = 1.0e-6
    candidates: int = 4
    max_levels: int = 40

    def check(self, path: str) -> None:
        """Sizes within MAX_SAMPLES, 0 < rtol < 1, candidates >= 1, 1 <= max_levels <= 60."""
        _check_sizes(path, self.n_alpha, self.n_R, self.n_t, "strain evaluations per base grid")
        require(0.0 < self.rtol < 1.0, f"{path}.rtol", self.rtol, "must lie in (0, 1)")
        require(1 <= self.candidates <= 64, f"{path}.candidates", self.candidates,
                "must lie in [1, 64]")
        require(1 <= self.max_levels <= MAX_LEVELS, f"{path}.max_levels", self.max_levels,
                f"must lie in [1, {MAX_LEVELS}]")


@dataclass
class BeyondGrid:
    """The grid of the area beyond the ultimate strain (creatio.model.strain.area_beyond):
    cell centres in alpha and R, n_t times over [0, T] with both ends."""

    n_alpha: int = 128
    n_R: int = 64
    n_t: int = 121

    def check(self, path: str) -> None:
        """Sizes within MAX_SAMPLES."""
        _check_sizes(path, self.n_alpha, self.n_R, self.n_t, "strain evaluations",
                     min_t=1)


@dataclass
class FatigueGrid:
    """The fatigue map's grid (creatio.model.fatigue.fatigue_map): alpha_i = 2 pi i /
    n_alpha, R_j = dR j / (n_R - 1) (both edges), n_t times of one period (t_k = T k / n_t,
    the last not repeating the first): its whole history is held at once."""

    n_alpha: int = 48
    n_R: int = 25
    n_t: int = 960

    def check(self, path: str) -> None:
        """Sizes within MAX_SAMPLES, at least 4 times (a cycle needs two turning points)."""
        _check_sizes(path, self.n_alpha, self.n_R, self.n_t, "history samples", min_t=4)


@dataclass
class FatigueCheckConfig:
    """The closed-form check of the fatigue count (docs/materials.md s.5) on one surface at
    h = 0: times where phi_a = phi_a(0) +- n pi / samples_per_half_turn, alpha_i = 2 pi i /
    n_alpha (so every extreme of v is sampled exactly), R_j = dR j / (n_R - 1)."""

    surface: str = "en02"
    samples_per_half_turn: int = 8
    n_alpha: int = 48
    n_R: int = 7

    def check(self, path: str, surfaces: dict[str, PhasesConfig], Ka: int) -> None:
        """The surface is one of the study's; samples_per_half_turn even and >= 4;
        n_alpha divides 2 Ka samples_per_half_turn (alpha on the phase grid); the history
        within MAX_SAMPLES."""
        require(self.surface in surfaces, f"{path}.surface", self.surface,
                f"must be one of the study's surfaces ({', '.join(surfaces)})")
        m = self.samples_per_half_turn
        require(m >= 4 and m % 2 == 0, f"{path}.samples_per_half_turn", m,
                "must be an even number >= 4 (the extremes v = k pi / 2 are sampled)")
        require(self.n_alpha >= 1 and (2 * Ka * m) % self.n_alpha == 0, f"{path}.n_alpha",
                self.n_alpha, f"must divide 2 Ka samples_per_half_turn = {2 * Ka * m} (Ka "
                "alpha then lies on the phase grid)")
        require(self.n_R >= 2, f"{path}.n_R", self.n_R, "must be >= 2 (both edges are sampled)")
        ph = surfaces[self.surface]
        law = ph.a.to_law(ph.T)
        travel = abs(float(law(ph.T).value) - float(law(0.0).value))
        n_t = m * max(1, round(travel / math.pi)) if math.isfinite(travel) else m
        sizes = {"n_alpha": self.n_alpha, "n_R": self.n_R, "samples_per_half_turn": m}
        name = max(sizes, key=lambda k: sizes[k])
        require_samples(f"{path}.{name}", sizes[name], self.n_alpha * self.n_R * n_t,
                        f"history samples ({self.n_alpha} x {self.n_R} x {n_t})")


def _vary_as(path: str, value: Any, base: DynamicConfig, changes: dict[str, Any]) -> None:
    """vary(base, changes), a refusal re-keyed to ``path`` = value, with the base's key and
    rule."""
    try:
        vary(base, changes)
    except ConfigError as e:
        raise ConfigError(path, value, f"gives {e.key}={e.value!r}, refused by {BASE}: "
                          f"{e.rule}") from None


def nominal_of(base: DynamicConfig, key: str) -> float:
    """The base's value of a dotted key (a null tilt reads as 0: level, azimuth 0)."""
    node: Any = base
    for part in key.split("."):
        node = getattr(node, part)
    return 0.0 if node is None else float(node)


@dataclass
class ToleranceInput:
    """One manufacturing or mounting input: the dotted key of bases.en02 it sets, its
    declared tolerance (uniform on [nominal - minus, nominal + plus]; with ``relative`` the
    deviations are fractions of the nominal) and the allocation's cap on each side
    ([minus, plus], in the same units; 0: that side is not allocated)."""

    key: str = MISSING
    minus: float = 0.0
    plus: float = 0.0
    relative: bool = False
    cap: list[float] = field(default_factory=lambda: [0.0, 0.0])

    def value(self, nominal: float, deviation: float) -> float:
        """The input's value at a signed deviation from the nominal."""
        return nominal * (1.0 + deviation) if self.relative else nominal + deviation

    def check(self, path: str, base: DynamicConfig) -> None:
        """minus, plus >= 0 with a width; each cap 0 or at least the declared tolerance of
        its side; a relative input's nominal nonzero; every end (declared and capped) a
        value EN-02 accepts; the azimuth is not allocated (every azimuth is checked)."""
        require(self.minus >= 0.0, f"{path}.minus", self.minus, "must be >= 0")
        require(self.plus >= 0.0, f"{path}.plus", self.plus, "must be >= 0")
        require(self.minus + self.plus > 0.0, f"{path}.plus", self.plus,
                f"must be > 0 when {path}.minus = 0 (an input needs a width)")
        require(len(self.cap) == 2, f"{path}.cap", list(self.cap),
                "must be [minus, plus]: the allocation's cap on each side")
        require(not (self.key == AZIMUTH_KEY and any(self.cap)), f"{path}.cap",
                list(self.cap), f"must be [0, 0] for {AZIMUTH_KEY}: the allocation checks "
                "every azimuth of study.tolerances.allocation.azimuths")
        for i, (c, tol) in enumerate(zip(self.cap, (self.minus, self.plus), strict=True)):
            require(c == 0.0 or c >= tol, f"{path}.cap[{i}]", c,
                    f"must be 0 (not allocated) or >= the declared tolerance {tol:g}")
        try:
            nominal = nominal_of(base, self.key)
        except (AttributeError, TypeError, ValueError):
            raise ConfigError(f"{path}.key", self.key, f"must name a number of {BASE}'s "
                              f"config (bases.{BASE})") from None
        if self.relative:
            require(nominal != 0.0, f"{path}.relative", self.relative,
                    f"needs a nonzero nominal ({self.key} = {nominal:g})")
        for name, value, dev in (("minus", self.minus, -self.minus),
                                 ("plus", self.plus, self.plus),
                                 ("cap[0]", self.cap[0], -self.cap[0]),
                                 ("cap[1]", self.cap[1], self.cap[1])):
            _vary_as(f"{path}.{name}", value, base, {self.key: self.value(nominal, dev)})


@dataclass
class SpecConfig:
    """What "within spec" means for one transport: carried, |final angle error| <=
    angle_deg and |final radius error| <= radius_m (both from the nominal run's)."""

    angle_deg: float = 1.0
    radius_m: float = 0.01

    def check(self, path: str) -> None:
        """Both bounds > 0."""
        require(self.angle_deg > 0.0, f"{path}.angle_deg", self.angle_deg, "must be > 0")
        require(self.radius_m > 0.0, f"{path}.radius_m", self.radius_m, "must be > 0")


@dataclass
class SobolConfig:
    """The Sobol' design of the declared tolerances (EN-05's machinery: base sizes N,
    powers of 2, the smaller designs prefixes of the largest; N (d + 2) runs)."""

    base_sizes: list[int] = field(default_factory=lambda: [256, 512])
    seed: int = 6
    resamples: int = 1000
    confidence: float = 0.95

    def check(self, path: str, d: int) -> None:
        """Sizes powers of 2 >= 4 increasing, resamples >= 100, confidence in (0, 1); the
        runs and bootstrap samples within MAX_RUNS and MAX_SAMPLES."""
        sizes = list(self.base_sizes)
        require(len(sizes) >= 1, f"{path}.base_sizes", sizes, "needs at least 1 value")
        for i, n in enumerate(sizes):
            require(n >= 4 and n & (n - 1) == 0, f"{path}.base_sizes[{i}]", n,
                    "must be a power of 2 >= 4 (Sobol' points balance in blocks of 2^k)")
        require(sizes == sorted(set(sizes)), f"{path}.base_sizes", sizes, "must increase")
        require(self.seed >= 0, f"{path}.seed", self.seed, "must be >= 0")
        require(self.resamples >= 100, f"{path}.resamples", self.resamples, "must be >= 100")
        require(0.0 < self.confidence < 1.0, f"{path}.confidence", self.confidence,
                "must lie in (0, 1)")
        n = max(sizes)
        require_runs(f"{path}.base_sizes", sizes, n * (d + 2),
                     f"runs (the largest base size x ({d} inputs + 2), Saltelli's design)")
        require_samples(f"{path}.resamples", self.resamples, self.resamples * n,
                        "bootstrap indices (resamples x the largest base size)")


@dataclass
class AllocationConfig:
    """The tolerance allocation (docs/materials.md s.8): on each allocated side of each
    input alone, ``scan`` equal steps up to the cap find the first deviation out of spec,
    then ``iterations`` bisections between it and the last one within; a tilted point is
    within spec only at every one of ``azimuths`` equally spaced azimuths."""

    scan: int = 8
    iterations: int = 20
    azimuths: int = 12

    def check(self, path: str, runs_per_point: int) -> None:
        """scan >= 1, 1 <= iterations <= 60, azimuths >= 1; the runs within MAX_RUNS."""
        require(self.scan >= 1, f"{path}.scan", self.scan, "must be >= 1")
        require(1 <= self.iterations <= MAX_HALVINGS, f"{path}.iterations", self.iterations,
                f"must lie in [1, {MAX_HALVINGS}] (bisections of the last scan step)")
        require(self.azimuths >= 1, f"{path}.azimuths", self.azimuths, "must be >= 1")
        sizes = {"scan": self.scan, "azimuths": self.azimuths}
        name = max(sizes, key=lambda k: sizes[k])
        require_runs(f"{path}.{name}", sizes[name],
                     runs_per_point * (self.scan + self.iterations) * self.azimuths,
                     f"runs ({runs_per_point} allocated sides x (scan {self.scan} + "
                     f"iterations {self.iterations}) x azimuths {self.azimuths})")


class Interval(StrEnum):
    """The binomial interval of the joint fraction (scipy.stats.binomtest)."""

    exact = "exact"    # Clopper-Pearson: covers at least the confidence level
    wilson = "wilson"  # Wilson score, without continuity correction


@dataclass
class JointConfig:
    """The joint Monte Carlo at the declared tolerances: n independent draws (numpy's
    PCG64 seeded by ``seed``) and the binomial interval of the fraction within spec."""

    n: int = 1000
    seed: int = 7
    confidence: float = 0.95
    interval: Interval = Interval.exact

    def check(self, path: str) -> None:
        """n >= 1 within MAX_RUNS, seed >= 0, confidence in (0, 1)."""
        require(self.n >= 1, f"{path}.n", self.n, "must be >= 1")
        require_runs(f"{path}.n", self.n, self.n, "runs (one per draw)")
        require(self.seed >= 0, f"{path}.seed", self.seed, "must be >= 0")
        require(0.0 < self.confidence < 1.0, f"{path}.confidence", self.confidence,
                "must lie in (0, 1)")


@dataclass
class BudgetConfig:
    """The accuracy budget of the tolerance parts (docs/accuracy.md): when enabled, each
    runs at the first setting a pilot finds within the part's budget, trying the methods in
    order (the ``candidates``, cheapest first as measured on EN-02's transport, then
    ``method``), each on its ladder from rtol ``loosest_rtol`` down to rtol/atol (factors
    of 10), loosest first: a choice that does not depend on the machine's timing;
    verified on ``points`` seeded points at 100x tighter tolerances and tightened 10x (at
    most ``max_tighten`` times) when broken. The budgets are fractions of what each part's
    answer resolves: the Sobol' outputs' standard deviation over the design
    (``sobol_fraction``), the spec's bounds for the joint fraction (``joint_fraction``) and
    the bisection's resolution for the allocation (``allocation_fraction``). Disabled, every
    run is bases.en02's own solver."""

    enabled: bool = False
    candidates: list[Method] = field(default_factory=list)
    method: Method = Method.radau5
    rtol: float = 1e-8
    atol: float = 1e-10
    loosest_rtol: float = 1e-4
    sobol_fraction: float = 1e-3
    joint_fraction: float = 1e-2
    allocation_fraction: float = 1e-2
    points: int = 16
    seed: int = 37
    max_tighten: int = 3

    def check(self, path: str) -> None:
        """An adaptive method, tolerances > 0 with rtol <= loosest_rtol, fractions in (0, 1],
        at least 16 points, 0 <= max_tighten <= 6."""
        require(METHODS[str(self.method)].adaptive, f"{path}.method", str(self.method),
                "must be an adaptive method (the ladder varies its tolerances)")
        for i, m in enumerate(self.candidates):
            require(METHODS[str(m)].adaptive, f"{path}.candidates[{i}]", str(m),
                    "must be an adaptive method (the ladder varies its tolerances)")
        for key in ("rtol", "atol", "loosest_rtol"):
            v = getattr(self, key)
            require(math.isfinite(v) and 0.0 < v < 1.0, f"{path}.{key}", v,
                    "must lie in (0, 1)")
        require(self.loosest_rtol >= self.rtol, f"{path}.loosest_rtol", self.loosest_rtol,
                f"must be >= rtol ({self.rtol})")
        for key in ("sobol_fraction", "joint_fraction", "allocation_fraction"):
            v = getattr(self, key)
            require(math.isfinite(v) and 0.0 < v <= 1.0, f"{path}.{key}", v,
                    "must lie in (0, 1] (a fraction of what the answer resolves)")
        require(self.points >= 16, f"{path}.points", self.points,
                "must be >= 16 (the verification's subsample)")
        require(self.seed >= 0, f"{path}.seed", self.seed, "must be >= 0")
        require(0 <= self.max_tighten <= 6, f"{path}.max_tighten", self.max_tighten,
                "must lie in [0, 6] (10x tightenings)")

    def rungs(self) -> list[Rung]:
        """The pilot's ladders, each loosest first: each candidate's, then method's (its
        rtol/atol last, the pilot's reference 100x tighter)."""
        out = []
        for m in [*dict.fromkeys(str(c) for c in self.candidates if c != self.method),
                  str(self.method)]:
            out += ladder(Rung(m, self.rtol, self.atol), self.loosest_rtol)
        return out


@dataclass
class TolerancesConfig:
    """EN-06 part 4 (docs/materials.md s.8): the inputs with their declared tolerances,
    the spec, and the sizes of the Sobol' indices, the allocation and the joint sample."""

    inputs: dict[str, ToleranceInput] = field(default_factory=dict)
    spec: SpecConfig = field(default_factory=SpecConfig)
    sobol: SobolConfig = field(default_factory=SobolConfig)
    allocation: AllocationConfig = field(default_factory=AllocationConfig)
    joint: JointConfig = field(default_factory=JointConfig)
    budget: BudgetConfig = field(default_factory=BudgetConfig)

    def check(self, path: str, base: DynamicConfig) -> None:
        """At least one input, distinct keys, each valid on the base; every size bounded."""
        require(len(self.inputs) >= 1, f"{path}.inputs", dict(self.inputs),
                "needs at least 1 input")
        keys = [i.key for i in self.inputs.values()]
        for name, inp in self.inputs.items():
            require(keys.count(inp.key) == 1, f"{path}.inputs.{name}.key", inp.key,
                    "is varied by two inputs")
            inp.check(f"{path}.inputs.{name}", base)
        self.spec.check(f"{path}.spec")
        self.sobol.check(f"{path}.sobol", len(self.inputs))
        sides = sum(int(c > 0.0) for i in self.inputs.values() for c in i.cap)
        self.allocation.check(f"{path}.allocation", max(sides, 1))
        self.joint.check(f"{path}.joint")
        self.budget.check(f"{path}.budget")

    @property
    def names(self) -> list[str]:
        """Input names, sorted: the design's column order however the config was written."""
        return sorted(self.inputs)


@dataclass
class TiltCheckConfig:
    """The energy identity under a mounting tilt (docs/materials.md s.8): EN-02 at
    beta_deg toward psi_deg on a cycle of cycle_s, at bases.en02's fixed step dt, dt / 2
    and dt / 4; the residual's largest value falls at the scheme's order."""

    beta_deg: float = 2.0
    psi_deg: float = 30.0
    cycle_s: float = 8.0

    def check(self, path: str, base: DynamicConfig) -> None:
        """0 < beta_deg < 90; a fixed-step base (the order is of dt); each run accepted."""
        require(0.0 < self.beta_deg < 90.0, f"{path}.beta_deg", self.beta_deg,
                "must lie in (0, 90) degrees (a tilt)")
        require(self.cycle_s > 0.0, f"{path}.cycle_s", self.cycle_s, "must be > 0")
        require(not base.solver.adaptive, f"bases.{BASE}.solver.method",
                str(base.solver.method), "study.tilt_check needs a fixed step (its order is "
                "of dt)")
        for dt in self.steps(base):
            changes = self.changes(dt)
            try:
                vary(base, changes)
            except ConfigError as e:
                key = {"study.duration": "cycle_s", "phases.T": "cycle_s",
                       "sphere.beta_deg": "beta_deg", "sphere.psi_deg": "psi_deg"}.get(
                    e.key, "cycle_s")
                raise ConfigError(f"{path}.{key}", getattr(self, key),
                                  f"at dt = {dt:g} s: {e.key}={e.value!r}: {e.rule}") from None

    @staticmethod
    def steps(base: DynamicConfig) -> list[float]:
        """The three steps: the base's dt, dt / 2, dt / 4."""
        return [base.solver.dt / 2**h for h in range(3)]

    def changes(self, dt: float) -> dict[str, Any]:
        """The changes of the base for the run at dt."""
        return {"sphere.beta_deg": self.beta_deg, "sphere.psi_deg": self.psi_deg,
                "phases.T": self.cycle_s, "study.duration": self.cycle_s, "solver.dt": dt}


@dataclass
class RibsConfig:
    """The rib part (docs/model.md, rib surfaces): EN-02 and EN-02R on the surface N ribs
    make, for each N of ``counts`` (each > 2 Ka) against the ideal surface; ``refused`` the
    counts shown refused (each <= 2 Ka); rib errors over ``seeds`` seeds at ``errors_N``
    (null: the smallest N within spec) with amplitude sigma ``sigma_e`` and phase sigma
    ``sigma_d_deg``."""

    counts: list[int] = field(default_factory=lambda: [18, 24, 36, 48, 72])
    refused: list[int] = field(default_factory=lambda: [12])
    errors_N: int | None = None
    seeds: int = 50
    sigma_e: float = 0.01
    sigma_d_deg: float = 1.0

    def check(self, path: str, Ka: int) -> None:
        """Counts above 2 Ka, refusals at or below it, positive sizes, sigmas >= 0."""
        require(len(self.counts) >= 1, f"{path}.counts", list(self.counts),
                "needs at least 1 rib count")
        for i, N in enumerate(self.counts):
            require(int(N) == N and N > 2 * Ka, f"{path}.counts[{i}]", N,
                    f"must be an integer > 2 Ka = {2 * Ka} (fewer ribs cannot carry the wave)")
        for i, N in enumerate(self.refused):
            require(int(N) == N and 1 <= N <= 2 * Ka, f"{path}.refused[{i}]", N,
                    f"must be an integer in [1, 2 Ka = {2 * Ka}] (a count the study refuses)")
        if self.errors_N is not None:
            require(int(self.errors_N) == self.errors_N and self.errors_N > 2 * Ka,
                    f"{path}.errors_N", self.errors_N,
                    f"must be null or an integer > 2 Ka = {2 * Ka}")
        require(int(self.seeds) == self.seeds and self.seeds >= 1, f"{path}.seeds", self.seeds,
                "must be an integer >= 1")
        require_runs(f"{path}.seeds", self.seeds, 2 * self.seeds, "rib-error runs")
        require_runs(f"{path}.counts", list(self.counts), 4 * len(self.counts), "rib runs")
        for name in ("sigma_e", "sigma_d_deg"):
            value = getattr(self, name)
            require(math.isfinite(value) and value >= 0.0, f"{path}.{name}", value,
                    "must be >= 0")


@dataclass
class En06Study:
    """EN-06: the strain the surfaces of EN-02 and EN-02R demand of the membrane, the stress
    and fatigue it causes in each material, the closed-form fatigue check, the energy check
    under tilt, and the tolerances of EN-02's transport."""

    id: str = MISSING
    title: str = ""
    surfaces: dict[str, PhasesConfig] = field(default_factory=dict)
    materials: dict[str, MaterialConfig] = field(default_factory=dict)
    strain: StrainGrid = field(default_factory=StrainGrid)
    beyond: BeyondGrid = field(default_factory=BeyondGrid)
    fatigue: FatigueGrid = field(default_factory=FatigueGrid)
    fatigue_check: FatigueCheckConfig = field(default_factory=FatigueCheckConfig)
    tolerances: TolerancesConfig = field(default_factory=TolerancesConfig)
    tilt_check: TiltCheckConfig = field(default_factory=TiltCheckConfig)
    ribs: RibsConfig = field(default_factory=RibsConfig)

    def check(self, path: str, Ka: int) -> None:
        """At least one surface and material, each valid; every grid within the limits."""
        require(len(self.surfaces) >= 1, f"{path}.surfaces", dict(self.surfaces),
                "needs at least 1 surface (a phases group)")
        require(len(self.materials) >= 1, f"{path}.materials", dict(self.materials),
                "needs at least 1 material (a material group)")
        for name, ph in self.surfaces.items():
            ph.check(f"{path}.surfaces.{name}")
        for name, mat in self.materials.items():
            mat.check(f"{path}.materials.{name}")
        self.strain.check(f"{path}.strain")
        self.beyond.check(f"{path}.beyond")
        self.fatigue.check(f"{path}.fatigue")
        self.fatigue_check.check(f"{path}.fatigue_check", self.surfaces, Ka)
        self.ribs.check(f"{path}.ribs", Ka)


@dataclass
class En06Config:
    """Root schema of EN-06 (docs/materials.md): one geometry, the surfaces' phases and the
    materials under ``study``, and EN-02's full config (bases.en02, on the same geometry)
    that the tolerance parts vary."""

    study: En06Study = field(default_factory=En06Study)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """Validate the geometry, then the study, then the base (its errors named under
        bases.en02) and the tolerance groups on it."""
        self.geometry.check("geometry")
        self.study.check("study", self.geometry.Ka)
        require(BASE in self.bases, "bases", sorted(self.bases), f"needs the base {BASE!r}")
        check_bases(self.bases)
        self.study.tolerances.check("study.tolerances", self.base)
        self.study.tilt_check.check("study.tilt_check", self.base)

    @property
    def base(self) -> DynamicConfig:
        """The EN-02 config the tolerance parts vary."""
        return self.bases[BASE]
