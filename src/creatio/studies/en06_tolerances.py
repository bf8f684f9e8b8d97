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

With ``study.tolerances.budget.enabled`` the sobol, allocation and joint parts run at the
accuracy their answers need (creatio.studies.budget, docs/accuracy.md): the loosest rung of
the budget's ladder a pilot finds within budget, verified on a seeded subsample rerun 100x
tighter and tightened when broken; the check is the dataset's ``accuracy_*`` attributes.
The Sobol' outputs' budget is sobol_fraction of each output's standard deviation over the
design (final angle, final radius, W_surface; ``carried`` is discrete and not budgeted), the
joint's joint_fraction of the spec's bounds (a draw can change sides only within that of
the bound), the allocation's allocation_fraction of the bisection's resolution: the shift of
each boundary, its margin's numerical error over the margin's slope (:func:`margin`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from creatio.dynamics.solvers import METHODS
from creatio.errors import ConfigError
from creatio.studies import budget as bd
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

__all__ = ["BUDGETED", "OUTPUTS", "Boundary", "Models", "Transport", "allocation_dataset",
           "binomial_interval", "boundary", "distributions", "errors", "evaluate",
           "joint_dataset", "key_units", "margin", "models_of", "nominal",
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


#: The base's transport model at a rung of the accuracy budget (a test passes a toy's).
Models = Callable[[bd.Rung], Model]

#: The Sobol' outputs under the budget (``carried`` is discrete: a flip is not an error of
#: a fraction of its spread).
BUDGETED = ("final_angle_error", "final_radius_error", "surface_work")


def models_of(base: DynamicConfig) -> Models:
    """EN-02 at a rung: the base with the rung's method and tolerances."""
    def at(rung: bd.Rung) -> Model:
        cfg = vary(base, rung.changes())
        return lambda ch: evaluate(cfg, ch)
    return at


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


def margin(model: Model, base: DynamicConfig, changes: Mapping[str, float], nom: Transport,
           spec: SpecConfig, azimuths: int) -> float:
    """How far beyond spec a point is, in units of the spec: max(|angle error| / angle_deg,
    |radius error| / radius_m) - 1 (<= 0 within spec; inf when not carried), the largest
    over the azimuths when tilted: the continuous function whose sign the allocation's
    bisection follows."""
    out = -math.inf
    tilts = ([{}] if not _tilted(changes, base) else
             [{AZIMUTH_KEY: 360.0 * k / azimuths} for k in range(azimuths)])
    for extra in tilts:
        e = errors(model({**changes, **extra}), nom)
        g = (max(abs(e["final_angle_error"]) / spec.angle_deg,
                 abs(e["final_radius_error"]) / spec.radius_m) - 1.0
             if e["carried"] == 1.0 else math.inf)
        out = max(out, g if math.isfinite(g) else math.inf)
    return out


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


def _at_rungs(models: Models) -> Callable[[bd.Rung], tuple[Model, Transport]]:
    """A rung's model and its nominal transport, each made once per rung."""
    cache: dict[bd.Rung, tuple[Model, Transport]] = {}

    def at(rung: bd.Rung) -> tuple[Model, Transport]:
        if rung not in cache:
            m = models(rung)
            cache[rung] = (m, nominal(m))
        return cache[rung]

    return at


def _runner(models: Models, keys: Sequence[str], X: np.ndarray, what: str
            ) -> tuple[bd.Runner, Callable[[bd.Rung], Transport]]:
    """The budget's run(rung, idx) over the rows of X (errors from the nominal at the same
    rung) and the nominal at a rung, each rung's model and nominal made once."""
    at = _at_rungs(models)

    def run(rung: bd.Rung, idx: np.ndarray) -> dict[str, np.ndarray]:
        m, nom = at(rung)
        return _run_rows(m, keys, X[idx], nom, f"{what} at {rung.label()}")

    return run, lambda rung: at(rung)[1]


def _rows(cfg: En06Config, model: Model | None, models: Models | None, keys: Sequence[str],
          X: np.ndarray, what: str,
          budget_of: Callable[[Mapping[str, np.ndarray]], Mapping[str, float]],
          ) -> tuple[dict[str, np.ndarray], Transport, bd.Verification | None]:
    """Every row of X run, with the nominal and the budget's check: under the budget when it
    is enabled and no fixed model is given, else at the model (the base's own solver)."""
    bgt = cfg.study.tolerances.budget
    if model is None and bgt.enabled:
        run, nom_at = _runner(models or models_of(cfg.base), keys, X, what)
        rows, check = bd.budgeted(run, X.shape[0], bgt.rungs(), budget_of, bgt.seed,
                                  bgt.points, bgt.max_tighten)
        log.info("en06 %s: %s", what, check.describe())
        return rows, nom_at(check.rung), check
    model = model or (lambda ch: evaluate(cfg.base, ch))
    nom = nominal(model)
    return _run_rows(model, keys, X, nom, what), nom, None


def _check_attrs(check: bd.Verification | None, note: str | None = None) -> dict[str, Any]:
    """The dataset's record of the budget: the check's attributes, the method it ran; note:
    why there is no check (nothing without a budget: the datasets of the base's solver)."""
    if check is None:
        return {} if note is None else {"accuracy_budget": note}
    return {**check.attrs(), "method": check.rung.method, "rtol": check.rung.rtol,
            "atol": check.rung.atol, "accuracy_describe": check.describe()}


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
def sobol_dataset(cfg: En06Config, model: Model | None = None,
                  models: Models | None = None) -> xr.Dataset:
    """Part ``sobol``: EN-05's Saltelli design of the largest base size over the declared
    tolerances (the smaller sizes its prefixes), every row run, and per base size and
    output S1 and ST with bootstrap half-widths (EN-05's sobol_indices); NaN where some
    run did not produce the output (runs_missing) or it is constant over the design. Under
    the budget (model None) the rows run at the rung it chooses (models: at a rung)."""
    tol, base = cfg.study.tolerances, cfg.base
    sb = tol.sobol
    names = tol.names
    d = len(names)
    dists = distributions(tol, base)
    n_max = max(sb.base_sizes)
    U = en05.sobol_design(names, n_max, sb.seed)
    X = en05.to_inputs(dists, U)
    frac = tol.budget.sobol_fraction
    rows, nom, check = _rows(cfg, model, models, [x.key for x in dists], X, "sobol",
                             lambda Y: bd.sobol_budget({k: Y[k] for k in BUDGETED}, frac))
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
    ds.attrs.update({**_common_attrs(cfg, "sobol", nom), **_check_attrs(check), "seed": sb.seed,
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


@dataclass(frozen=True)
class _Side:
    """One allocated side of one input: where it sits in the arrays and how it varies."""

    i: int
    j: int
    key: str
    changes: Callable[[float], dict[str, float]]
    cap: float


def _sides(cfg: En06Config) -> list[_Side]:
    """The allocated sides (cap > 0), in input then side order."""
    tol, base = cfg.study.tolerances, cfg.base
    out = []
    for i, name in enumerate(tol.names):
        inp = tol.inputs[name]
        x0 = nominal_of(base, inp.key)
        for j, sign in enumerate((-1.0, 1.0)):
            if float(inp.cap[j]) == 0.0:
                continue

            def changes(dev: float, inp: Any = inp, x0: float = x0, sign: float = sign
                        ) -> dict[str, float]:
                return {inp.key: inp.value(x0, sign * dev)}

            out.append(_Side(i, j, f"{name}{'-+'[j]}", changes, float(inp.cap[j])))
    return out


def _search(cfg: En06Config, model: Model, nom: Transport, sides: Sequence[_Side]
            ) -> list[Boundary]:
    """:func:`boundary` of every side at model (all 0 when the nominal is not carried)."""
    tol = cfg.study.tolerances
    al = tol.allocation
    out = []
    for sd in sides:
        if not nom.carried:  # the nominal's errors are 0: it is within spec when carried
            out.append(Boundary(0.0, 0.0, False, 0))
            continue

        def test(dev: float, sd: _Side = sd) -> tuple[bool, int]:
            return within(model, cfg.base, sd.changes(dev), nom, tol.spec, al.azimuths)

        b = boundary(test, sd.cap, al.scan, al.iterations)
        log.info("en06 allocation: %s: %.6g (%d runs)", sd.key, b.inside, b.runs)
        out.append(b)
    return out


def _resolution(cfg: En06Config, sd: _Side) -> float:
    """The bisection's resolution on a side: cap / scan / 2^iterations."""
    al = cfg.study.tolerances.allocation
    return sd.cap / al.scan / 2.0**al.iterations


def _budgeted_search(cfg: En06Config, models: Models, sides: Sequence[_Side]
                     ) -> tuple[list[Boundary], Transport, bd.Verification | None]:
    """The searches at the first rung (budget.choose) whose boundary shifts (in bisection
    resolutions) a pilot at the boundaries of method's loosest rung finds within budget,
    verified at the final boundaries 100x tighter and tightened 10x while broken: a
    boundary's shift is the margin's numerical error over the margin's slope there (a
    central difference 2^10 resolutions wide at that loosest rung)."""
    tol, bgt = cfg.study.tolerances, cfg.study.tolerances.budget
    al = tol.allocation
    at = _at_rungs(models)
    rungs = bgt.rungs()
    start = next(r for r in rungs if r.method == rungs[-1].method)
    rung = start
    found = _search(cfg, *at(rung), sides)
    pts = [k for k, b in enumerate(found) if not b.capped and b.inside > 0.0]
    if not pts:
        return found, at(rung)[1], None
    m0, nom0 = at(rung)
    res = {k: _resolution(cfg, sides[k]) for k in pts}
    slope = {}
    for k in pts:
        sd, d = sides[k], found[k].inside
        h = min(2.0**10 * res[k], 0.5 * d, 0.5 * (sd.cap - d))
        g = [margin(m0, cfg.base, sd.changes(d + s * h), nom0, tol.spec, al.azimuths)
             for s in (-1.0, 1.0)]
        slope[k] = abs(g[1] - g[0]) / (2.0 * h) if h > 0.0 else math.inf

    def runner(bounds: Sequence[Boundary]) -> bd.Runner:
        def run(r: bd.Rung, idx: np.ndarray) -> dict[str, np.ndarray]:
            m, nom = at(r)
            out = np.empty(len(idx))
            for n, q in enumerate(idx):
                k = pts[int(q)]
                g = margin(m, cfg.base, sides[k].changes(bounds[k].inside), nom, tol.spec,
                           al.azimuths)
                s = slope[k]
                out[n] = (math.inf if not math.isfinite(g) else
                          0.0 if not math.isfinite(s) else g / s / res[k])
            return {"boundary": out}
        return run

    budget = {"boundary": bgt.allocation_fraction}
    everything = np.arange(len(pts))
    rung = bd.choose(runner(found), rungs, everything, bd.fixed(bgt.allocation_fraction))
    tightened = 0
    while True:
        if rung != start or tightened:
            found = _search(cfg, *at(rung), sides)
        run = runner(found)
        check = bd.verify(run, run(rung, everything), rung, budget, bgt.seed + 1, bgt.points)
        if check.ok or tightened >= bgt.max_tighten:
            check = dataclasses.replace(check, tightened=tightened)
            log.info("en06 allocation: %s", check.describe())
            return found, at(rung)[1], check
        rung = rung.tighter(10.0)
        tightened += 1


def allocation_dataset(cfg: En06Config, model: Model | None = None,
                       models: Models | None = None) -> xr.Dataset:
    """Part ``allocation``: for each input alone (the others nominal) and each side with a
    cap, :func:`boundary` of "within spec" (at every azimuth when tilted), in the input's
    units (a relative input's as a fraction of its nominal). Under the budget (model None)
    the searches run at the rung :func:`_budgeted_search` chooses (models: at a rung)."""
    tol = cfg.study.tolerances
    al = tol.allocation
    names = tol.names
    sides = _sides(cfg)
    check = None
    if model is None and tol.budget.enabled:
        found, nom, check = _budgeted_search(cfg, models or models_of(cfg.base), sides)
    else:
        model = model or (lambda ch: evaluate(cfg.base, ch))
        nom = nominal(model)
        found = _search(cfg, model, nom, sides)
    shape = (len(names), 2)
    inside, outside = np.full(shape, np.nan), np.full(shape, np.nan)
    capped = np.zeros(shape, np.int8)
    allocated = np.zeros(shape, np.int8)
    runs = np.zeros(shape, np.int64)
    for sd, b in zip(sides, found, strict=True):
        allocated[sd.i, sd.j] = 1
        inside[sd.i, sd.j], outside[sd.i, sd.j] = b.inside, b.outside
        capped[sd.i, sd.j], runs[sd.i, sd.j] = int(b.capped), b.runs
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
    note = ("no boundary below a cap: nothing to check" if tol.budget.enabled and model is None
            else None)
    ds.attrs.update({**_common_attrs(cfg, "allocation", nom), **_check_attrs(check, note),
                     "accuracy_units": "bisection resolutions (cap / scan / 2^iterations)",
                     "scan": al.scan,
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


def joint_dataset(cfg: En06Config, model: Model | None = None,
                  models: Models | None = None) -> xr.Dataset:
    """Part ``joint``: n independent draws of every input at once from its declared
    distribution (PCG64 seeded, mapped by EN-05's to_inputs), the fraction within spec and
    its binomial interval. Under the budget (model None) the draws run at the rung it
    chooses for errors within joint_fraction of the spec's bounds (models: at a rung)."""
    tol, base = cfg.study.tolerances, cfg.base
    jt, spec, frac = tol.joint, tol.spec, tol.budget.joint_fraction
    dists = distributions(tol, base)
    U = np.random.default_rng(jt.seed).random((jt.n, len(dists)))
    X = en05.to_inputs(dists, U)
    rows, nom, check = _rows(
        cfg, model, models, [x.key for x in dists], X, "joint",
        lambda Y: {"final_angle_error": frac * spec.angle_deg,
                   "final_radius_error": frac * spec.radius_m})
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
    if check is not None:
        ds.attrs["accuracy_note"] = ("surface_work is recorded but not budgeted here: the "
                                     "fraction within spec does not use it")
    ds.attrs.update({**_common_attrs(cfg, "joint", nom), **_check_attrs(check), "n": jt.n,
                     "seed": jt.seed,
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
