"""EN-06 part 4: the surface a finite set of ribs makes, and what it does to the transport.

EN-02 (and EN-02R) run on the rib surface of N ribs (docs/model.md s.14.4) for each N of the
series and on the ideal surface, each at dt and dt / 2: the skin's shape error, h_0 and its
largest alias (closed forms, creatio.model.ribs), the final angle and radius against the
ideal run's, min N, the surface work, the dt difference and the energy residuals at dt and
dt / 2; the smallest N within spec
(|final angle error| <= angle_deg, |final radius error| <= radius_m, carried). Then the ribs
with errors at that N (or a chosen one) over seeds: the fraction within spec and its
binomial interval. Rib counts N <= 2 Ka are refused, each with the reason, not run.

Cost (2 cores shared, EN-02's rk4 at dt = 2 ms over 120 s): about 0.3 s a run, 2 x 6 x 2
runs of the series and one per seed: about 40 s for the defaults, plus the rib surface's
compile (about a minute, once per cache).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import xarray as xr

from creatio.dynamics import simulate
from creatio.dynamics.problem import SimulationResult, SphereProblem
from creatio.model import ribs
from creatio.model.surface import Surface
from creatio.studies.en06_tolerances import binomial_interval
from creatio.studies.schema import DynamicConfig, PhasesConfig

__all__ = ["RIB_COUNTS", "rib_problem", "ribs_dataset"]

#: The study's rib counts (docs/materials.md): the series the transport error is measured on.
RIB_COUNTS = (18, 24, 36, 48, 72)


def rib_problem(base: SphereProblem, rib_set: ribs.Ribs | None) -> SphereProblem:
    """base on the rib surface of rib_set (None: the ideal surface), all else unchanged."""
    s = base.model.surface
    return base.replace(surface=Surface(s.R0, s.dR, s.A, s.Kr, s.Ka, ribs=rib_set))


def _outcome(res: SimulationResult, ref: SimulationResult | None) -> dict[str, float]:
    """Final angle and radius (the centre's horizontal radius, as EN-05 and the tolerance
    parts measure it; and their errors against ref), W_surface, min N, carried."""
    h = res.histories
    angle = math.degrees(float(h.azimuth[-1]))
    radius = float(np.hypot(h.X[-1, 0], h.X[-1, 1]))
    out = {"final_angle_deg": angle, "final_radius_m": radius,
           "W_surface_J": float(h.surface_work[-1]), "min_normal_N": res.extrema.min_N,
           "carried": float(res.carried and res.counts.status == "ok"),
           "energy_residual_J": res.extrema.max_energy_residual}
    if ref is not None:
        out["angle_error_deg"] = angle - math.degrees(float(ref.histories.azimuth[-1]))
        out["radius_error_m"] = radius - float(np.hypot(ref.histories.X[-1, 0],
                                                         ref.histories.X[-1, 1]))
        out["transport_error_m"] = float(np.max(np.abs(h.X - ref.histories.X)))
    return out


def _pair(problem: SphereProblem) -> tuple[SimulationResult, SimulationResult, float]:
    """The runs at dt and dt / 2 and the largest centre difference between them."""
    a, b = simulate(problem), simulate(problem.replace(dt=problem.solver.dt / 2.0))
    return a, b, float(np.max(np.abs(a.histories.X - b.histories.X)))


def ribs_dataset(base: DynamicConfig, surfaces: dict[str, PhasesConfig],
                 counts: Sequence[int] = RIB_COUNTS, refused: Sequence[int] = (12,),
                 errors_N: int | None = None, seeds: int = 50, sigma_e: float = 0.01,
                 sigma_d_deg: float = 1.0, angle_deg: float = 1.0,
                 radius_m: float = 0.01) -> xr.Dataset:
    """EN-06's rib study on base (EN-02's config) with each named phase pair of surfaces
    (en02, en02r): the N series against the ideal run, the refusals, and the rib errors at
    errors_N (None: the first surface's smallest N within spec, else the largest N) over
    `seeds` seeds (first surface only); see the module."""
    Ka = int(base.geometry.Ka)
    reasons = []
    for N in refused:
        try:
            ribs.check_rib_count(N, Ka)
            reasons.append("")
        except ValueError as e:
            reasons.append(str(e))
    names = list(surfaces)
    counts = [int(N) for N in counts]
    fields = ("final_angle_deg", "final_radius_m", "W_surface_J", "min_normal_N", "carried",
              "energy_residual_J", "angle_error_deg", "radius_error_m", "transport_error_m",
              "dt_difference_m", "energy_residual_half_J", "within_spec")
    data = {f: np.full((len(names), len(counts)), np.nan) for f in fields}
    ideal = {f: np.full(len(names), np.nan) for f in (*fields[:6], "dt_difference_m")}
    problems = {}
    for i, name in enumerate(names):
        problem = _with_phases(base.sphere_problem(), surfaces[name])
        problems[name] = problem
        ref, _, ref_dt = _pair(rib_problem(problem, None))
        for key, value in _outcome(ref, None).items():
            ideal[key][i] = value
        ideal["dt_difference_m"][i] = ref_dt
        for j, N in enumerate(counts):
            run = rib_problem(problem, ribs.Ribs(N))
            res, half, diff = _pair(run)
            for key, value in _outcome(res, ref).items():
                data[key][i, j] = value
            data["dt_difference_m"][i, j] = diff
            data["energy_residual_half_J"][i, j] = half.extrema.max_energy_residual
            data["within_spec"][i, j] = float(
                data["carried"][i, j] == 1.0
                and abs(data["angle_error_deg"][i, j]) <= angle_deg
                and abs(data["radius_error_m"][i, j]) <= radius_m)
    shape = [ribs.shape_error(N, Ka) for N in counts]
    h0 = [float(ribs.alias_amplitudes(N, Ka, 0)) for N in counts]
    m = np.array([-2, -1, 1, 2])
    alias = [ribs.alias_amplitudes(N, Ka, m) for N in counts]
    largest = [int(m[np.argmax(a)]) for a in alias]
    # rib errors at errors_N, first surface, against its ideal run
    if errors_N is None:
        within = [N for N, ok in zip(counts, data["within_spec"][0], strict=True) if ok == 1.0]
        errors_N = min(within) if within else max(counts)
    first = problems[names[0]]
    ref = simulate(rib_problem(first, None))
    err = {k: np.full(seeds, np.nan) for k in ("angle_error_deg", "radius_error_m", "carried")}
    for seed in range(seeds):
        e, d = ribs.rib_errors(errors_N, sigma_e, math.radians(sigma_d_deg), seed)
        res = simulate(rib_problem(first, ribs.Ribs(errors_N, tuple(e), tuple(d))))
        out = _outcome(res, ref)
        for k in err:
            err[k][seed] = out[k]
    ok = ((err["carried"] == 1.0) & (np.abs(err["angle_error_deg"]) <= angle_deg)
          & (np.abs(err["radius_error_m"]) <= radius_m))
    lo, hi = binomial_interval(int(ok.sum()), seeds, 0.95)
    ds = xr.Dataset(
        {**{f: (("surface", "N"), v) for f, v in data.items()},
         **{f"ideal_{f}": (("surface",), v) for f, v in ideal.items()},
         "shape_error_rel": (("N",), np.array(shape)),
         "h0": (("N",), np.array(h0)),
         "largest_alias_n": (("N",), np.array(largest)),
         "largest_alias_h": (("N",), np.array([float(np.max(a)) for a in alias])),
         "refused_reason": (("refused_N",), np.array(reasons, dtype=object)),
         "error_angle_deg": (("seed",), err["angle_error_deg"]),
         "error_radius_m": (("seed",), err["radius_error_m"]),
         "error_carried": (("seed",), err["carried"]),
         "error_within_spec": (("seed",), ok.astype(float))},
        coords={"surface": names, "N": counts, "refused_N": list(refused),
                "seed": np.arange(seeds)},
        attrs={"errors_N": errors_N, "sigma_e": sigma_e, "sigma_d_deg": sigma_d_deg,
               "spec_angle_deg": angle_deg, "spec_radius_m": radius_m,
               "fraction_within_spec": float(ok.mean()) if seeds else math.nan,
               "interval_95_low": lo, "interval_95_high": hi, "Ka": Ka,
               "dt_s": first.solver.dt, "assumption": "spline skin"},
    )
    return ds


def _with_phases(problem: SphereProblem, phases: PhasesConfig) -> SphereProblem:
    """problem with the laws of phases (the surface's motion of EN-02 or EN-02R)."""
    phi_r, phi_a, gamma = phases.laws()
    return problem.replace(phi_r=phi_r, phi_a=phi_a, gamma=gamma)
