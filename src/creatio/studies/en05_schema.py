"""The config schema of EN-05 (docs/studies.md, docs/model.md s.13): input distributions,
the Sobol' design, the calibration round trip and the design of the experiment.

Plain dataclasses and their rules, like creatio.studies.schema; nothing here samples or
runs. A distribution is checked against the study it varies: each end of its support (a
normal's +-8 sd) must be a value the study's own rules accept, so a range the model refuses
(mu < 0, A >= R0, an RK4 step beyond its stability limit) is refused here, in one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum

from creatio.errors import ConfigError
from creatio.studies.schema import (
    MISSING,
    OMIT_NULL,
    DynamicConfig,
    check_bases,
    culprit,
    require,
    require_runs,
    require_samples,
    vary,
)

__all__ = [
    "ACCURACY_PREFIX",
    "BASE",
    "BudgetConfig",
    "CameraConfig",
    "CalibrationConfig",
    "DesignConfig",
    "Dist",
    "En05Config",
    "En05Study",
    "InputDistribution",
    "SensitivityConfig",
    "UncertaintyConfig",
]

#: The study whose inputs EN-05 varies and whose model it fits (its full config: bases.en02).
BASE = "en02"
#: Coordinates a camera may measure.
COORDINATES = ("x", "y", "z")
#: How far a normal distribution's tails are checked (in standard deviations).
NORMAL_TAIL_SD = 8.0
#: The Sobol' dataset's attributes that hold its sample's accuracy check (the prefix of
#: creatio.studies.budget.Verification.attrs; ``<prefix>unresolved`` as JSON beside it).
ACCURACY_PREFIX = "sample_accuracy_"
#: The most fits of the round trip (2 windows x seeds + spread_seeds): each fit integrates
#: the model tens of times (the defaults ask for 500).
MAX_FITS = 10_000


class Dist(StrEnum):
    """Distribution of one uncertain input (docs/model.md s.13.1)."""

    uniform = "uniform"          # low, high
    loguniform = "loguniform"    # low, high (> 0): uniform in log
    normal = "normal"            # mean, sd
    truncnormal = "truncnormal"  # mean, sd, truncated to [low, high]


_USED = {Dist.uniform: {"low", "high"}, Dist.loguniform: {"low", "high"},
         Dist.normal: {"mean", "sd"}, Dist.truncnormal: {"mean", "sd", "low", "high"}}


@dataclass
class InputDistribution:
    """One uncertain input: the config key it sets and its distribution's parameters."""

    key: str = MISSING
    dist: Dist = Dist.uniform
    low: float = 0.0
    high: float = 0.0
    mean: float = 0.0
    sd: float = 0.0

    def check(self, path: str) -> None:
        """Parameters the kind uses set and ordered, the others left at 0."""
        for name in ("low", "high", "mean", "sd"):
            if name not in _USED[self.dist]:
                require(getattr(self, name) == 0.0, f"{path}.{name}", getattr(self, name),
                        f"is not used by dist={self.dist.value}")
        if "low" in _USED[self.dist]:
            require(self.low < self.high, f"{path}.high", self.high,
                    f"must exceed {path}.low = {self.low}")
        if self.dist is Dist.loguniform:
            require(self.low > 0.0, f"{path}.low", self.low, "must be > 0 (log-uniform)")
        if "sd" in _USED[self.dist]:
            require(self.sd > 0.0, f"{path}.sd", self.sd, "must be > 0")

    def support(self) -> tuple[float, float]:
        """The ends of the support (a normal's: mean +- 8 sd, beyond which it never samples
        in practice: probability 1e-15)."""
        if self.dist is Dist.normal:
            return self.mean - NORMAL_TAIL_SD * self.sd, self.mean + NORMAL_TAIL_SD * self.sd
        return self.low, self.high

    def check_on(self, path: str, base: DynamicConfig) -> None:
        """Each end of the support is a value the base study's physics accepts (its own
        rule, named); the integrator's stability limit is left to the sample's solver
        (study.sensitivity.overrides), so it is lifted here."""
        for end in self.support():
            try:
                vary(base, {self.key: end, "solver.allow_unstable": True})
            except ConfigError as e:
                hint = (" (a normal's tails reach it: use dist=truncnormal with low and high)"
                        if self.dist is Dist.normal else "")
                raise ConfigError(f"{path}.{'low' if end == self.support()[0] else 'high'}",
                                  end, f"{self.key}={end:g} is refused by {BASE}: "
                                  f"{e.rule}{hint}") from None


@dataclass
class UncertaintyConfig:
    """The inputs of a study with their distributions (conf/uncertainty/<study>.yaml), by a
    short name used in the reports (mu, eps, ...)."""

    study: str = BASE
    inputs: dict[str, InputDistribution] = field(default_factory=dict)

    def check(self, path: str, base: DynamicConfig) -> None:
        """At least one input, distinct keys, each distribution valid on the base study."""
        require(self.study == BASE, f"{path}.study", self.study,
                f"EN-05 varies {BASE} (its base config, bases.{BASE})")
        require(len(self.inputs) >= 1, f"{path}.inputs", dict(self.inputs),
                "needs at least 1 input")
        keys = [d.key for d in self.inputs.values()]
        for name, d in self.inputs.items():
            require(keys.count(d.key) == 1, f"{path}.inputs.{name}.key", d.key,
                    "is varied by two inputs")
            require(d.key not in ("study.duration",), f"{path}.inputs.{name}.key", d.key,
                    "follows phases.T: vary phases.T")
            d.check(f"{path}.inputs.{name}")
            d.check_on(f"{path}.inputs.{name}", base)

    @property
    def names(self) -> list[str]:
        """Input names, sorted: the design's column order, the same however the config was
        written (a resolved config file sorts its keys)."""
        return sorted(self.inputs)

    @property
    def distributions(self) -> list[InputDistribution]:
        """The distributions in the order of :attr:`names`."""
        return [self.inputs[n] for n in self.names]


@dataclass
class BudgetConfig:
    """The accuracy budget of the Sobol' sample's runs (creatio.studies.budget): numerical error
    <= ``fraction`` x each output's standard deviation over the sample. A pilot of
    ``points`` seeded points picks the loosest rtol from ``loosest_rtol`` down to the
    sample's own (study.sensitivity.overrides) that meets it; another seeded subsample of
    as many points rerun 100x tighter checks it."""

    fraction: float = 1e-3
    loosest_rtol: float = 1e-4
    points: int = 16

    def check(self, path: str) -> None:
        """fraction in (0, 1), loosest_rtol in (0, 1), at least 16 points."""
        require(0.0 < self.fraction < 1.0, f"{path}.fraction", self.fraction,
                "must lie in (0, 1) (a fraction of each output's standard deviation)")
        require(0.0 < self.loosest_rtol < 1.0, f"{path}.loosest_rtol", self.loosest_rtol,
                "must lie in (0, 1)")
        require(self.points >= 16, f"{path}.points", self.points,
                "must be >= 16 (the pilot's and the check's subsample)")


@dataclass
class SensitivityConfig:
    """The Sobol' design (docs/model.md s.13.1): base sizes N (powers of 2; the smaller
    designs are prefixes of the largest), the scrambling seed, the bootstrap, the Hydra
    overrides of the base study for the sample's runs (radau5: an RK4 step would have to
    shrink below 0.5 ms where mu is large and eps small) and their accuracy budget (None:
    every run at the overrides' own tolerances, unchecked)."""

    base_sizes: list[int] = field(default_factory=lambda: [256, 512])
    seed: int = 5
    resamples: int = 1000
    confidence: float = 0.95
    overrides: list[str] = field(default_factory=lambda: ["solver=radau5"])
    batch_size: int = 0
    budget: BudgetConfig | None = field(default_factory=BudgetConfig,
                                        metadata={OMIT_NULL: True})
    ishigami_a: float = 7.0
    ishigami_b: float = 0.1

    def check(self, path: str) -> None:
        """Sizes powers of 2 >= 4 in increasing order, resamples >= 100, confidence in (0, 1)."""
        sizes = self.base_sizes
        require(len(sizes) >= 1, f"{path}.base_sizes", list(sizes), "needs at least 1 value")
        for i, n in enumerate(sizes):
            require(n >= 4 and n & (n - 1) == 0, f"{path}.base_sizes[{i}]", n,
                    "must be a power of 2 >= 4 (Sobol' points balance in blocks of 2^k)")
        require(list(sizes) == sorted(set(sizes)), f"{path}.base_sizes", list(sizes),
                "must increase")
        require(self.resamples >= 100, f"{path}.resamples", self.resamples, "must be >= 100")
        require(0.0 < self.confidence < 1.0, f"{path}.confidence", self.confidence,
                "must lie in (0, 1)")
        require(self.batch_size >= 0, f"{path}.batch_size", self.batch_size,
                "must be >= 0 (0: about two batches)")
        if self.budget is not None:
            self.budget.check(f"{path}.budget")


@dataclass
class CameraConfig:
    """The camera of a prototype's track: noise per coordinate, frame rate, what it sees."""

    noise_m: float = 0.001
    rate_hz: float = 30.0
    coordinates: list[str] = field(default_factory=lambda: ["x", "y"])

    def check(self, path: str) -> None:
        """noise > 0, rate > 0, coordinates a non-empty subset of x, y, z."""
        require(self.noise_m > 0.0, f"{path}.noise_m", self.noise_m, "must be > 0")
        require(self.rate_hz > 0.0, f"{path}.rate_hz", self.rate_hz, "must be > 0")
        cs = list(self.coordinates)
        require(len(cs) >= 1 and len(set(cs)) == len(cs) and set(cs) <= set(COORDINATES),
                f"{path}.coordinates", cs, "must be distinct names among x, y, z")

    @property
    def interval(self) -> float:
        """Time between frames (s)."""
        return 1.0 / self.rate_hz


@dataclass
class CalibrationConfig:
    """The synthetic round trip (docs/model.md s.13.2): the model at `truth` on a cycle of
    `cycle_s`, seen by the camera over `window_s`, fitted back from `start` (the base's own
    values when empty) once per noise seed; `spread_seeds` fits of the first key alone set
    the spread of the estimate beside the Cramer-Rao bound."""

    fit: list[str] = field(default_factory=lambda: ["sphere.mu", "sphere.eps"])
    truth: list[float] = field(default_factory=lambda: [0.05, 0.01])
    cycle_s: float = 10.0
    window_s: list[float] = field(default_factory=lambda: [1.0, 10.0])
    seeds: int = 200
    example_seed: int = 0
    spread_seeds: int = 100

    def check(self, path: str, base: DynamicConfig) -> None:
        """One truth per fitted key, each valid on the base; a window inside the cycle."""
        require(len(self.fit) >= 1, f"{path}.fit", list(self.fit), "needs at least 1 key")
        require(len(self.truth) == len(self.fit), f"{path}.truth", list(self.truth),
                f"needs one value per fitted key ({len(self.fit)})")
        require(self.cycle_s > 0.0, f"{path}.cycle_s", self.cycle_s, "must be > 0")
        w = list(self.window_s)
        require(len(w) == 2 and 0.0 <= w[0] < w[1] <= self.cycle_s, f"{path}.window_s", w,
                f"must be [t0, t1] with 0 <= t0 < t1 <= cycle_s = {self.cycle_s}")
        try:
            vary(base, {"phases.T": self.cycle_s, "study.duration": self.cycle_s,
                        **dict(zip(self.fit, self.truth, strict=True))})
        except ConfigError as e:
            if e.key in ("phases.T", "study.duration"):  # the cycle sets both
                raise ConfigError(f"{path}.cycle_s", self.cycle_s, e.rule) from None
            raise ConfigError(f"{path}.{e.key}", e.value, e.rule) from None
        require(self.seeds >= 1, f"{path}.seeds", self.seeds, "must be >= 1")
        require(0 <= self.example_seed < self.seeds, f"{path}.example_seed", self.example_seed,
                f"must lie in [0, seeds = {self.seeds})")
        require(self.spread_seeds >= 2, f"{path}.spread_seeds", self.spread_seeds,
                "must be >= 2 (a spread)")


@dataclass
class DesignConfig:
    """The design of the experiment (docs/model.md s.13.3): the Cramer-Rao sigma_mu on a
    grid of cycle lengths and friction coefficients, central differences of relative step
    `steps[0]` checked against `steps[1]`; `target` is the +- on mu a test must reach at
    the `confidence` level to pin it."""

    cycles_s: list[float] = MISSING
    mu: list[float] = field(default_factory=lambda: [0.05, 0.15, 0.3])
    steps: list[float] = field(default_factory=lambda: [0.01, 0.005])
    target: float = 0.01
    confidence: float = 0.95

    def check(self, path: str, base: DynamicConfig) -> None:
        """Cycles and mu positive and each valid on the base, two distinct steps in (0, 0.5)."""
        for name in ("cycles_s", "mu"):
            values = getattr(self, name)
            require(len(values) >= 1, f"{path}.{name}", list(values), "needs at least 1 value")
            for i, v in enumerate(values):
                require(v > 0.0, f"{path}.{name}[{i}]", v, "must be > 0")
        require(len(self.steps) == 2 and self.steps[0] != self.steps[1], f"{path}.steps",
                list(self.steps), "needs two different relative steps (the second checks "
                "the first)")
        for i, h in enumerate(self.steps):
            require(0.0 < h < 0.5, f"{path}.steps[{i}]", h, "must lie in (0, 0.5)")
        require(self.target > 0.0, f"{path}.target", self.target, "must be > 0")
        require(0.0 < self.confidence < 1.0, f"{path}.confidence", self.confidence,
                "must lie in (0, 1)")
        top = max(self.mu) * (1.0 + max(self.steps))
        for T in (min(self.cycles_s), max(self.cycles_s)):
            try:
                vary(base, {"phases.T": T, "study.duration": T, "sphere.mu": top})
            except ConfigError as e:
                raise ConfigError(f"{path}.cycles_s", T, f"with sphere.mu = {top:g}: "
                                  f"{e.key}={e.value!r}: {e.rule}") from None


@dataclass
class En05Study:
    """EN-05's settings: the Sobol' design, the camera, the round trip, the design of the
    experiment."""

    id: str = "en05"
    title: str = ""
    sensitivity: SensitivityConfig = field(default_factory=SensitivityConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    calibration: CalibrationConfig = field(default_factory=CalibrationConfig)
    design: DesignConfig = field(default_factory=DesignConfig)


@dataclass
class En05Config:
    """Root schema of EN-05: its settings, the input distributions, and the full config of
    the study it varies and fits (bases.en02)."""

    study: En05Study = field(default_factory=En05Study)
    uncertainty: UncertaintyConfig = field(default_factory=UncertaintyConfig)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """The base valid (errors named under bases.en02), then every group on it."""
        require(BASE in self.bases, "bases", sorted(self.bases), f"needs the base {BASE!r}")
        check_bases(self.bases)
        st = self.study
        st.sensitivity.check("study.sensitivity")
        st.camera.check("study.camera")
        self.uncertainty.check("uncertainty", self.base)
        st.calibration.check("study.calibration", self.base)
        st.design.check("study.design", self.base)
        require(math.isfinite(st.camera.noise_m), "study.camera.noise_m", st.camera.noise_m,
                "must be finite")
        self._check_sizes()

    def _check_sizes(self) -> None:
        """Every size that sets a run count or an allocation within its limit (MAX_RUNS,
        MAX_SAMPLES), named by the key that sets it, before anything runs."""
        st = self.study
        s, c, d = st.sensitivity, st.calibration, st.design
        n, k = max(s.base_sizes), len(self.uncertainty.inputs)
        require_runs("study.sensitivity.base_sizes", list(s.base_sizes), n * (k + 2),
                     f"runs (the largest base size x ({k} inputs + 2), Saltelli's design)")
        require_samples("study.sensitivity.resamples", s.resamples, s.resamples * n,
                        "bootstrap indices (resamples x the largest base size)")
        if s.budget is not None:
            require_runs("study.sensitivity.budget.points", s.budget.points,
                         3 * s.budget.points, "runs at least (the pilot's points at its "
                         "reference and one rung or more, the check's 100x tighter)")
        key = culprit(c, ["seeds", "spread_seeds"],
                      lambda x: 2 * x.seeds + x.spread_seeds <= MAX_FITS)
        require(2 * c.seeds + c.spread_seeds <= MAX_FITS, f"study.calibration.{key}",
                getattr(c, key), f"asks for {2 * c.seeds + c.spread_seeds:,} fits (2 windows "
                f"x seeds + spread_seeds), more than {MAX_FITS:,} (time): use fewer")
        require_samples("study.camera.rate_hz", st.camera.rate_hz,
                        st.camera.rate_hz * c.cycle_s, "frames of a track (rate_hz x cycle_s)")
        longer = max(("cycles_s", "mu"), key=lambda name: len(getattr(d, name)))
        require_runs(f"study.design.{longer}", f"[{len(getattr(d, longer)):,} values]",
                     len(d.cycles_s) * len(d.mu) * 5,
                     "runs (cycles_s x mu x 5: the point and two steps either side)")

    @property
    def base(self) -> DynamicConfig:
        """The EN-02 config EN-05 varies and fits."""
        return self.bases[BASE]
