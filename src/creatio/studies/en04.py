"""EN-04: what the actuators must deliver, and the still-cavity verification (docs/studies.md,
docs/model.md s.12).

Two datasets, each a part of the study:

* ``en04_actuation``: for each sphere study named in ``study.actuation.studies`` (EN-02 and
  EN-02R), its own run (the base config's problem, sampled every
  ``study.actuation.sample_interval`` instead of every output interval: the same steps, so
  the same trajectory) and the actuation demand of docs/model.md s.12.1: the load power,
  the membrane's kinetic energy and inertia, gravity and damping powers by a converged
  quadrature beside their closed form, the stroke, speeds and bandwidth of the normal
  motion; the run again at dt / refine for the load's energy check;
* ``en04_oscillation``: the sphere of ``study.oscillation.base`` displaced a little along
  R and along alpha in a still cavity, at each friction coefficient and two amplitudes; the
  measured frequencies beside the closed forms of docs/model.md s.12.3.

* ``en04_control``: the closed loop of docs/model.md s.12.2 on the sphere of
  ``study.control.base``, beside the open-loop quintic and trapezoidal laws, and its
  robustness (creatio.studies.en04_control).
The config (``conf/study/en04.yaml``) holds the settings under ``study`` and the full configs
of the studies it works on under ``bases``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from creatio.dynamics import SimulationResult, SphereProblem, stability_limit
from creatio.model import actuation as act
from creatio.model.cavity import (
    bottom_curvatures,
    cavity_angle,
    cavity_angle_branch,
    cavity_branch,
    cavity_radius,
)
from creatio.model.laws import Law, LawKind
from creatio.model.numerics import steps_in
from creatio.model.oscillation import StillCavity, regularised_rolling, still_cavity
from creatio.model.sphere import inertia
from creatio.model.surface import Motion, Surface, wavenumber
from creatio.studies.en04_control import (
    ControlConfig,
    DemandSettings,
    ExtremaGridConfig,
    run_control,
)
from creatio.studies.registry import Part
from creatio.studies.schema import (
    MAX_SAMPLES,
    MISSING,
    DynamicConfig,
    check_bases,
    culprit,
    require,
    require_runs,
    require_samples,
)

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "DIRECTIONS",
    "ActuationConfig",
    "Demand",
    "En04Config",
    "En04Study",
    "ExtremaGridConfig",
    "Oscillation",
    "QuadratureConfig",
    "StillCavityConfig",
    "actuation_problem",
    "closed_forms",
    "demand",
    "measure_oscillation",
    "oscillation_tolerance",
    "parts",
    "run",
    "run_actuation",
    "run_oscillation",
    "still_problem",
]

#: The principal directions of a still cavity's small oscillations.
DIRECTIONS = ("alpha", "R")


# ------------------------------------------------------------------------------ config
@dataclass
class QuadratureConfig:
    """The membrane quadrature: the first grid, its growth per refinement, the relative
    change at which it stops, the most grids tried, and the times it is checked at."""

    n_alpha: int = 9
    n_R: int = 5
    growth: float = 1.5
    rtol: float = 1e-10
    max_levels: int = 12
    check_interval: float = 0.1

    def check(self, path: str) -> None:
        """Counts >= 1, growth > 1, 0 < rtol < 1, at least two grids, check_interval > 0."""
        require(self.n_alpha >= 1, f"{path}.n_alpha", self.n_alpha, "must be >= 1")
        require(self.n_R >= 1, f"{path}.n_R", self.n_R, "must be >= 1")
        require(self.growth > 1.0, f"{path}.growth", self.growth, "must be > 1")
        require(0.0 < self.rtol < 1.0, f"{path}.rtol", self.rtol, "must be in (0, 1)")
        require(self.max_levels >= 2, f"{path}.max_levels", self.max_levels,
                "must be >= 2 (a change needs two grids)")
        require(self.check_interval > 0.0, f"{path}.check_interval", self.check_interval,
                "must be > 0 s")


@dataclass
class ActuationConfig:
    """Actuation demand (docs/model.md s.12.1) of the studies named (keys of ``bases``)."""

    studies: list[str] = field(default_factory=lambda: ["en02", "en02r"])
    sigma: float = 0.5
    c_d: float = 0.0
    damped_c_d: float = 0.5
    sample_interval: float = 0.01
    energy_fraction: float = 0.99
    quadrature: QuadratureConfig = field(default_factory=QuadratureConfig)
    extrema: ExtremaGridConfig = field(default_factory=ExtremaGridConfig)

    def check(self, path: str, bases: dict[str, DynamicConfig]) -> None:
        """Studies among the bases, sigma and c_d >= 0, damped_c_d > 0, the sample interval a
        multiple of each fixed-step base's dt dividing its duration, 0 < fraction < 1."""
        require(len(self.studies) >= 1, f"{path}.studies", list(self.studies),
                "needs at least 1 study")
        for i, name in enumerate(self.studies):
            require(name in bases, f"{path}.studies[{i}]", name,
                    f"must be a key of bases ({', '.join(sorted(bases))})")
        require(self.sigma >= 0.0, f"{path}.sigma", self.sigma, "must be >= 0 kg/m^2")
        require(self.c_d >= 0.0, f"{path}.c_d", self.c_d, "must be >= 0 N s/m^3")
        require(self.damped_c_d > 0.0, f"{path}.damped_c_d", self.damped_c_d,
                "must be > 0 N s/m^3 (the damped case)")
        require(0.0 < self.energy_fraction < 1.0, f"{path}.energy_fraction",
                self.energy_fraction, "must be in (0, 1)")
        require(self.sample_interval > 0.0, f"{path}.sample_interval", self.sample_interval,
                "must be > 0 s")
        for name in self.studies:
            base = bases[name]
            sv = base.solver
            if not (sv.adaptive or sv.dense_output):
                require(steps_in(self.sample_interval, sv.dt) is not None,
                        f"{path}.sample_interval", self.sample_interval,
                        f"must be a multiple of bases.{name}.solver.dt = {sv.dt} (the run's "
                        "own steps are sampled)")
            require(steps_in(base.study.duration, self.sample_interval) is not None,
                    f"{path}.sample_interval", self.sample_interval,
                    f"must divide bases.{name}.study.duration = {base.study.duration} s")
        self.quadrature.check(f"{path}.quadrature")
        self.extrema.check(f"{path}.extrema")


@dataclass
class StillCavityConfig:
    """Still-cavity oscillations (docs/model.md s.12.3) of the sphere of ``base``: each
    friction coefficient, the contact displaced by amplitude_m (arc length) and by
    amplitude_factor times it, along alpha and along R, for ``duration`` seconds."""

    base: str = "en02"
    mus: list[float] = field(default_factory=lambda: [0.0, 0.15])
    amplitude_m: float = 5e-4
    amplitude_factor: float = 2.0
    duration: float = 20.0

    def check(self, path: str, bases: dict[str, DynamicConfig]) -> None:
        """A flat base with A > 0 (the closed forms are the flat annulus's), mu = 0 and some
        mu > 0, small amplitudes, every run stable at the base's dt."""
        require(self.base in bases, f"{path}.base", self.base,
                f"must be a key of bases ({', '.join(sorted(bases))})")
        base = bases[self.base]
        gamma = base.phases.gamma
        require(gamma.kind is LawKind.constant and gamma.phi0 == 0.0,
                f"bases.{self.base}.phases.gamma", f"{gamma.kind.value}, phi0 = {gamma.phi0}",
                "the still-cavity closed forms hold on the flat annulus: gamma constant 0")
        require(base.geometry.A > 0.0, f"bases.{self.base}.geometry.A", base.geometry.A,
                "must be > 0 (a still cavity needs a corrugation)")
        require(len(self.mus) >= 2 and 0.0 in self.mus and max(self.mus) > 0.0,
                f"{path}.mus", list(self.mus),
                "needs mu = 0 (sliding) and at least one mu > 0 (rolling)")
        for i, mu in enumerate(self.mus):
            require(mu >= 0.0, f"{path}.mus[{i}]", mu, "must be >= 0")
        require(self.amplitude_factor > 1.0, f"{path}.amplitude_factor",
                self.amplitude_factor, "must be > 1")
        g = base.geometry
        k = wavenumber(g.Kr, g.dR)
        R_c, _ = _bottom(base)
        kmax = max(bottom_curvatures(g.A, k, g.Ka, g.R0 + R_c, 0.0))
        limit = 0.01 / kmax
        largest = self.amplitude_m * self.amplitude_factor
        require(0.0 < self.amplitude_m and largest <= limit, f"{path}.amplitude_m",
                self.amplitude_m,
                f"must be > 0 with amplitude_m x amplitude_factor <= 1 % of the bottom's "
                f"smallest radius of curvature ({limit:.4g} m): the closed forms are the "
                "small-oscillation limit")
        sv = base.solver
        require(self.duration > 0.0, f"{path}.duration", self.duration, "must be > 0 s")
        if not (sv.adaptive or sv.dense_output):
            require(steps_in(self.duration, sv.dt) is not None, f"{path}.duration",
                    self.duration, f"must be a multiple of bases.{self.base}.solver.dt = {sv.dt}")
        for i, mu in enumerate(self.mus):
            prob = still_problem(base, "R", self.amplitude_m, mu, self.duration)
            limit_dt = stability_limit(prob)
            require(sv.dt <= limit_dt or sv.allow_unstable, f"{path}.mus[{i}]", mu,
                    f"puts the {str(sv.method).upper()} stability limit of the regularised "
                    f"friction at {limit_dt:.6g} s, below bases.{self.base}.solver.dt = {sv.dt}")


@dataclass
class En04Study:
    """EN-04's settings: the actuation demand, the still-cavity check and the closed loop."""

    id: str = MISSING
    title: str = ""
    actuation: ActuationConfig = field(default_factory=ActuationConfig)
    oscillation: StillCavityConfig = field(default_factory=StillCavityConfig)
    control: ControlConfig = field(default_factory=ControlConfig)

    def check(self, path: str, bases: dict[str, DynamicConfig]) -> None:
        """Each part's rules against the bases, then every size within its limit."""
        self.actuation.check(f"{path}.actuation", bases)
        self.oscillation.check(f"{path}.oscillation", bases)
        self.control.check(f"{path}.control", bases)
        self.check_sizes(path, bases)

    def check_sizes(self, path: str, bases: dict[str, DynamicConfig]) -> None:
        """Every size that sets an allocation (MAX_SAMPLES: rows, grid points) or a run
        count (MAX_RUNS), named by the key that sets it: a control duration of 1e9 s passed
        validation and asked for 171 TiB after 69 s of runs; a grid of 29 million
        controllers was accepted."""
        a, o, c = self.actuation, self.oscillation, self.control
        for name in a.studies:
            base = bases[name]
            require_samples(f"{path}.actuation.sample_interval", a.sample_interval,
                            base.study.duration / a.sample_interval,
                            f"rows of bases.{name} (its duration / sample_interval)")
        q = a.quadrature
        longest = max(bases[name].study.duration for name in a.studies)
        require_samples(f"{path}.actuation.quadrature.check_interval", q.check_interval,
                        longest / q.check_interval,
                        f"check times ({longest:g} s / check_interval)")

        def finest(x: QuadratureConfig) -> float:
            try:
                scale = x.growth ** (x.max_levels - 1)
                return x.n_alpha * scale * x.n_R * scale
            except OverflowError:  # growth ** 1e15: beyond any limit
                return math.inf

        names = ["n_alpha", "n_R", "growth", "max_levels"]
        key = culprit(q, names, lambda x: finest(x) <= MAX_SAMPLES)
        require_samples(f"{path}.actuation.quadrature.{key}", getattr(q, key), finest(q),
                        "points of the finest quadrature grid (n_alpha x n_R x "
                        "growth^(2 (max_levels - 1)))")
        for where, grid in ((f"{path}.actuation.extrema", a.extrema),
                            (f"{path}.control.extrema", c.extrema)):
            key = culprit(grid, ["n_alpha", "n_R"],
                          lambda x: x.n_alpha * x.n_R <= MAX_SAMPLES)
            require_samples(f"{where}.{key}", getattr(grid, key), grid.n_alpha * grid.n_R,
                            "start points of the extrema search (n_alpha x n_R)")
        sv = bases[o.base].solver
        require_samples(f"{path}.oscillation.duration", o.duration, o.duration / sv.dt,
                        f"rows of each still-cavity run (duration / bases.{o.base}.solver.dt)")
        require_runs(f"{path}.oscillation.mus", f"[{len(o.mus):,} values]", 4 * len(o.mus),
                     "runs (mus x 2 amplitudes x 2 directions)")
        sv = bases[c.base].solver
        finest_dt = min(sv.timesteps())
        require_samples(f"{path}.control.duration", c.duration, c.duration / finest_dt,
                        f"rows of each controlled run (every step recorded: duration / "
                        f"{finest_dt:g} s)")
        grids = {
            "": ["omega_max", "delta_max_deg", "omega_c", "omega_n"],
            "trapezoid.": ["omega_max", "a_max"],
            "robustness.": ["mus", "mass_factors"],
        }
        runs, longest = 0, ("", "", 0)
        for prefix, keys in grids.items():
            node = c if not prefix else getattr(c, prefix.rstrip("."))
            count = 1
            for k in keys:
                count *= len(getattr(node, k))
                if len(getattr(node, k)) > longest[2]:
                    longest = (prefix, k, len(getattr(node, k)))
            runs += 2 * count
        require_runs(f"{path}.control.{longest[0]}{longest[1]}", f"[{longest[2]:,} values]",
                     runs, "runs of the closed and open loops (their grids, at dt and "
                     "dt / refine)")


@dataclass
class En04Config:
    """Root schema of EN-04: its settings and the full configs of the studies it works on."""

    study: En04Study = field(default_factory=En04Study)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """Every base valid (errors named under bases.<study>), then the study's rules."""
        check_bases(self.bases)
        self.study.check("study", self.bases)

    def step_limit(self) -> float:
        """The smallest friction stability limit over the runs of the study."""
        a, o = self.study.actuation, self.study.oscillation
        limits = [self.bases[name].step_limit() for name in a.studies]
        limits += [stability_limit(still_problem(self.bases[o.base], "R", o.amplitude_m, mu,
                                                 o.duration)) for mu in o.mus]
        return min(limits)


def parts(cfg: En04Config) -> list[Part]:
    """The actuation demand, the still-cavity verification, the closed loop."""
    return [Part("en04_actuation", {"part": "actuation"}),
            Part("en04_oscillation", {"part": "oscillation"}),
            Part("en04_control", {"part": "control"})]


def run(cfg: En04Config, part: str) -> xr.Dataset:
    """The dataset of one part."""
    if part == "actuation":
        return run_actuation(cfg)
    if part == "oscillation":
        return run_oscillation(cfg)
    if part == "control":
        c = cfg.study.control
        base = cfg.bases[c.base]
        a, q = cfg.study.actuation, cfg.study.actuation.quadrature
        settings = DemandSettings(a.sigma, a.c_d, q.n_alpha, q.n_R, q.growth, q.rtol,
                                  q.max_levels, c.extrema.n_alpha, c.extrema.n_R,
                                  a.energy_fraction)
        return run_control(c, base, closed_forms(base).roll_alpha ** 2, settings)
    raise ValueError(f"part must be actuation, oscillation or control, got {part!r}")


# --------------------------------------------------------------------- actuation demand
def _surface_motion(base: DynamicConfig) -> tuple[Surface, Motion]:
    return base.geometry.surface(), Motion(*base.phases.laws())


def actuation_problem(base: DynamicConfig, sample_interval: float, dt: float | None = None
                      ) -> SphereProblem:
    """The base study's own problem (at dt, default its solver's), its histories sampled every
    sample_interval: for a fixed step the steps, and so the trajectory, are the base's."""
    return base.sphere_problem(dt).replace(interval=sample_interval)


@dataclass
class Demand:
    """One study's actuation demand: histories on the sample grid, the scalars, and the
    quadrature's convergence (docs/model.md s.12.1)."""

    t: np.ndarray
    histories: dict[str, np.ndarray]
    scalars: dict[str, float]
    convergence: act.Convergence
    status: str


def demand(cfg: En04Config, name: str) -> Demand:
    """The actuation demand of bases[name]: its run at dt and dt / refine, the membrane
    integrals on the sample grid (the quadrature converged on the check grid first), the
    closed forms, the normal motion's extrema and the bandwidth."""
    from scipy.integrate import cumulative_simpson

    from creatio.dynamics import simulate

    a = cfg.study.actuation
    base = cfg.bases[name]
    surface, motion = _surface_motion(base)
    g = base.sphere.g
    res = simulate(actuation_problem(base, a.sample_interval))
    fine_dt = base.solver.timesteps()[1]
    fine = simulate(actuation_problem(base, a.sample_interval, fine_dt))
    h, hf = res.histories, fine.histories
    t = h.t
    P_s = act.load_power(surface, motion, t, h.R, h.alpha, h.N, h.f)
    P_fine = act.load_power(surface, motion, hf.t, hf.R, hf.alpha, hf.N, hf.f)
    T = base.study.duration
    q = a.quadrature
    check_t = t[:: max(1, steps_in(q.check_interval, a.sample_interval) or 1)] if t.size else t
    if check_t.size == 0:
        check_t = np.array([0.0])
    conv = act.converge_quadrature(surface, motion, check_t, a.sigma, a.c_d, g, q.n_alpha,
                                   q.n_R, q.rtol, q.growth, q.max_levels)
    grid = np.linspace(0.0, T, steps_in(T, a.sample_interval) + 1)
    # every figure of s.12.1 along the run, the normal motion over the whole cycle (the
    # surface's motion, not the run's)
    d = act.actuation_demand(surface, motion, t, P_s, conv.rule, a.sigma, a.c_d, g, grid=grid,
                             sample_interval=a.sample_interval, span=(0.0, T),
                             extrema=(a.extrema.n_alpha, a.extrema.n_R),
                             energy_fraction=a.energy_fraction)
    mi = d.integrals
    damped = a.damped_c_d * mi.speed_square
    P_act_damped = P_s + mi.inertia + mi.gravity + damped
    flat = _flat(base)
    if flat:
        K_cf, P_in_cf = act.annulus_kinetic_energy(surface, motion, t, a.sigma)
        t_Kcf, K_max_cf = act.time_maximum(
            lambda x: act.annulus_kinetic_energy(surface, motion, x, a.sigma)[0], 0.0, T)
        K_at = float(act.membrane_integrals(surface, motion, np.array([t_Kcf]), conv.rule,
                                            a.sigma, 0.0, g).kinetic[0])
        K_rel = float(np.max(np.abs(mi.kinetic - K_cf)) / np.max(np.abs(K_cf)))
        P_rel = float(np.max(np.abs(mi.inertia - P_in_cf)) / np.max(np.abs(P_in_cf)))
    else:
        K_cf = P_in_cf = np.full(t.size, math.nan)
        t_Kcf = K_max_cf = K_at = K_rel = P_rel = math.nan
    ex = d.extrema
    ang = act.angular_law_bounds(surface, motion)
    W_cum = cumulative_simpson(P_s, x=t, initial=0.0) if t.size > 1 else np.zeros(t.size)
    W_surf = act.time_integral(P_s, t)
    W_surf_fine = act.time_integral(P_fine, hf.t)
    W_run = float(h.surface_work[-1]) if t.size else math.nan
    W_run_fine = float(hf.surface_work[-1]) if hf.t.size else math.nan
    powers = {**d.powers(), "P_damping_damped": damped, "P_actuator_damped": P_act_damped}
    scalars: dict[str, float] = {
        "sigma": a.sigma, "c_d": a.c_d, "damped_c_d": a.damped_c_d, "duration": T,
        "K_m_max": d.K_m_max, "K_m_max_time": d.K_m_max_time, "K_m_max_closed_form": K_max_cf,
        "K_m_max_closed_form_time": t_Kcf, "K_m_at_closed_form_time": K_at,
        "K_m_closed_form_rel_error": K_rel, "P_inertia_closed_form_rel_error": P_rel,
        "W_surface": W_surf, "W_surface_run": W_run, "W_surface_fine": W_surf_fine,
        "W_surface_run_fine": W_run_fine, "dt": base.solver.dt, "fine_dt": fine_dt,
        "stroke": ex.stroke, "stroke_alpha": math.degrees(ex.stroke_point[0]),
        "stroke_R": ex.stroke_point[1],
        "stroke_angular_law": ang["stroke"],
        "max_W_t": ex.max_W_t, "max_W_t_closed_form": d.max_W_t_closed_form,
        "max_W_t_angular_law": ang["max_W_t"],
        "max_W_tt": ex.max_W_tt, "max_W_tt_closed_form": d.max_W_tt_closed_form,
        "max_W_tt_angular_law": ang["max_W_tt"],
        "worst_alpha": math.degrees(ex.worst[0]), "worst_R": ex.worst[1],
        "bandwidth": d.bandwidth, "bandwidth99": d.bandwidth99,
        "quadrature_rel_change": conv.final_rel_change,
        "quadrature_converged": float(conv.converged),
        "quadrature_n_alpha": float(conv.rule.shape[0]),
        "quadrature_n_R": float(conv.rule.shape[1]),
    }
    for key, y in powers.items():
        for figure, value in act.power_figures(y, t, T).items():
            scalars[f"{key}_{figure}"] = value
    histories = {**powers, "load_work": W_cum, "surface_work": h.surface_work,
                 "K_m": mi.kinetic, "K_m_closed_form": K_cf, "P_inertia_closed_form": P_in_cf,
                 "contact_R": h.R, "contact_alpha": np.degrees(h.alpha),
                 "normal_reaction": h.N}
    return Demand(t, histories, scalars, conv, res.counts.status)


def _flat(base: DynamicConfig) -> bool:
    gamma = base.phases.gamma
    return gamma.kind is LawKind.constant and gamma.phi0 == 0.0


#: Units and names of the actuation histories and scalars (dataset attributes).
_HISTORY_ATTRS = {
    "P_surface": ("W", "load power (N n + f) . c_t the membrane puts into the sphere"),
    "P_inertia": ("W", "membrane inertia power dK_m/dt"),
    "P_gravity": ("W", "power lifting the membrane against gravity"),
    "P_damping": ("W", "membrane damping power at study.actuation.c_d"),
    "P_actuator": ("W", "actuator power P_surface + P_inertia + P_gravity + P_damping"),
    "P_damping_damped": ("W", "membrane damping power at study.actuation.damped_c_d"),
    "P_actuator_damped": ("W", "actuator power with the damped case's c_d"),
    "load_work": ("J", "time integral of P_surface from these samples (Simpson), W_surface(t)"),
    "surface_work": ("J", "the run's own surface work (integrated with the state)"),
    "K_m": ("J", "membrane kinetic energy (quadrature)"),
    "K_m_closed_form": ("J", "membrane kinetic energy, flat-annulus closed form"),
    "P_inertia_closed_form": ("W", "membrane inertia power, flat-annulus closed form"),
    "contact_R": ("m", "contact radial coordinate R"),
    "contact_alpha": ("degree", "contact angle alpha"),
    "normal_reaction": ("N", "normal reaction N"),
}


_UNITS = {"sigma": "kg m-2", "c_d": "N s m-3", "damped_c_d": "N s m-3", "duration": "s",
          "dt": "s", "fine_dt": "s", "stroke_alpha": "degree", "worst_alpha": "degree",
          "stroke_R": "m", "worst_R": "m", "bandwidth": "Hz", "bandwidth99": "Hz"}


def _scalar_unit(key: str) -> str:
    """The unit of an actuation scalar, from its name."""
    if key in _UNITS:
        return _UNITS[key]
    if key.endswith("_time"):
        return "s"
    if key.startswith("P_"):
        return "J" if key.endswith("_energy") else "W"
    if key.startswith(("K_m_max", "K_m_at", "W_surface")):
        return "J"
    if key.startswith("max_W_tt"):
        return "m s-2"
    if key.startswith("max_W_t"):
        return "m s-1"
    if key.startswith("stroke"):
        return "m"
    return "1"


def run_actuation(cfg: En04Config) -> xr.Dataset:
    """The actuation dataset: one ``case`` per study of study.actuation.studies, its
    histories on a common time grid (NaN past a run's end) and its figures."""
    import xarray as xr

    from creatio.studies.run_datasets import output_grid

    a = cfg.study.actuation
    cases = [demand(cfg, name) for name in a.studies]
    grid = output_grid(max(cfg.bases[n].study.duration for n in a.studies), a.sample_interval)
    data: dict[str, Any] = {}
    for key, (unit, long_name) in _HISTORY_ATTRS.items():
        rows = np.full((len(cases), grid.size), math.nan)
        for i, d in enumerate(cases):
            rows[i, : d.t.size] = d.histories[key]
        data[key] = (("case", "time"), rows, {"units": unit, "long_name": long_name})
    for key in cases[0].scalars:
        if key in data:
            raise ValueError(f"actuation scalar {key!r} would replace the history of that name")
        data[key] = ("case", np.array([d.scalars[key] for d in cases]),
                     {"units": _scalar_unit(key)})
    data["status"] = ("case", np.array([d.status for d in cases], dtype=str))
    levels = max(len(d.convergence.levels) for d in cases)
    n = np.full((len(cases), levels, 2), -1, dtype=np.int32)
    rel = np.full((len(cases), levels, len(act.INTEGRALS)), math.nan)
    for i, d in enumerate(cases):
        n[i, : len(d.convergence.levels)] = np.array(d.convergence.levels)
        rel[i, : len(d.convergence.levels)] = d.convergence.rel_change
    data["level_n_alpha"] = (("case", "level"), n[..., 0],
                             {"long_name": "alpha nodes of the quadrature grid (-1: not tried)",
                              "units": "1"})
    data["level_n_R"] = (("case", "level"), n[..., 1],
                         {"long_name": "Gauss-Legendre R nodes of the quadrature grid",
                          "units": "1"})
    data["level_rel_change"] = (("case", "level", "integral"), rel, {
        "long_name": "max over the check times of the change from the grid before, over the "
                     "integral's largest absolute-integrand scale", "units": "1"})
    coords = {
        "case": ("case", np.array(list(a.studies), dtype=str), {"long_name": "sphere study"}),
        "time": ("time", grid, {"units": "s"}),
        "level": ("level", np.arange(levels, dtype=np.int32),
                  {"long_name": "quadrature refinement level", "units": "1"}),
        "integral": ("integral", np.array(act.INTEGRALS, dtype=str)),
    }
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "part": "actuation",
        "sample_interval": a.sample_interval,
        "history_interval": max(cfg.bases[n].solver.output_interval for n in a.studies),
        "quadrature_rtol": a.quadrature.rtol,
        "comment": "peaks are max |P| over the sample grid; energies and means by Simpson's "
                   "rule over it; K_m_max refined between samples by golden-section search",
    })
    return ds


# -------------------------------------------------------------------- still oscillations
def _bottom(base: DynamicConfig) -> tuple[float, float]:
    """(R_c, alpha_c) of the cavity bottom nearest the base's start, at the phases of t = 0."""
    g = base.geometry
    k = wavenumber(g.Kr, g.dR)
    laws = base.phases.laws()
    pr = laws[0](0.0).value.item()
    pa = laws[1](0.0).value.item()
    R0 = base.study.initial.R
    a0 = math.radians(base.study.initial.alpha_deg)
    return (float(cavity_radius(pr, k, cavity_branch(R0, pr, k))),
            float(cavity_angle(pa, g.Ka, cavity_angle_branch(a0, pa, g.Ka))))


def still_problem(base: DynamicConfig, direction: str, amplitude: float, mu: float,
                  duration: float) -> SphereProblem:
    """The base's sphere in the still cavity nearest its start (every phase frozen at its
    t = 0 value), at rest with the contact displaced by the arc length ``amplitude`` along
    ``direction`` (R or alpha), friction mu, every step recorded."""
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    R_c, a_c = _bottom(base)
    prob = base.sphere_problem()
    T = base.phases.T
    motion = prob.model.motion
    frozen = Motion(*(Law(phi0=float(law.scalar(0.0)[0]), T=T)
                      for law in (motion.phi_r, motion.phi_a, motion.gamma)))
    rho_c = base.geometry.R0 + R_c
    return prob.replace(
        motion=frozen, mu=float(mu),
        R=R_c + (amplitude if direction == "R" else 0.0),
        alpha=a_c + (amplitude / rho_c if direction == "alpha" else 0.0),
        Rdot=0.0, alphadot=0.0, t_end=float(duration),
        interval=prob.solver.dt, dense_output=False)


@dataclass(frozen=True)
class Oscillation:
    """A measured oscillation: angular frequency from the zero crossings, their count, and
    the decay rate fitted to the extremes' logarithm (0 when they do not decay)."""

    omega: float
    crossings: int
    decay: float


def measure_oscillation(t: np.ndarray, x: np.ndarray) -> Oscillation:
    """Frequency of a displacement history x(t) about 0: successive zero crossings of a
    damped linear oscillation are pi / omega apart, so omega = pi (n - 1) / (t_n - t_1) over
    the n crossings located on a cubic spline of the samples (the first sample excluded);
    the decay rate is minus the slope of log |x| at the extremes (least squares)."""
    from scipy.interpolate import CubicSpline

    ok = np.isfinite(x)
    t, x = t[ok], x[ok]
    if t.size < 4:
        return Oscillation(math.nan, 0, math.nan)
    spline = CubicSpline(t, x)
    roots = spline.roots(extrapolate=False)
    roots = roots[roots > t[0] + 1e-12]
    omega = math.pi * (roots.size - 1) / (roots[-1] - roots[0]) if roots.size >= 3 else math.nan
    ext = spline.derivative().roots(extrapolate=False)
    ext = ext[ext > t[0] + 1e-12]
    decay = math.nan
    if ext.size >= 3:
        slope = np.polyfit(ext, np.log(np.abs(spline(ext))), 1)[0]
        decay = float(-slope)
    return Oscillation(float(omega), int(roots.size), decay)


def oscillation_tolerance(kappa: float, amplitude: float) -> float:
    """Relative tolerance of a frequency measured at contact amplitude a against its
    small-oscillation closed form: 2 (kappa a)^2. The shift is second order in the amplitude
    (the potential's and the metric's next terms are a^2 kappa^2 relative to the leading
    ones; measured coefficients 0.8 along alpha and 0.5 along R on EN-02's cavity, docs/model.md
    s.12.3), and the scheme's own phase error, (omega dt)^4 / 120 ~ 3e-9 for RK4 at 2 ms, is
    far below it."""
    return 2.0 * (kappa * amplitude) ** 2


def closed_forms(base: DynamicConfig) -> StillCavity:
    """The still-cavity closed forms of the base's sphere and cavity (docs/model.md s.12.3)."""
    g = base.geometry
    R_c, _ = _bottom(base)
    b, m = base.sphere.b, base.sphere.m
    return still_cavity(g.A, wavenumber(g.Kr, g.dR), g.Ka, g.R0 + R_c, b, base.sphere.g,
                        inertia(m, b) / (m * b * b))


def run_oscillation(cfg: En04Config) -> xr.Dataset:
    """The still-cavity verification dataset: each run (direction x mu x amplitude) with its
    displacement history, measured frequency and decay, beside the closed forms and the
    regularised-friction prediction; the zero-amplitude extrapolation per (direction, mu)."""
    import xarray as xr

    from creatio.dynamics import simulate

    o = cfg.study.oscillation
    base = cfg.bases[o.base]
    cf = closed_forms(base)
    R_c, a_c = _bottom(base)
    rho_c = base.geometry.R0 + R_c
    sp = base.sphere
    j = inertia(sp.m, sp.b) / (sp.m * sp.b**2)
    amplitudes = (o.amplitude_m, o.amplitude_m * o.amplitude_factor)
    runs: list[tuple[str, float, float, SimulationResult]] = []
    for direction in DIRECTIONS:
        for mu in o.mus:
            for amp in amplitudes:
                res = simulate(still_problem(base, direction, amp, mu, o.duration))
                runs.append((direction, float(mu), amp, res))
    grid = runs[0][3].histories.t
    disp = np.full((len(runs), grid.size), math.nan)
    rows: dict[str, list[Any]] = {k: [] for k in (
        "direction", "mu", "amplitude", "status", "omega", "crossings", "decay",
        "omega_closed_form", "omega_regularised", "decay_regularised")}
    for i, (direction, mu, amp, res) in enumerate(runs):
        x = (res.histories.R - R_c) if direction == "R" else rho_c * (res.histories.alpha - a_c)
        disp[i, : x.size] = x
        meas = measure_oscillation(res.histories.t, x)
        slide = cf.slide(direction)
        closed = slide if mu == 0.0 else cf.roll(direction)
        reg = regularised_rolling(slide, mu * sp.g / sp.eps, j)
        for key, value in (("direction", direction), ("mu", mu), ("amplitude", amp),
                           ("status", res.counts.status), ("omega", meas.omega),
                           ("crossings", meas.crossings), ("decay", meas.decay),
                           ("omega_closed_form", closed), ("omega_regularised", reg[0]),
                           ("decay_regularised", reg[1])):
            rows[key].append(value)
    r = len(amplitudes)
    omega = np.array(rows["omega"]).reshape(-1, r)
    # frequency = omega_0 + c a^2: two amplitudes a and f a give omega_0 without the c a^2
    f2 = o.amplitude_factor**2
    extrapolated = (f2 * omega[:, 0] - omega[:, 1]) / (f2 - 1.0)
    units = {"amplitude": "m", "omega": "rad s-1", "omega_closed_form": "rad s-1",
             "omega_regularised": "rad s-1", "decay": "s-1", "decay_regularised": "s-1",
             "mu": "1", "crossings": "1"}
    long = {
        "amplitude": "initial arc-length displacement of the contact point",
        "omega": "angular frequency measured from the zero crossings",
        "crossings": "zero crossings used",
        "decay": "decay rate fitted to the extremes",
        "omega_closed_form": "closed form: sliding at mu = 0, rolling without slip otherwise",
        "omega_regularised": "linearised regularised-friction prediction",
        "decay_regularised": "linearised regularised-friction decay rate",
    }
    data: dict[str, Any] = {
        "displacement": (("run", "time"), disp, {
            "units": "m", "long_name": "contact displacement from the bottom (R - R_c, or "
                                      "rho_c (alpha - alpha_c))"}),
    }
    for key, values in rows.items():
        arr = np.array(values, dtype=str) if key in ("direction", "status") else np.array(values)
        attrs = {k: v for k, v in (("units", units.get(key)), ("long_name", long.get(key))) if v}
        data[key] = ("run", arr, attrs)
    data["omega_zero_amplitude"] = (("mode",), extrapolated, {
        "units": "rad s-1", "long_name": "measured frequency extrapolated to zero amplitude "
                                        "from the two amplitudes (second-order shift removed)"})
    modes = [(d, mu) for d in DIRECTIONS for mu in o.mus]
    data["mode_direction"] = ("mode", np.array([d for d, _ in modes], dtype=str))
    data["mode_mu"] = ("mode", np.array([mu for _, mu in modes]), {"units": "1"})
    coords = {"run": ("run", np.arange(len(runs), dtype=np.int32), {"units": "1"}),
              "mode": ("mode", np.arange(len(modes), dtype=np.int32), {"units": "1"}),
              "time": ("time", grid, {"units": "s"})}
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "part": "oscillation", "base": o.base, "dt": base.solver.dt,
        "method": str(base.solver.method), "R_c": R_c, "alpha_c": a_c, "rho_c": rho_c,
        "kappa_R": cf.kappa_R, "kappa_alpha": cf.kappa_alpha,
        "slide_R": cf.slide_R, "slide_alpha": cf.slide_alpha,
        "roll_R": cf.roll_R, "roll_alpha": cf.roll_alpha,
        "inertia_ratio": j, "friction_rate_per_mu": sp.g / sp.eps,
        "comment": "frequencies in rad/s; every run starts at rest in the still cavity, the "
                   "contact displaced by the amplitude along its direction",
    })
    return ds

