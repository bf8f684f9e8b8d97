"""EN-07 (docs/aerospace.md): a demonstrator in microgravity. Three datasets from the sphere
study of ``bases.<study.base>`` (EN-02's):

* ``en07_similarity``: the similarity check. The base and each case (s, a) scaled by
  :func:`scale_config` (the pull as the ``base`` confinement P = m a, g = 0), all adaptive at
  the similarity tolerances; the largest difference of the centre in scaled units
  (X' / s - X), beside the base's own tolerance on the centre (rtol max |X|) and the base's
  difference from its convergence partner;
* ``en07_requirements``: per platform and law (the quintic cycle, EN-04's closed loop), the
  largest scale at the preload ceiling and, at the largest scale allowed, the smallest pull,
  each by bisection of direct runs (every run tried is kept: the feasible region's points);
  at the design point, the transport's time, the residual's drift, EN-04's actuation
  figures, EN-06's strain maximum, the mount force, pass or fail and what binds;
* ``en07_interfaces``: the base at interfaces.scale under the base pull on EN-03's free
  structure for each host inertia, every step recorded: mount force, torque, yaw, its rate,
  the stored momentum and H_z's drift, the point-mass closed form beside each.

Runs are read through their datasets (creatio.studies.run_datasets, creatio.studies.sphere);
the one SimulationResult handed on is given to EN-04's :func:`demand_figures` unread.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import xarray as xr

from creatio.dynamics import simulate
from creatio.model import actuation as act
from creatio.model import strain as S
from creatio.model.similarity import factors, point_mass_yaw, pull_vector
from creatio.model.surface import Motion
from creatio.studies.en04_control import DemandSettings, demand_figures
from creatio.studies.en07_schema import En07Config
from creatio.studies.platform_schema import PlatformConfig
from creatio.studies.registry import Part
from creatio.studies.run_datasets import run_dataset, structure_dataset
from creatio.studies.schema import ControlGroup, DynamicConfig, vary
from creatio.studies.sphere import result_dataset

__all__ = ["CONSTRAINTS", "Design", "Trial", "interface_row", "parts", "run", "scale_config",
           "search", "strain_maximum", "transport", "transport_config"]

#: The constraints of the requirements table, in its column order.
CONSTRAINTS = ("window", "preload_max", "scale_min", "residual_drift", "strain")


def parts(cfg: En07Config) -> list[Part]:
    """The similarity check, the requirements search, the interfaces."""
    return [Part("en07_similarity", {"part": "similarity"}),
            Part("en07_requirements", {"part": "requirements"}),
            Part("en07_interfaces", {"part": "interfaces"})]


def run(cfg: En07Config, part: str) -> xr.Dataset:
    """The dataset of one part, its ``part`` and its cost (CPU and wall seconds of this
    process, compilation included) as attributes."""
    functions = {"similarity": run_similarity, "requirements": run_requirements,
                 "interfaces": run_interfaces}
    if part not in functions:
        raise ValueError(f"part must be similarity, requirements or interfaces, got {part!r}")
    cpu, wall = time.process_time(), time.perf_counter()
    ds = functions[part](cfg)
    ds.attrs.update({"part": part, "cpu_s": time.process_time() - cpu,
                     "wall_s": time.perf_counter() - wall})
    return ds


# ------------------------------------------------------------------------------ similarity
def scale_config(cfg: DynamicConfig, s: float, a_ratio: float) -> DynamicConfig:
    """cfg scaled by s under a pull a_ratio times its gravity (validated again): R0, dR, A,
    b and the start's R times s; the cycle, duration, step and output interval times
    sqrt(s / a_ratio); eps and Rdot as velocities; every rate (a law's rate and omega, the
    start's alphadot, the closed loop's omega_max, omega_c, omega_n) divided by the time
    factor, u_max by its square; gravity times a_ratio; mu, m, every angle unchanged."""
    f = factors(s, a_ratio)
    geo, sp, st, sv = cfg.geometry, cfg.sphere, cfg.study, cfg.solver
    changes: dict[str, Any] = {
        "geometry.R0": geo.R0 * s, "geometry.dR": geo.dR * s, "geometry.A": geo.A * s,
        "sphere.b": sp.b * s, "sphere.g": sp.g * a_ratio, "sphere.eps": sp.eps * f.velocity,
        "phases.T": cfg.phases.T * f.time, "study.duration": st.duration * f.time,
        "study.initial.R": st.initial.R * s,
        "study.initial.Rdot": st.initial.Rdot * f.velocity,
        "study.initial.alphadot": st.initial.alphadot * f.rate,
        "solver.dt": sv.dt * f.time, "solver.output_interval": sv.output_interval * f.time,
    }
    if sv.h0 is not None:
        changes["solver.h0"] = sv.h0 * f.time
    for name in ("r", "a", "gamma"):
        law = getattr(cfg.phases, name)
        changes[f"phases.{name}.rate"] = law.rate * f.rate
        changes[f"phases.{name}.omega"] = law.omega * f.rate
    if cfg.control is not None:
        changes["control"] = scale_control(cfg.control, f.rate)
    return vary(cfg, changes)


def scale_control(c: ControlGroup, rate: float) -> ControlGroup:
    """The closed loop at a time scale whose rates are ``rate`` times the reference's."""
    return replace(c, omega_max=c.omega_max * rate, omega_c=c.omega_c * rate,
                   omega_n=c.omega_n * rate,
                   u_max=None if c.u_max is None else c.u_max * rate * rate)


def _base_pull_dataset(cfg: DynamicConfig) -> xr.Dataset:
    """The run of cfg with its gravity replaced by the ``base`` confinement's pull P = m g
    (g = 0): the pull of docs/aerospace.md s.1."""
    prob = cfg.sphere_problem()
    m, g = cfg.sphere.m, cfg.sphere.g
    prob = prob.replace(g=0.0, confinement="base", force=m * g)
    return run_dataset(prob, simulate(prob))


def run_similarity(cfg: En07Config) -> xr.Dataset:
    """The ``en07_similarity`` dataset (the module docstring)."""
    st = cfg.study
    sim = st.similarity
    base = vary(cfg.bases[st.base], {"solver.method": sim.method, "solver.rtol": sim.rtol,
                                     "solver.atol": sim.atol})
    ref = _base_pull_dataset(base)
    partner = base.sphere_problem(base.solver.timesteps()[1])
    partner_ds = run_dataset(partner, simulate(partner))
    X0 = ref["centre"].values
    partner_diff = float(np.max(np.abs(partner_ds["centre"].values - X0)))
    bound = sim.rtol * float(np.max(np.abs(X0)))
    errors, v_errors, tfs, series, statuses = [], [], [], [], []
    for s, a in zip(sim.scales, sim.pulls_g, strict=True):
        scaled = scale_config(base, s, a)
        ds = _base_pull_dataset(scaled)
        f = factors(s, a)
        n = min(ds.sizes["time"], ref.sizes["time"])
        dX = np.max(np.abs(ds["centre"].values[:n] / s - X0[:n]), axis=1)
        dV = np.abs(ds["velocity"].values[:n] / f.velocity - ref["velocity"].values[:n])
        same_rows = ds.sizes["time"] == ref.sizes["time"]
        err = float(np.max(dX)) if same_rows else math.inf
        errors.append(err)
        v_errors.append(float(np.max(dV)) if same_rows else math.inf)
        tfs.append(f.time)
        statuses.append(str(ds.attrs["status"]))
        series.append(np.pad(dX, (0, ref.sizes["time"] - n), constant_values=math.nan))
    holds = np.array([e <= bound for e in errors], np.int8)
    t = ref["time"].values
    out = xr.Dataset(
        {
            "scale": ("case", np.asarray(sim.scales, float), {"long_name": "length scale s"}),
            "pull_g": ("case", np.asarray(sim.pulls_g, float),
                       {"long_name": "pull a / g (base confinement P / (m g))"}),
            "time_factor": ("case", np.asarray(tfs), {"long_name": "sqrt(s g / a)"}),
            "max_position_error_scaled": ("case", np.asarray(errors), {
                "units": "m", "long_name": "largest |X'(t') / s - X(t)| over the rows"}),
            "max_velocity_error_scaled": ("case", np.asarray(v_errors), {
                "units": "m s-1", "long_name": "largest |V' / sqrt(s a / g) - V|"}),
            "holds": ("case", holds, {"long_name": "1 if the error is within the tolerance "
                                                   "bound rtol max |X|"}),
            "status": ("case", np.array(statuses, dtype=str)),
            "position_error": (("case", "time"), np.array(series), {
                "units": "m", "long_name": "|X'(t') / s - X(t)| (largest component)"}),
        },
        coords={"case": ("case", np.arange(len(errors))),
                "time": ("time", t, {"units": "s", "long_name": "time of the base run"})})
    out.attrs.update({
        "method": sim.method, "rtol": sim.rtol, "atol": sim.atol,
        "tolerance_bound": bound, "base_partner_difference": partner_diff,
        "base_partner_rtol": partner.solver.rtol, "holds": int(holds.all()),
        "base_status": str(ref.attrs["status"]), "base_carried": int(ref.attrs["carried"]),
        "comment": "the pull is the base confinement P = m a with g = 0 in every run",
    })
    return out


# ---------------------------------------------------------------------------- requirements
def _g(cfg: En07Config) -> float:
    """The unit of every pull and residual: the base's gravity (m/s^2)."""
    return float(cfg.bases[cfg.study.base].sphere.g)


def budget(cfg: En07Config, platform: PlatformConfig) -> float:
    """The time one transport may take on a platform: window / margin, or the untimed budget."""
    rq = cfg.study.requirements
    if platform.window_s is None:
        return float(rq.untimed_transport_s)
    return float(platform.window_s) / rq.margin


#: The fraction of the friction's stability limit a transport's fixed step may take where the
#: base's step, scaled, would exceed it (a budget's cycle is not the scaled one).
STABLE_FRACTION = 0.9


def transport_config(cfg: En07Config, law: str, s: float, pull_g: float, T: float,
                     residual: tuple[float, tuple[float, float, float]] | None = None
                     ) -> DynamicConfig:
    """The base scaled by s under the pull pull_g (g), one transport in T seconds: the quintic
    cycle of length T, or the closed loop (study.control scaled) run for T; a fixed step
    dividing T (the base's step scaled), every step recorded; gravity the pull plus the
    residual (magnitude in g, direction) as one vector (a tilt; none: level)."""
    st = cfg.study
    base = cfg.bases[st.base]
    g = _g(cfg)
    scaled = scale_config(base, s, pull_g)
    n = max(1, math.ceil(T / scaled.solver.dt * (1.0 - 1e-12)))
    dt = T / n
    changes: dict[str, Any] = {"phases.T": T, "study.duration": T, "solver.dt": dt,
                               "solver.output_interval": dt}
    if law == "closed_loop":
        changes["control"] = scale_control(st.control, factors(s, pull_g).rate)
    gm, beta, psi = pull_vector(pull_g * g, 0.0, (1.0, 0.0, 0.0))
    if residual is not None and residual[0] > 0.0:
        gm, beta, psi = pull_vector(pull_g * g, residual[0] * g, residual[1])
    changes["sphere.g"] = gm
    if beta > 0.0:
        changes["sphere.beta_deg"] = math.degrees(beta)
        changes["sphere.psi_deg"] = math.degrees(psi)
    out = vary(scaled, {**changes, "solver.allow_unstable": True})
    limit = out.step_limit()
    if dt > STABLE_FRACTION * limit:  # the pull a residual tilts, a cycle not scaled with it
        n = math.ceil(T / (STABLE_FRACTION * limit))
        changes.update({"solver.dt": T / n, "solver.output_interval": T / n})
    return vary(scaled, {**changes, "solver.allow_unstable": scaled.solver.allow_unstable})


def transport(cfg: DynamicConfig) -> tuple[xr.Dataset, Any]:
    """One run's dataset (with the closed loop's readouts) and its result, for
    :func:`demand_figures`."""
    prob = cfg.sphere_problem()
    res = simulate(prob)
    return result_dataset(prob, res, cfg.control), res


def carries(ds: xr.Dataset) -> bool:
    """Whether a transport run carried the sphere: it ran to the end, never left its cavity's
    cell, and (closed loop) arrived."""
    ok = str(ds.attrs["status"]) == "ok" and int(ds.attrs["carried"]) == 1
    if "arrival_time" in ds.attrs:
        ok = ok and math.isfinite(float(ds.attrs["arrival_time"]))
    return ok


def transport_time(ds: xr.Dataset) -> float:
    """The transport's time: the closed loop's arrival, or the quintic cycle's end."""
    if "arrival_time" in ds.attrs:
        return float(ds.attrs["arrival_time"])
    return float(ds["time"].values[-1])


@dataclass
class Trial:
    """One direct run of the search: scale, pull (g), whether it carried the sphere, the
    residual's drift (m; NaN when not carried or no residual) and whether both hold."""

    scale: float
    pull_g: float
    carried: bool
    drift: float
    feasible: bool


@dataclass
class Design:
    """The outcome of one platform and law's search: the design point (the last feasible run
    of the bisection), the bracket that confirms it (inside carried, outside not) and every
    run tried. ``binding`` names the constraint that limits the design (at the largest scale
    allowed, scale_max; else what fails just beyond the largest scale at the preload ceiling),
    ``preload_set_by`` what fails just below the smallest pull (or the search's floor)."""

    feasible: bool
    binding: str
    preload_set_by: str
    scale: float
    pull_g: float
    inside: tuple[float, float] | None
    outside: tuple[float, float] | None
    trials: list[Trial] = field(default_factory=list)


def _bisect(ok: Callable[[float], bool], lo: float, hi: float, rel_tol: float
            ) -> tuple[float, float]:
    """(inside, outside) of a bracket on log x, ok(inside) and not ok(outside) holding at the
    start, shrunk until outside / inside <= 1 + rel_tol (or inside / outside)."""
    inside, outside = lo, hi
    while max(inside, outside) / min(inside, outside) > 1.0 + rel_tol:
        mid = math.sqrt(inside * outside)
        if ok(mid):
            inside = mid
        else:
            outside = mid
    return inside, outside


def search(cfg: En07Config, platform: PlatformConfig, law: str) -> Design:
    """The largest scale that carries one transport at the preload ceiling within the budget;
    at scale_max, the smallest pull that does (docs/aerospace.md s.3)."""
    rq = cfg.study.requirements
    T = budget(cfg, platform)
    residual = (platform.residual_g, platform.unit_direction())
    trials: list[Trial] = []
    a_max, s_max, s_min = platform.preload_max_g, rq.scale_max, rq.scale_min

    def ok(s: float, a: float) -> bool:
        with_res = transport_config(cfg, law, s, a, T, residual)
        ds, _ = transport(with_res)
        good = carries(ds)
        drift = math.nan
        if good and residual[0] > 0.0:
            drift = _drift(ds, transport(transport_config(cfg, law, s, a, T))[0])
            good = drift <= rq.drift_max * with_res.sphere.b
        trials.append(Trial(s, a, carries(ds), drift, good))
        return good

    limit = "window" if platform.window_s is not None else "untimed_transport"

    def reason() -> str:
        """What the last run tried failed on."""
        t = trials[-1]
        return "residual_drift" if t.carried and not t.feasible else limit

    if ok(s_max, a_max):
        a_min = rq.preload_min_g
        if ok(s_max, a_min):
            return Design(True, "scale_max", "preload_min", s_max, a_min, (s_max, a_min), None,
                          trials)
        outside_reason = [limit]

        def ok_pull(a: float) -> bool:
            good = ok(s_max, a)
            if not good:
                outside_reason[0] = reason()
            return good

        outside_reason[0] = reason()
        inside, outside = _bisect(ok_pull, a_max, a_min, rq.rel_tol)
        return Design(True, "scale_max", outside_reason[0], s_max, inside, (s_max, inside),
                      (s_max, outside), trials)
    first = reason()
    if not ok(s_min, a_max):
        return Design(False, f"{reason()}+preload_max", "preload_max", s_min, a_max, None,
                      (s_min, a_max), trials)
    outside_reason = [first]

    def ok_scale(s: float) -> bool:
        good = ok(s, a_max)
        if not good:
            outside_reason[0] = reason()
        return good

    inside, outside = _bisect(ok_scale, s_min, s_max, rq.rel_tol)
    return Design(True, f"{outside_reason[0]}+preload_max", "preload_max", inside, a_max,
                  (inside, a_max), (outside, a_max), trials)


def strain_maximum(cfg: En07Config, s: float = 1.0) -> S.Maximum:
    """EN-06's maximum of the membrane strain (h = 0) over the base's cycle at scale s (the
    surfaces of every transport, open or closed loop, are this family: scale-free)."""
    st = cfg.study
    scaled = scale_config(cfg.bases[st.base], s, 1.0)
    surface, motion = scaled.geometry.surface(), Motion(*scaled.phases.laws())
    g = st.strain
    times = np.linspace(0.0, scaled.phases.T, g.n_t)
    return S.maximum(S.largest_face_strain(surface, motion, 0.0), surface.dR, times,
                     n_alpha=g.n_alpha, n_R=g.n_R, rtol=g.rtol, candidates=g.candidates,
                     max_levels=g.max_levels)


def mount_force(ds: xr.Dataset, m: float, residual: np.ndarray) -> np.ndarray:
    """|m (A - a_residual)| at each row: what the device's mount passes to the host, A the
    sphere's acceleration (central differences of the recorded velocity, world frame)."""
    t = ds["time"].values
    V = ds["world_velocity"].values if "world_velocity" in ds else ds["velocity"].values
    if t.size < 3:
        return np.full(t.size, math.nan)
    A = np.gradient(V, t, axis=0, edge_order=2)
    return np.linalg.norm(m * (A - residual[None, :]), axis=1)


def _drift(a: xr.Dataset, b: xr.Dataset) -> float:
    """Largest distance of run a's centre from run b's path (its recorded points, every step):
    how far the residual moves the sphere off its carried path, whatever the timing (a
    closed loop that arrives a few milliseconds later has not drifted)."""
    from scipy.spatial import cKDTree

    pa, pb = a["centre"].values, b["centre"].values
    if pa.size == 0 or pb.size == 0:
        return math.nan
    distance, _ = cKDTree(pb).query(pa)
    return float(np.max(distance))


def design_figures(cfg: En07Config, platform: PlatformConfig, law: str, d: Design
                   ) -> dict[str, Any]:
    """The design point's figures (docs/aerospace.md s.3): the transport's time, the residual's
    drift, EN-04's actuation figures, the peak mount force, each constraint's verdict."""
    st = cfg.study
    g = _g(cfg)
    T = budget(cfg, platform)
    u = np.asarray(platform.unit_direction())
    m = cfg.bases[st.base].sphere.m
    out: dict[str, Any] = {"transport_s": math.nan, "residual_drift_m": math.nan,
                           "mount_force_peak_N": math.nan, "sphere_radius_m": math.nan,
                           **{f"{k}": math.nan for k, *_ in _DEMAND}}
    if not d.feasible:
        return out
    with_res = transport_config(cfg, law, d.scale, d.pull_g, T,
                                (platform.residual_g, platform.unit_direction()))
    ds, res = transport(with_res)
    ds0, _ = transport(transport_config(cfg, law, d.scale, d.pull_g, T))
    surface = with_res.geometry.surface()
    prob = with_res.sphere_problem()
    a = act.converge_quadrature(surface, Motion(*with_res.phases.laws()),
                                np.linspace(0.0, T, 41), st.actuation.sigma,
                                st.actuation.c_d, -platform.residual_g * g * u[2],
                                st.actuation.n_alpha, st.actuation.n_R, st.actuation.rtol,
                                st.actuation.growth, st.actuation.max_levels)
    levels = a.levels[-2] if a.converged and len(a.levels) > 1 else a.levels[-1]
    s = st.actuation
    settings = DemandSettings(s.sigma, s.c_d, s.n_alpha, s.n_R, s.growth, s.rtol,
                              s.max_levels, s.extrema_n_alpha, s.extrema_n_R,
                              s.energy_fraction)
    demand = demand_figures(res, surface, prob.model.motion, prob.model.control,
                            act.quadrature(surface, *levels), settings,
                            -platform.residual_g * g * u[2], float(with_res.solver.dt))
    out.update({
        "transport_s": transport_time(ds),
        "residual_drift_m": _drift(ds, ds0),
        "mount_force_peak_N": float(np.nanmax(mount_force(ds, m,
                                                          platform.residual_g * g * u))),
        "sphere_radius_m": float(with_res.sphere.b),
        "quadrature_n_alpha": levels[0], "quadrature_n_R": levels[1],
        **{key: demand.figures[src] for key, src, _ in _DEMAND},
    })
    return out


#: EN-04's actuation figures reported per design: (variable, DEMAND_FIGURES key, unit).
_DEMAND = (("P_actuator_peak", "P_actuator_peak", "W"), ("E_actuator", "E_actuator", "J"),
           ("stroke", "stroke", "m"), ("bandwidth", "bandwidth", "Hz"))


def verdicts(cfg: En07Config, platform: PlatformConfig, d: Design, fig: dict[str, Any],
             strain: float) -> tuple[dict[str, int], bool, str]:
    """Each constraint's verdict (1 pass, 0 fail), the overall pass and what binds: the
    search's limit when every constraint passes, else the first that fails (no design: the
    verdicts of the last run tried, the smallest scale at the preload ceiling)."""
    rq = cfg.study.requirements
    T = budget(cfg, platform)
    drift_limit = rq.drift_max * fig["sphere_radius_m"]
    v = {
        "window": int(d.feasible and fig["transport_s"] <= T * (1.0 + 1e-12)),
        "preload_max": int(d.feasible and d.pull_g <= platform.preload_max_g),
        "scale_min": int(d.feasible and d.scale >= rq.scale_min),
        "residual_drift": int(d.feasible and fig["residual_drift_m"] <= drift_limit),
        "strain": int(strain <= cfg.study.material.eps_u),
    }
    if not d.feasible:  # the last run tried (the smallest scale at the ceiling) says why
        t = d.trials[-1]
        v.update({"window": int(t.carried), "preload_max": 1, "scale_min": 1,
                  "residual_drift": int(not t.carried or t.feasible)})
        return v, False, d.binding
    failed = [k for k in CONSTRAINTS if not v[k]]
    if failed:
        return v, False, failed[0]
    return v, True, d.binding


def run_requirements(cfg: En07Config) -> xr.Dataset:
    """The ``en07_requirements`` dataset (the module docstring)."""
    st = cfg.study
    names = list(st.platforms)
    laws = list(st.requirements.laws)
    mx = strain_maximum(cfg)
    m = cfg.bases[st.base].sphere.m
    g = _g(cfg)
    shape = (len(names), len(laws))
    scal = {k: np.full(shape, math.nan) for k in (
        "scale", "pull_g", "preload_N", "transport_s", "residual_drift_m", "mount_force_peak_N",
        "sphere_radius_m", "inside_scale", "inside_pull_g", "outside_scale", "outside_pull_g",
        *(k for k, *_ in _DEMAND))}
    passed = np.zeros(shape, np.int8)
    binding = np.full(shape, "", dtype=object)
    set_by = np.full(shape, "", dtype=object)
    constraint = np.zeros((*shape, len(CONSTRAINTS)), np.int8)
    trials: list[list[Trial]] = []
    for i, name in enumerate(names):
        p = st.platforms[name]
        for j, law in enumerate(laws):
            d = search(cfg, p, law)
            fig = design_figures(cfg, p, law, d)
            v, ok, bind = verdicts(cfg, p, d, fig, mx.value)
            passed[i, j], binding[i, j], set_by[i, j] = ok, bind, d.preload_set_by
            constraint[i, j] = [v[k] for k in CONSTRAINTS]
            scal["scale"][i, j], scal["pull_g"][i, j] = d.scale, d.pull_g
            scal["preload_N"][i, j] = m * d.pull_g * g
            for key in ("transport_s", "residual_drift_m", "mount_force_peak_N",
                        "sphere_radius_m", *(k for k, *_ in _DEMAND)):
                scal[key][i, j] = fig[key]
            if d.inside is not None:
                scal["inside_scale"][i, j], scal["inside_pull_g"][i, j] = d.inside
            if d.outside is not None:
                scal["outside_scale"][i, j], scal["outside_pull_g"][i, j] = d.outside
            trials.append(d.trials)
    n = max(len(t) for t in trials)
    tr = {k: np.full((*shape, n), math.nan) for k in (
        "trial_scale", "trial_pull_g", "trial_carried", "trial_drift_m", "trial_feasible")}
    for k, ts in enumerate(trials):
        i, j = divmod(k, len(laws))
        for q, t in enumerate(ts):
            tr["trial_scale"][i, j, q], tr["trial_pull_g"][i, j, q] = t.scale, t.pull_g
            tr["trial_carried"][i, j, q] = float(t.carried)
            tr["trial_drift_m"][i, j, q] = t.drift
            tr["trial_feasible"][i, j, q] = float(t.feasible)
    pl = ("platform", "law")
    units = {"scale": "1", "pull_g": "1", "preload_N": "N", "transport_s": "s",
             "residual_drift_m": "m", "mount_force_peak_N": "N", "sphere_radius_m": "m",
             "P_actuator_peak": "W", "E_actuator": "J", "stroke": "m", "bandwidth": "Hz"}
    data: dict[str, Any] = {k: (pl, v, {"units": units.get(k, "1")}) for k, v in scal.items()}
    data.update({
        "passed": (pl, passed, {"long_name": "1 if every constraint passes"}),
        "binding": (pl, binding.astype(str), {"long_name": "the constraint that binds"}),
        "preload_set_by": (pl, set_by.astype(str), {
            "long_name": "what fails just below the smallest pull (preload_max: the ceiling)"}),
        "constraint_passed": ((*pl, "constraint"), constraint,
                              {"long_name": "1 if the constraint passes at the design"}),
        **{k: ((*pl, "trial"), v, {"long_name": f"{k} of every run the search tried"})
           for k, v in tr.items()},
        "window_s": ("platform", np.array([math.nan if st.platforms[k].window_s is None
                                           else st.platforms[k].window_s for k in names]),
                     {"units": "s", "long_name": "microgravity window (NaN: none)"}),
        "budget_s": ("platform", np.array([budget(cfg, st.platforms[k]) for k in names]),
                     {"units": "s", "long_name": "time one transport may take"}),
        "residual_g": ("platform", np.array([st.platforms[k].residual_g for k in names]),
                       {"units": "1"}),
        "preload_max_g": ("platform", np.array([st.platforms[k].preload_max_g
                                                for k in names]), {"units": "1"}),
        "label": ("platform", np.array([st.platforms[k].label for k in names], dtype=str)),
    })
    out = xr.Dataset(data, coords={"platform": names, "law": laws,
                                   "constraint": list(CONSTRAINTS),
                                   "trial": np.arange(n)})
    out.attrs.update({
        "max_strain": mx.value, "max_strain_alpha": mx.alpha, "max_strain_R": mx.R,
        "max_strain_t": mx.t, "strain_limit": float(st.material.eps_u),
        "material": st.material.name, "margin": st.requirements.margin,
        "scale_min": st.requirements.scale_min, "scale_max": st.requirements.scale_max,
        "preload_min_g": st.requirements.preload_min_g, "rel_tol": st.requirements.rel_tol,
        "drift_max_radii": st.requirements.drift_max, "sphere_mass": m, "g": g,
    })
    return out


# ------------------------------------------------------------------------------ interfaces
def interface_dataset(cfg: En07Config, I_s: float, scale: float | None = None,
                      pull_g: float | None = None, T: float | None = None) -> xr.Dataset:
    """The base at the interfaces' scale under their pull (the base confinement, g = 0) on
    EN-03's free structure of inertia I_s, every step recorded (T: another cycle length at
    that scale, for the closed-form limit)."""
    st = cfg.study
    it = st.interfaces
    s = it.scale if scale is None else scale
    a = it.pull_g if pull_g is None else pull_g
    scaled = scale_config(cfg.bases[st.base], s, a)
    if T is not None:
        n = max(1, math.ceil(T / scaled.solver.dt))
        scaled = vary(scaled, {"phases.T": T, "study.duration": T, "solver.dt": T / n,
                               "solver.output_interval": T / n})
    prob = scaled.sphere_problem()
    m = scaled.sphere.m
    prob = prob.replace(g=0.0, confinement="base", force=m * scaled.sphere.g,
                        inertia=float(I_s), interval=prob.solver.dt)
    ds = structure_dataset(prob, simulate(prob))
    th = np.radians(ds["theta"].values)
    X, V, W = ds["centre"].values, ds["velocity"].values, ds["theta_rate"].values
    rel = V + W[:, None] * np.stack([-X[:, 1], X[:, 0], 0.0 * X[:, 2]], axis=-1)
    c, sn = np.cos(th), np.sin(th)
    world = np.stack([c * rel[:, 0] - sn * rel[:, 1], sn * rel[:, 0] + c * rel[:, 1],
                      rel[:, 2]], axis=-1)
    ds["world_velocity"] = (("time", "component"), world,
                            {"long_name": "sphere centre velocity in the world frame",
                             "units": "m s-1"})
    return ds


def interface_row(ds: xr.Dataset, I_s: float, m: float) -> dict[str, float]:
    """The interface figures of one run (docs/aerospace.md s.4) and the point-mass closed
    form: yaw -m rho0^2 / (I_s + m rho0^2) times the sphere's relative turn."""
    t = ds["time"].values
    F = mount_force(ds, m, np.zeros(3))
    rate = ds["theta_rate"].values
    torque = I_s * np.gradient(rate, t, edge_order=2) if t.size >= 3 else np.full(t.size,
                                                                                  math.nan)
    theta = ds["theta"].values
    rho0 = float(ds["centre_radius"].values[0])
    turn = math.radians(float(ds.attrs["angular_displacement"]))
    return {
        "mount_force_peak_N": float(np.max(F)),
        "mount_force_rms_N": float(np.sqrt(np.mean(F * F))),
        "torque_peak_N_m": float(np.max(np.abs(torque))),
        "yaw_excursion_deg": float(np.max(np.abs(theta - theta[0]))),
        "yaw_final_deg": float(theta[-1] - theta[0]),
        "yaw_rate_peak_deg_s": math.degrees(float(ds.attrs["max_structure_rate"])),
        "stored_momentum_N_m_s": float(ds.attrs["hz_scale"]),
        "H_z_drift": float(ds.attrs["max_hz_drift"]),
        "point_mass_yaw_deg": math.degrees(point_mass_yaw(m, rho0, I_s, turn)),
        "radial_excursion_m": float(np.ptp(ds["centre_radius"].values)),
        "initial_radius_m": rho0,
    }


#: Units of the interface figures.
_INTERFACE_UNITS = {
    "mount_force_peak_N": "N", "mount_force_rms_N": "N", "torque_peak_N_m": "N m",
    "yaw_excursion_deg": "degree", "yaw_final_deg": "degree", "yaw_rate_peak_deg_s":
    "degree s-1", "stored_momentum_N_m_s": "kg m2 s-1", "H_z_drift": "kg m2 s-1",
    "point_mass_yaw_deg": "degree", "radial_excursion_m": "m", "initial_radius_m": "m"}


def run_interfaces(cfg: En07Config) -> xr.Dataset:
    """The ``en07_interfaces`` dataset (the module docstring)."""
    it = cfg.study.interfaces
    m = cfg.bases[cfg.study.base].sphere.m
    rows = []
    thetas = []
    interface_times = []
    for I_s in it.inertias:
        ds = interface_dataset(cfg, I_s)
        rows.append(interface_row(ds, I_s, m))
        thetas.append(ds["theta"].values)
        interface_times.append(ds["time"].values)
    n = max(len(x) for x in thetas)
    theta = np.full((len(thetas), n), math.nan)
    for i, x in enumerate(thetas):
        theta[i, :len(x)] = x
    keep = max(1, n // 2000)
    longest = max(range(len(thetas)), key=lambda i: len(thetas[i]))
    times = interface_times[longest][::keep]
    data: dict[str, Any] = {k: ("host_inertia", np.array([r[k] for r in rows]),
                                {"units": u}) for k, u in _INTERFACE_UNITS.items()}
    data["theta"] = (("host_inertia", "time"), theta[:, ::keep],
                     {"units": "degree", "long_name": "host yaw (every few rows)"})
    out = xr.Dataset(data, coords={"host_inertia": ("host_inertia",
                                                    np.asarray(it.inertias, float),
                                                    {"units": "kg m2"}),
                                   "time": ("time", times, {"units": "s"})})
    out.attrs.update({"scale": it.scale, "pull_g": it.pull_g, "sphere_mass": m,
                      "comment": "base confinement P = m a, g = 0: the pull's reaction is "
                                 "internal to the device"})
    return out
