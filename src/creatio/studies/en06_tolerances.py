"""EN-06's tolerances and its energy check under tilt (docs/materials.md s.8): how exactly the
membrane must be built and mounted for EN-02's transport to stay within spec.

Every run is EN-02 (``bases.en02``, on the study's geometry) at its own step, varied by
dotted keys (creatio.studies.schema.vary) and read through EN-05's outputs of a run
(creatio.studies.en05.run_outputs) and the dataset's final centre azimuth. Errors are taken
from the nominal run's (the base itself, the same solver): the final angle's, the final
radius', carried or not, and W_surface.

Parts (one dataset and one job each):

* ``tilt``: the energy identity under a mounting tilt, its largest residual at dt, dt / 2,
  dt / 4 and the observed orders (:func:`tilt_dataset`).
* ``sobol``: first-order and total Sobol' indices of the outputs over the declared
  tolerances, by EN-05's design and estimators (sobol_design, to_inputs, sobol_indices), at
  each base size (:func:`sobol_dataset`).
* ``allocation``: each input alone, each side, the largest deviation within spec, by a scan
  to the cap and a bisection (:func:`boundary`, :func:`allocation_dataset`).
* ``joint``: independent draws at the declared tolerances, the fraction within spec and its
  binomial interval (:func:`binomial_interval`, :func:`joint_dataset`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from creatio.dynamics.solvers import METHODS
from creatio.errors import ConfigError
from creatio.studies import en05
from creatio.studies import sphere as en02
from creatio.studies.en05_schema import Dist, InputDistribution
from creatio.studies.en06_schema import (
    AZIMUTH_KEY,
    En06Config,
    SpecConfig,
    TolerancesConfig,
    nominal_of,
)
from creatio.studies.schema import DynamicConfig, vary

__all__ = ["OUTPUTS", "Boundary", "Transport", "allocation_dataset", "binomial_interval",
           "boundary", "distributions", "errors", "evaluate", "joint_dataset", "key_units",
           "nominal",
           "sobol_dataset", "tilt_dataset", "within", "within_spec"]

log = logging.getLogger("creatio")

#: The outputs of one transport (docs/materials.md s.8): name -> (units, description).
OUTPUTS: dict[str, tuple[str, str]] = {
    "final_angle_error": ("degree", "final centre azimuth minus the nominal run's"),
    "final_radius_error": ("m", "final horizontal radius of the centre minus the nominal "
                                "run's"),
    "carried": ("1", "1 if the run ends ok and the contact never left its cavity's cell"),
    "surface_work": ("J", "work of the membrane on the sphere over the cycle (W_surface)"),
}

#: Units of the keys a tolerance input usually sets (an angle's key ends in _deg).
KEY_UNITS = {"geometry.R0": "m", "geometry.dR": "m", "geometry.A": "m", "sphere.b": "m",
             "sphere.m": "kg", "sphere.mu": "1", "sphere.eps": "m s-1", "sphere.g": "m s-2",
             "study.initial.R": "m"}


def key_units(key: str) -> str:
    """The units of a config key's value ('degree' for a key in _deg; '' when not known)."""
    return "degree" if key.endswith("_deg") else KEY_UNITS.get(key, "")


#: What the tolerance parts rest on, one line (datasets' attrs and the report).
ASSUMPTION = ("EN-02's sphere model as it is (rigid sphere, prescribed surface); each input "
              "uniform on its declared tolerance; errors from the nominal run at the same step")


@dataclass(frozen=True)
class Transport:
    """The figures of one EN-02 run the tolerances read (NaN where the run did not end ok,
    or was refused before it ran: ``status`` says which)."""

    final_angle_deg: float
    final_radius_m: float
    surface_work_J: float
    carried: bool
    status: str


#: A transport of the base varied by dotted keys: what the parts evaluate (a test passes
#: a closed-form toy in its place).
Model = Callable[[Mapping[str, float]], Transport]


def evaluate(base: DynamicConfig, changes: Mapping[str, float]) -> Transport:
    """EN-02 varied by ``changes`` at its own dt: final azimuth (degrees, unwrapped), final
    radius, W_surface and carried, through EN-05's outputs of a run; a combination the
    model's rules refuse is not carried (status ``refused: <key>: <rule>``)."""
    try:
        cfg = vary(base, changes)
    except ConfigError as e:
        return Transport(math.nan, math.nan, math.nan, False, f"refused: {e.key}: {e.rule}")
    ds = en02.run(cfg, cfg.solver.dt)
    out = en05.run_outputs(ds, cfg.sphere.m, cfg.sphere.g)
    status = str(ds.attrs["status"])
    angle = float(ds.centre_azimuth.values[-1]) if status == "ok" else math.nan
    return Transport(angle, out["final_radius"], out["surface_work"], bool(out["carried"]),
                     status)


def nominal(model: Model) -> Transport:
    """The nominal transport: the base unchanged."""
    return model({})


def errors(t: Transport, nom: Transport) -> dict[str, float]:
    """The outputs of :data:`OUTPUTS` of one transport against the nominal."""
    return {"final_angle_error": t.final_angle_deg - nom.final_angle_deg,
            "final_radius_error": t.final_radius_m - nom.final_radius_m,
            "carried": float(t.carried), "surface_work": t.surface_work_J}


def within_spec(errs: Mapping[str, float], spec: SpecConfig) -> bool:
    """Carried, |final angle error| <= spec.angle_deg and |final radius error| <=
    spec.radius_m (a NaN error is out of spec)."""
    return bool(errs["carried"] == 1.0 and abs(errs["final_angle_error"]) <= spec.angle_deg
                and abs(errs["final_radius_error"]) <= spec.radius_m)


def _tilted(changes: Mapping[str, float], base: DynamicConfig) -> bool:
    beta = changes.get("sphere.beta_deg", nominal_of(base, "sphere.beta_deg"))
    return float(beta) > 0.0


def within(model: Model, base: DynamicConfig, changes: Mapping[str, float], nom: Transport,
           spec: SpecConfig, azimuths: int) -> tuple[bool, int]:
    """(within spec, runs): a level point by one run; a tilted one only if within spec at
    every azimuth 360 k / azimuths (stopping at the first that is not)."""
    if not _tilted(changes, base):
        return within_spec(errors(model(changes), nom), spec), 1
    for k in range(azimuths):
        ok = within_spec(errors(model({**changes, AZIMUTH_KEY: 360.0 * k / azimuths}), nom),
                         spec)
        if not ok:
            return False, k + 1
    return True, azimuths


def distributions(tol: TolerancesConfig, base: DynamicConfig) -> list[InputDistribution]:
    """Each input's uniform distribution on its declared tolerance, in :attr:`names` order."""
    out = []
    for name in tol.names:
        inp = tol.inputs[name]
        x0 = nominal_of(base, inp.key)
        lo, hi = sorted((inp.value(x0, -inp.minus), inp.value(x0, inp.plus)))
        out.append(InputDistribution(key=inp.key, dist=Dist.uniform, low=lo, high=hi))
    return out


def _run_rows(model: Model, keys: Sequence[str], X: np.ndarray, nom: Transport,
              what: str) -> dict[str, np.ndarray]:
    """The outputs and status of the model at every row of X (columns: keys)."""
    n = X.shape[0]
    rows: dict[str, Any] = {name: np.full(n, np.nan) for name in OUTPUTS}
    rows["status"] = np.full(n, "", dtype=object)
    for i in range(n):
        t = model({k: float(x) for k, x in zip(keys, X[i], strict=True)})
        for name, v in errors(t, nom).items():
            rows[name][i] = v
        rows["status"][i] = t.status
        if (i + 1) % 500 == 0 or i + 1 == n:
            log.info("en06 %s: %d/%d runs", what, i + 1, n)
    return rows


def _nominal_vars(nom: Transport) -> dict[str, Any]:
    return {
        "nominal_final_angle": ((), nom.final_angle_deg, {
            "units": "degree", "long_name": "final centre azimuth of the nominal run"}),
        "nominal_final_radius": ((), nom.final_radius_m, {
            "units": "m", "long_name": "final centre radius of the nominal run"}),
        "nominal_surface_work": ((), nom.surface_work_J, {
            "units": "J", "long_name": "W_surface of the nominal run"}),
    }


def _common_attrs(cfg: En06Config, part: str, nom: Transport) -> dict[str, Any]:
    spec = cfg.study.tolerances.spec
    sv = cfg.base.solver
    return {"part": part, "assumptions": ASSUMPTION, "spec_angle_deg": spec.angle_deg,
            "spec_radius_m": spec.radius_m, "method": str(sv.method), "dt": sv.dt,
            "nominal_status": nom.status, "nominal_carried": int(nom.carried)}


def _input_coords(cfg: En06Config) -> dict[str, Any]:
    tol = cfg.study.tolerances
    names = tol.names
    dists = distributions(tol, cfg.base)
    return {
        "input": ("input", names),
        "input_key": ("input", [tol.inputs[n].key for n in names]),
        "input_units": ("input", [key_units(tol.inputs[n].key) for n in names]),
        "input_nominal": ("input", [nominal_of(cfg.base, tol.inputs[n].key) for n in names],
                          {"long_name": "nominal value of the input's key"}),
        "input_low": ("input", [d.low for d in dists], {"long_name": "lowest declared value"}),
        "input_high": ("input", [d.high for d in dists],
                       {"long_name": "highest declared value"}),
    }


# ------------------------------------------------------------------------------- Sobol'
def sobol_dataset(cfg: En06Config, model: Model | None = None) -> xr.Dataset:
    """Part ``sobol``: EN-05's Saltelli design of the largest base size over the declared
    tolerances (the smaller sizes its prefixes), every row run, and per base size and
    output S1 and ST with bootstrap half-widths (EN-05's sobol_indices); NaN where some
    run did not produce the output (runs_missing) or it is constant over the design."""
    tol, base = cfg.study.tolerances, cfg.base
    sb = tol.sobol
    model = model or (lambda ch: evaluate(base, ch))
    names = tol.names
    d = len(names)
    dists = distributions(tol, base)
    n_max = max(sb.base_sizes)
    U = en05.sobol_design(names, n_max, sb.seed)
    X = en05.to_inputs(dists, U)
    nom = nominal(model)
    rows = _run_rows(model, [x.key for x in dists], X, nom, "sobol")
    sizes = np.array(sb.base_sizes)
    shape = (sizes.size, len(OUTPUTS), d)
    est = {k: np.full(shape, np.nan) for k in ("S1", "ST", "S1_conf", "ST_conf")}
    missing = np.zeros((sizes.size, len(OUTPUTS)), dtype=np.int64)
    not_ok = np.zeros(sizes.size, dtype=np.int64)
    status = rows["status"].astype(str)
    for i, N in enumerate(sizes):
        m = int(N) * (d + 2)
        not_ok[i] = int(np.sum(status[:m] != "ok"))
        for j, out in enumerate(OUTPUTS):
            y = rows[out][:m]
            missing[i, j] = int(np.sum(~np.isfinite(y)))
            if missing[i, j] or np.ptp(y) == 0.0:
                continue
            si = en05.sobol_indices(names, y, sb.resamples, sb.confidence, sb.seed)
            for key, arr in est.items():
                arr[i, j] = [si[key][nm] for nm in names]
    long = {"S1": "first-order Sobol' index", "ST": "total Sobol' index",
            "S1_conf": "bootstrap half-width of S1", "ST_conf": "bootstrap half-width of ST"}
    data: dict[str, Any] = {k: (("base_size", "output", "input"), v,
                                {"long_name": long[k], "units": "1"}) for k, v in est.items()}
    data["runs_missing"] = (("base_size", "output"), missing, {
        "long_name": "runs of the design that did not produce the output", "units": "1"})
    data["runs_not_ok"] = (("base_size",), not_ok, {
        "long_name": "runs of the design that did not end ok", "units": "1"})
    data["runs"] = (("base_size",), sizes * (d + 2), {
        "long_name": "runs of the design, N (d + 2)", "units": "1"})
    data["unit_sample"] = (("point", "input"), U, {"long_name": "design point in the unit "
                                                   "cube", "units": "1"})
    data["input_value"] = (("point", "input"), X, {"long_name": "input value of the point"})
    for name, (units, what) in OUTPUTS.items():
        data[name] = (("point",), rows[name], {"long_name": what, "units": units})
    data["status"] = (("point",), status, {"long_name": "run status"})
    data.update(_nominal_vars(nom))
    ds = xr.Dataset(data, coords={
        "base_size": ("base_size", sizes, {"long_name": "Sobol' base sample N", "units": "1"}),
        "output": ("output", list(OUTPUTS)),
        "point": ("point", np.arange(X.shape[0])),
        **_input_coords(cfg)})
    ds.attrs.update({**_common_attrs(cfg, "sobol", nom), "seed": sb.seed,
                     "resamples": sb.resamples, "confidence": sb.confidence,
                     "comment": "indices of an output are NaN where some run of that design "
                                "did not produce it (runs_missing) or it is constant over the "
                                "design (carried, when every run carries)"})
    return ds


# --------------------------------------------------------------------------- allocation
@dataclass(frozen=True)
class Boundary:
    """One side's allocation: ``inside``, the largest deviation found within spec (every
    scanned deviation below it within spec too), ``outside``, the smallest found out of spec
    above it (NaN when the cap is within spec: ``capped``), and the runs it took."""

    inside: float
    outside: float
    capped: bool
    runs: int


def boundary(test: Callable[[float], tuple[bool, int]], cap: float, scan: int,
             iterations: int) -> Boundary:
    """The largest deviation in [0, cap] within spec: ``test(d)`` -> (within spec, runs) at
    d = cap k / scan, k = 1, 2, ... up to the first out of spec, then ``iterations``
    bisections between it and the last within (d = 0, the nominal, taken within)."""
    runs = 0
    lo = 0.0
    for k in range(1, scan + 1):
        d = cap * k / scan
        ok, n = test(d)
        runs += n
        if not ok:
            hi = d
            break
        lo = d
    else:
        return Boundary(cap, math.nan, True, runs)
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        ok, n = test(mid)
        runs += n
        lo, hi = (mid, hi) if ok else (lo, mid)
    return Boundary(lo, hi, False, runs)


def allocation_dataset(cfg: En06Config, model: Model | None = None) -> xr.Dataset:
    """Part ``allocation``: for each input alone (the others nominal) and each side with a
    cap, :func:`boundary` of "within spec" (at every azimuth when tilted), in the input's
    units (a relative input's as a fraction of its nominal)."""
    tol, base = cfg.study.tolerances, cfg.base
    al, spec = tol.allocation, tol.spec
    model = model or (lambda ch: evaluate(base, ch))
    names = tol.names
    nom = nominal(model)
    shape = (len(names), 2)
    inside, outside = np.full(shape, np.nan), np.full(shape, np.nan)
    capped = np.zeros(shape, np.int8)
    allocated = np.zeros(shape, np.int8)
    runs = np.zeros(shape, np.int64)
    nominal_in = nom.carried  # the nominal's errors are 0: it is within spec when carried
    for i, name in enumerate(names):
        inp = tol.inputs[name]
        x0 = nominal_of(base, inp.key)
        for j, sign in enumerate((-1.0, 1.0)):
            cap = float(inp.cap[j])
            if cap == 0.0:
                continue
            allocated[i, j] = 1
            if not nominal_in:
                inside[i, j], outside[i, j] = 0.0, 0.0
                continue

            def test(dev: float, inp: Any = inp, x0: float = x0, sign: float = sign
                     ) -> tuple[bool, int]:
                return within(model, base, {inp.key: inp.value(x0, sign * dev)}, nom, spec,
                              al.azimuths)

            b = boundary(test, cap, al.scan, al.iterations)
            inside[i, j], outside[i, j] = b.inside, b.outside
            capped[i, j], runs[i, j] = int(b.capped), b.runs
            log.info("en06 allocation: %s %s: %.6g (%d runs)", name, "-+"[j], b.inside, b.runs)
    sides = ("input", "side")
    declared = np.array([[tol.inputs[n].minus, tol.inputs[n].plus] for n in names])
    caps = np.array([list(tol.inputs[n].cap) for n in names], float)
    data: dict[str, Any] = {
        "allocation": (sides, inside, {"long_name": "largest deviation within spec (the "
                                       "input's units; relative inputs as a fraction)"}),
        "first_outside": (sides, outside, {"long_name": "smallest deviation found out of spec "
                                           "(NaN: the cap is within spec)"}),
        "cap": (sides, caps, {"long_name": "the search's cap (0: side not allocated)"}),
        "declared": (sides, declared, {"long_name": "declared tolerance"}),
        "capped": (sides, capped, {"long_name": "1 where the cap itself is within spec",
                                   "units": "1"}),
        "allocated": (sides, allocated, {"long_name": "1 where the side was allocated",
                                         "units": "1"}),
        "runs": (sides, runs, {"long_name": "runs of the side's search", "units": "1"}),
        "relative": (("input",), np.array([int(tol.inputs[n].relative) for n in names],
                                          np.int8),
                     {"long_name": "1 where deviations are fractions of the nominal",
                      "units": "1"}),
        **_nominal_vars(nom)}
    ds = xr.Dataset(data, coords={"side": ("side", ["minus", "plus"]), **_input_coords(cfg)})
    ds.attrs.update({**_common_attrs(cfg, "allocation", nom), "scan": al.scan,
                     "iterations": al.iterations, "azimuths": al.azimuths,
                     "comment": "each input alone; scan to the first deviation out of spec, "
                                "then bisect; a tilted point is within spec only at every "
                                "azimuth 360 k / azimuths"})
    return ds


# -------------------------------------------------------------------------------- joint
def binomial_interval(k: int, n: int, confidence: float, method: str = "exact"
                      ) -> tuple[float, float]:
    """The two-sided interval of a binomial fraction k / n at ``confidence``
    (scipy.stats.binomtest: ``exact`` Clopper-Pearson, or ``wilson``)."""
    from scipy import stats

    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence,
                                                       method=method)
    return float(ci.low), float(ci.high)


def joint_dataset(cfg: En06Config, model: Model | None = None) -> xr.Dataset:
    """Part ``joint``: n independent draws of every input at once from its declared
    distribution (PCG64 seeded, mapped by EN-05's to_inputs), the fraction within spec and
    its binomial interval."""
    tol, base = cfg.study.tolerances, cfg.base
    jt = tol.joint
    model = model or (lambda ch: evaluate(base, ch))
    dists = distributions(tol, base)
    U = np.random.default_rng(jt.seed).random((jt.n, len(dists)))
    X = en05.to_inputs(dists, U)
    nom = nominal(model)
    rows = _run_rows(model, [x.key for x in dists], X, nom, "joint")
    ok = np.array([within_spec({k: rows[k][i] for k in OUTPUTS}, tol.spec)
                   for i in range(jt.n)], np.int8)
    k = int(ok.sum())
    lo, hi = binomial_interval(k, jt.n, jt.confidence, str(jt.interval))
    data: dict[str, Any] = {
        "input_value": (("draw", "input"), X, {"long_name": "input value of the draw"}),
        **{name: (("draw",), rows[name], {"long_name": what, "units": units})
           for name, (units, what) in OUTPUTS.items()},
        "status": (("draw",), rows["status"].astype(str), {"long_name": "run status"}),
        "within_spec": (("draw",), ok, {"long_name": "1 where the transport is within spec",
                                        "units": "1"}),
        "fraction_within_spec": ((), k / jt.n, {"long_name": "fraction of draws within spec",
                                                "units": "1"}),
        "within_count": ((), k, {"long_name": "draws within spec", "units": "1"}),
        "interval_low": ((), lo, {"long_name": "binomial interval of the fraction: low",
                                  "units": "1"}),
        "interval_high": ((), hi, {"long_name": "binomial interval of the fraction: high",
                                   "units": "1"}),
        **_nominal_vars(nom)}
    ds = xr.Dataset(data, coords={"draw": ("draw", np.arange(jt.n)), **_input_coords(cfg)})
    ds.attrs.update({**_common_attrs(cfg, "joint", nom), "n": jt.n, "seed": jt.seed,
                     "confidence": jt.confidence, "interval": str(jt.interval),
                     "interval_method": {"exact": "Clopper-Pearson (exact)",
                                         "wilson": "Wilson score"}[str(jt.interval)],
                     "comment": "independent draws (numpy PCG64), each input uniform on its "
                                "declared tolerance; scipy.stats.binomtest's interval"})
    return ds


# ---------------------------------------------------------------------------- tilt check
def tilt_dataset(cfg: En06Config) -> xr.Dataset:
    """Part ``tilt``: bases.en02 tilted by study.tilt_check on its short cycle at dt, dt / 2
    and dt / 4: the largest energy residual E - E0 - W_surface + D_friction (V = -m g . X)
    at each, and the observed order of each halving, log2 of the ratio."""
    tc, base = cfg.study.tilt_check, cfg.base
    steps = tc.steps(base)
    residual, status = np.empty(len(steps)), []
    for i, dt in enumerate(steps):
        c = vary(base, tc.changes(dt))
        ds = en02.run(c, dt)
        residual[i] = float(ds.attrs["max_energy_residual"])
        status.append(str(ds.attrs["status"]))
    with np.errstate(divide="ignore", invalid="ignore"):
        order = np.log2(residual[:-1] / residual[1:])
    out = xr.Dataset({
        "energy_residual": (("dt",), residual, {
            "units": "J", "long_name": "largest |E - E0 - W_surface + D_friction| over the run "
                                       "(V = -m g . X, g the tilted vector)"}),
        "observed_order": (("halving",), order, {
            "units": "1", "long_name": "log2 of the residual's ratio between a step and its "
                                       "half"}),
        "status": (("dt",), np.array(status), {"long_name": "run status"}),
    }, coords={"dt": ("dt", np.array(steps), {"units": "s", "long_name": "time step"}),
               "halving": ("halving", np.arange(1, len(steps)))})
    out.attrs.update({"part": "tilt", "beta_deg": tc.beta_deg, "psi_deg": tc.psi_deg,
                      "cycle_s": tc.cycle_s, "method": str(base.solver.method),
                      "scheme_order": METHODS[str(base.solver.method)].order,
                      "assumptions": "EN-02's sphere model with gravity as the tilted vector",
                      "comment": "the residual is at the scheme's truncation level when it "
                                 "falls at the scheme's order"})
    return out
