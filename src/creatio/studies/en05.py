"""EN-05: which inputs matter, fitting the model to a track, which test pins mu (docs/studies.md,
docs/model.md s.13).

* Sensitivity (s.13.1): a Sobol' design of the uncertain inputs (SALib's Saltelli sample on
  the unit cube, mapped through each input's inverse CDF), the EN-05 outputs of each run
  (:func:`run_outputs`), and first-order and total indices with bootstrap intervals
  (SALib's estimators, :func:`sobol_indices`). The runs themselves go through the pipeline's
  batched point machinery; :func:`sobol_dataset` turns their rows into the indices. The same
  two functions compute the Ishigami check (:func:`ishigami_dataset`).
* Calibration (s.13.2): the model sampled at a track's frame times (dense output on the
  frame grid), scipy's least_squares on the centre residuals, the Gauss-Newton covariance
  s^2 (J^T J)^-1 with J from central differences at the estimate (:func:`fit_track`); the
  synthetic round trip and its coverage over noise seeds (:func:`calibration_dataset`).
* Design of the experiment (s.13.3): the Cramer-Rao sigma_mu over cycle length and mu,
  from central differences of two runs at two step sizes (:func:`experiment_dataset`).

Parts of the study (creatio.studies.registry): ``en05_ishigami``, ``en05_calibration``,
``en05_experiment``; the Sobol' sample's dataset ``en05_sobol`` is made by the pipeline from
the batch files (creatio.pipeline.points).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from creatio.dynamics import SphereProblem, simulate, stability_limit
from creatio.errors import ConfigError
from creatio.studies.en05_schema import (
    BASE,
    CameraConfig,
    Dist,
    En05Config,
    InputDistribution,
)
from creatio.studies.registry import Part
from creatio.studies.schema import DynamicConfig, vary

__all__ = [
    "KINEMATIC_OUTPUTS",
    "OUTPUTS",
    "Fit",
    "Track",
    "calibration_dataset",
    "cramer_rao",
    "cycle_config",
    "experiment_dataset",
    "fit_track",
    "frame_grid",
    "ishigami",
    "ishigami_closed_form",
    "ishigami_dataset",
    "model_centre",
    "parts",
    "physical_ranges",
    "point_outputs",
    "run",
    "run_outputs",
    "sampled_problem",
    "sobol_dataset",
    "sobol_design",
    "sobol_indices",
    "synthetic_track",
    "to_inputs",
    "truth_config",
    "window_frames",
]

#: EN-05's outputs of one run (docs/model.md s.13.1): name -> (units, description).
OUTPUTS: dict[str, tuple[str, str]] = {
    "final_radius": ("m", "horizontal radius of the centre at the end of the cycle"),
    "max_abs_lag": ("degree", "largest |centre azimuth - pattern angle| (output samples)"),
    "cumulative_spin": ("degree", "integral of |omega| dt over the cycle"),
    "min_normal_ratio": ("1", "min N over all steps / (m g)"),
    "max_slip_speed": ("m s-1", "largest slip speed over all steps"),
    "surface_work": ("J", "work of the membrane on the sphere over the cycle"),
    "carried": ("1", "1 if the run ends ok and the contact never left its cavity's cell"),
}
#: The outputs that are pure kinematics: independent of the mass m (docs/model.md s.13.1).
KINEMATIC_OUTPUTS = ("final_radius", "max_abs_lag", "cumulative_spin", "min_normal_ratio",
                     "max_slip_speed", "carried")


# ------------------------------------------------------------------------- distributions
def to_inputs(inputs: Sequence[InputDistribution], U: np.ndarray) -> np.ndarray:
    """Map points of the unit cube (n x d, column j for ``inputs[j]``) to input values
    through each distribution's inverse CDF (scipy.stats)."""
    from scipy import stats

    U = np.atleast_2d(np.asarray(U, float))
    X = np.empty_like(U)
    for j, d in enumerate(inputs):
        u = U[:, j]
        if d.dist is Dist.uniform:
            X[:, j] = d.low + (d.high - d.low) * u
        elif d.dist is Dist.loguniform:
            X[:, j] = stats.loguniform.ppf(u, d.low, d.high)
        elif d.dist is Dist.normal:
            X[:, j] = stats.norm.ppf(u, loc=d.mean, scale=d.sd)
        else:
            a, b = (d.low - d.mean) / d.sd, (d.high - d.mean) / d.sd
            X[:, j] = stats.truncnorm.ppf(u, a, b, loc=d.mean, scale=d.sd)
    return X


def physical_ranges(inputs: Mapping[str, InputDistribution]) -> dict[str, tuple[float, float]]:
    """Config key -> the range its distribution covers (a normal's: mean +- 3 sd), the
    width a fitted interval is compared with (docs/model.md s.13.2)."""
    out = {}
    for d in inputs.values():
        lo, hi = d.support()
        if d.dist is Dist.normal:
            lo, hi = d.mean - 3.0 * d.sd, d.mean + 3.0 * d.sd
        out[d.key] = (float(lo), float(hi))
    return out


# ------------------------------------------------------------------------- sensitivity
def _unit_problem(names: Sequence[str]) -> dict[str, Any]:
    return {"num_vars": len(names), "names": list(names), "bounds": [[0.0, 1.0]] * len(names)}


def sobol_design(names: Sequence[str], N: int, seed: int) -> np.ndarray:
    """Saltelli's sample of N base points for first-order and total indices (N (d + 2)
    points of the unit cube, SALib.sample.sobol with Owen scrambling seeded by ``seed``).
    The design of N is the first N (d + 2) rows of the design of any larger N."""
    from SALib.sample import sobol

    return sobol.sample(_unit_problem(names), N, calc_second_order=False, scramble=True,
                        seed=seed)


def sobol_indices(names: Sequence[str], Y: np.ndarray, resamples: int, confidence: float,
                  seed: int) -> dict[str, dict[str, float]]:
    """First-order and total indices of Y (the outputs of :func:`sobol_design`'s rows) and
    their bootstrap half-widths at ``confidence`` (SALib.analyze.sobol: Saltelli 2010's
    first-order and Jansen's total estimator)."""
    from SALib.analyze import sobol

    Y = np.asarray(Y, float)
    si = sobol.analyze(_unit_problem(names), Y, calc_second_order=False,
                       num_resamples=resamples, conf_level=confidence, seed=seed)
    return {key: {n: float(v) for n, v in zip(names, si[key], strict=True)}
            for key in ("S1", "ST", "S1_conf", "ST_conf")}


def run_outputs(ds: Any, m: float, g: float) -> dict[str, float]:
    """EN-05's outputs of one run's EN-02 dataset (:data:`OUTPUTS`): NaN for a run that did
    not end ok (it produced no end-of-cycle figure), except ``carried`` (0 then)."""
    a = ds.attrs
    ok = str(a["status"]) == "ok"
    carried = float(ok and int(a["carried"]) == 1)
    if not ok:
        return {**{name: math.nan for name in OUTPUTS}, "carried": carried}
    return {
        "final_radius": float(ds.centre_radius.values[-1]),
        "max_abs_lag": float(np.max(np.abs(ds.angular_lag.values))),
        "cumulative_spin": float(ds.cumulative_spin.values[-1]),
        "min_normal_ratio": float(a["min_normal_reaction"]) / (m * g),
        "max_slip_speed": float(a["max_slip_speed"]),
        "surface_work": float(ds.surface_work.values[-1]),
        "carried": carried,
    }


def point_outputs(ds: Any, cfg: DynamicConfig) -> dict[str, float]:
    """:func:`run_outputs` of one point of the sample (its config gives m and g): the figures
    each batch row keeps (creatio.pipeline.points)."""
    return run_outputs(ds, cfg.sphere.m, cfg.sphere.g)


def sobol_dataset(cfg: En05Config, rows: Mapping[str, np.ndarray]) -> Any:
    """The Sobol' dataset of EN-05 from the sample's rows (every design point of the
    largest N, in design order): inputs, outputs and status per point, and per base size
    N and output the indices with their intervals, computed only when every run of that
    design produced the output (else the count of runs that did not)."""
    import xarray as xr

    sens = cfg.study.sensitivity
    names = cfg.uncertainty.names
    d = len(names)
    n_max = max(sens.base_sizes)
    U = sobol_design(names, n_max, sens.seed)
    X = to_inputs(cfg.uncertainty.distributions, U)
    n = n_max * (d + 2)
    status = np.asarray(rows["status"]).astype(str)
    if status.size != n:
        raise ValueError(f"the sample has {status.size} rows, its design {n}")
    sizes = np.array(sens.base_sizes)
    shape = (sizes.size, len(OUTPUTS), d)
    out = {k: np.full(shape, np.nan) for k in ("S1", "ST", "S1_conf", "ST_conf")}
    runs_missing = np.zeros((sizes.size, len(OUTPUTS)), dtype=np.int64)
    not_ok = np.zeros(sizes.size, dtype=np.int64)
    for i, N in enumerate(sizes):
        rows_n = int(N) * (d + 2)
        not_ok[i] = int(np.sum(status[:rows_n] != "ok"))
        for j, name in enumerate(OUTPUTS):
            y = np.asarray(rows[name], float)[:rows_n]
            runs_missing[i, j] = int(np.sum(~np.isfinite(y)))
            if runs_missing[i, j] or np.ptp(y) == 0.0:
                continue
            si = sobol_indices(names, y, sens.resamples, sens.confidence, sens.seed)
            for key in out:
                out[key][i, j] = [si[key][nm] for nm in names]
    dims = ("base_size", "output", "input")
    point = ("point",)
    data: dict[str, Any] = {
        k: (dims, v, {"long_name": {"S1": "first-order Sobol' index", "ST": "total Sobol' index",
                                    "S1_conf": "bootstrap half-width of S1",
                                    "ST_conf": "bootstrap half-width of ST"}[k], "units": "1"})
        for k, v in out.items()}
    data["runs_missing"] = (("base_size", "output"), runs_missing,
                            {"long_name": "runs of the design that did not produce the output",
                             "units": "1"})
    data["runs_not_ok"] = (("base_size",), not_ok,
                           {"long_name": "runs of the design that did not end ok", "units": "1"})
    data["runs"] = (("base_size",), sizes * (d + 2),
                    {"long_name": "runs of the design, N (d + 2)", "units": "1"})
    data["unit_sample"] = (("point", "input"), U,
                           {"long_name": "design point in the unit cube", "units": "1"})
    data["input_value"] = (("point", "input"), X, {"long_name": "input value of the point"})
    for name, (units, what) in OUTPUTS.items():
        data[name] = (point, np.asarray(rows[name], float), {"long_name": what, "units": units})
    data["status"] = (point, status, {"long_name": "run status"})
    ds = xr.Dataset(data, coords={
        "base_size": ("base_size", sizes, {"long_name": "Sobol' base sample N", "units": "1"}),
        "output": ("output", list(OUTPUTS)),
        "input": ("input", names),
        "input_key": ("input", [cfg.uncertainty.inputs[n].key for n in names]),
        "point": ("point", np.arange(n)),
    })
    carried = np.asarray(rows["carried"], float)
    ds.attrs.update({
        "carried_fraction": float(np.mean(carried)),
        "carried_runs": int(np.sum(carried)),
        "seed": sens.seed,
        "resamples": sens.resamples,
        "confidence": sens.confidence,
        "sample_overrides": " ".join(sens.overrides),
        "comment": "indices of an output are NaN where some run of that design did not "
                   "produce it (runs_missing) or it is constant over the design",
    })
    return ds


# --------------------------------------------------------------------------- Ishigami
def ishigami(X: np.ndarray, a: float, b: float) -> np.ndarray:
    """The Ishigami function sin x1 + a sin^2 x2 + b x3^4 sin x1 on [-pi, pi]^3."""
    return np.sin(X[:, 0]) + a * np.sin(X[:, 1]) ** 2 + b * X[:, 2] ** 4 * np.sin(X[:, 0])


def ishigami_closed_form(a: float, b: float) -> dict[str, list[float]]:
    """Closed-form first-order and total indices of the Ishigami function (uniform inputs on
    [-pi, pi]): V1 = (1 + b pi^4 / 5)^2 / 2, V2 = a^2 / 8, V13 = 8 b^2 pi^8 / 225,
    V = V1 + V2 + V13."""
    pi4 = math.pi ** 4
    v1 = 0.5 * (1.0 + b * pi4 / 5.0) ** 2
    v2 = a * a / 8.0
    v13 = 8.0 * b * b * pi4 * pi4 / 225.0
    v = v1 + v2 + v13
    return {"S1": [v1 / v, v2 / v, 0.0], "ST": [(v1 + v13) / v, v2 / v, v13 / v]}


def ishigami_dataset(cfg: En05Config) -> Any:
    """The estimator check: Ishigami's indices at every base size, by the same design and
    estimator functions as the model's sample, beside the closed forms."""
    import xarray as xr

    sens = cfg.study.sensitivity
    names = ["x1", "x2", "x3"]
    cube = {n: InputDistribution(key=n, dist=Dist.uniform, low=-math.pi, high=math.pi)
            for n in names}
    sizes = list(sens.base_sizes)
    est = {k: np.empty((len(sizes), 3)) for k in ("S1", "ST", "S1_conf", "ST_conf")}
    for i, N in enumerate(sizes):
        X = to_inputs(list(cube.values()), sobol_design(names, N, sens.seed))
        si = sobol_indices(names, ishigami(X, sens.ishigami_a, sens.ishigami_b),
                           sens.resamples, sens.confidence, sens.seed)
        for k in est:
            est[k][i] = [si[k][n] for n in names]
    exact = ishigami_closed_form(sens.ishigami_a, sens.ishigami_b)
    dims = ("base_size", "input")
    data = {k: (dims, v, {"units": "1"}) for k, v in est.items()}
    data["S1_closed_form"] = (("input",), np.array(exact["S1"]), {"units": "1"})
    data["ST_closed_form"] = (("input",), np.array(exact["ST"]), {"units": "1"})
    ds = xr.Dataset(data, coords={"base_size": ("base_size", np.array(sizes), {"units": "1"}),
                                  "input": ("input", names)})
    ds.attrs.update({"a": sens.ishigami_a, "b": sens.ishigami_b, "seed": sens.seed,
                     "resamples": sens.resamples, "confidence": sens.confidence,
                     "title": "EN-05 Ishigami check of the Sobol' estimators"})
    return ds


# ----------------------------------------------------------------------- sampled model
def frame_grid(t: np.ndarray, tol: float = 1e-6) -> tuple[float, np.ndarray]:
    """(interval, frame numbers) of times on one frame grid t_i = k_i * interval from t = 0
    (dropped frames allowed); ValueError when they are not, to ``tol`` of an interval."""
    t = np.asarray(t, float)
    if t.size < 2:
        raise ValueError("needs at least 2 times")
    gaps = np.diff(t)
    step = float(np.min(gaps))
    k = np.rint(t / step)
    good = k > 0
    interval = float(np.sum(k[good] * t[good]) / np.sum(k[good] ** 2)) if good.any() else step
    k = np.rint(t / interval)
    off = np.max(np.abs(t - k * interval)) / interval
    if off > tol:
        raise ValueError(f"times are not on one frame grid k / rate from t = 0 (a time is "
                         f"{off:.2g} frame intervals off the grid of {interval:.6g} s)")
    return interval, k.astype(np.int64)


def sampled_problem(cfg: DynamicConfig, interval: float, t_end: float) -> SphereProblem:
    """The config's run to t_end, rows every `interval` from each step's dense output, the
    trajectory only (what a camera sees); a fixed step beyond the friction stability limit
    refined to dt / ceil(dt / limit) (so a fit can try any mu and eps)."""
    prob = cfg.sphere_problem().replace(dense_output=True, interval=interval, t_end=t_end,
                                        energy=False, rotation=None, allow_unstable=False)
    dt, limit = prob.solver.dt, stability_limit(prob)
    if dt > limit:
        prob = prob.replace(dt=dt / math.ceil(dt / limit * (1 + 1e-12)))
    return prob


def model_centre(cfg: DynamicConfig, interval: float, frames: np.ndarray
                 ) -> tuple[np.ndarray, str, bool]:
    """The sphere centre (n x 3) of the config's run at times frames * interval (rows past a
    stop are NaN), the run's status and whether it stayed in its cavity."""
    frames = np.asarray(frames, np.int64)
    res = simulate(sampled_problem(cfg, interval, float(frames[-1]) * interval))
    X = np.full((frames.size, 3), np.nan)
    have = frames < res.histories.t.size
    X[have] = res.histories.X[frames[have]]
    return X, res.counts.status, bool(res.carried)


# ----------------------------------------------------------------------------- tracks
@dataclass(frozen=True)
class Track:
    """A measured (or synthetic) track: times (s) and the centre's coordinates (m) per frame,
    the camera's stated noise (m per coordinate, NaN when not stated), the study it is of."""

    t: np.ndarray
    xyz: np.ndarray
    coordinates: tuple[str, ...]
    noise_m: float = math.nan
    study: str = ""
    source: str = ""

    def grid(self) -> tuple[float, np.ndarray]:
        """(frame interval, frame numbers) of the times (:func:`frame_grid`)."""
        return frame_grid(self.t)


def synthetic_track(cfg: DynamicConfig, camera: CameraConfig, window: Sequence[float],
                    seed: int, truth_X: np.ndarray | None = None) -> Track:
    """The model's centre on the camera's frames within window [t0, t1] plus Gaussian noise
    of camera.noise_m per coordinate (numpy's default generator seeded by ``seed``)."""
    frames = window_frames(camera, window)
    X = model_centre(cfg, camera.interval, frames)[0] if truth_X is None else truth_X
    cols = ["xyz".index(c) for c in camera.coordinates]
    rng = np.random.default_rng(seed)
    noisy = X[:, cols] + rng.normal(0.0, camera.noise_m, (frames.size, len(cols)))
    return Track(frames * camera.interval, noisy, tuple(camera.coordinates), camera.noise_m,
                 BASE, f"synthetic, seed {seed}")


def window_frames(camera: CameraConfig, window: Sequence[float]) -> np.ndarray:
    """The camera's frame numbers k (t = k / rate) within the window [t0, t1]."""
    t0, t1 = float(window[0]), float(window[1])
    first = math.ceil(t0 * camera.rate_hz - 1e-9)
    last = math.floor(t1 * camera.rate_hz + 1e-9)
    return np.arange(first, last + 1, dtype=np.int64)


# --------------------------------------------------------------------------------- fit
@dataclass
class Fit:
    """A least-squares fit of config keys to a track (docs/model.md s.13.2)."""

    keys: list[str]
    start: np.ndarray
    estimate: np.ndarray
    stderr: np.ndarray
    interval: np.ndarray            # (p, 2): 95 % (or `confidence`) interval
    correlation: np.ndarray         # (p, p)
    residuals: np.ndarray           # (n, k) model - track at the estimate
    model: np.ndarray               # (n, k) the model's coordinates at the estimate
    residual_rms_m: float
    s2: float
    dof: int
    condition: float                # of J^T J with columns scaled to unit norm
    status: str                     # the run at the estimate
    carried: bool
    evaluations: int
    optimizer: str
    flags: dict[str, str] = field(default_factory=dict)

    def covers(self, truth: Sequence[float]) -> np.ndarray:
        """Whether each interval holds the corresponding true value."""
        t = np.asarray(truth, float)
        return (self.interval[:, 0] <= t) & (t <= self.interval[:, 1])


#: J^T J (columns scaled to unit norm) with a condition number above this is near singular:
#: its inverse then loses more than half of the double-precision digits.
SINGULAR_CONDITION = 1e8


def _link(changes: dict[str, Any]) -> dict[str, Any]:
    """phases.T carries study.duration with it (the only interpolation of the EN-02
    family's configs, study.duration: ${..phases.T})."""
    if "phases.T" in changes:
        changes = {**changes, "study.duration": changes["phases.T"]}
    return changes


def fit_track(cfg: DynamicConfig, track: Track, keys: Sequence[str],
              start: Sequence[float] | None = None,
              ranges: Mapping[str, tuple[float, float]] | None = None,
              confidence: float = 0.95, diff_step: float = 1e-5, scan: int = 5) -> Fit:
    """Fit config keys to a track: scipy's least_squares (trust-region reflective, bounds
    [0, inf)) on the centre residuals at the track's frame times, started from the best of
    ``start`` and a grid of ``scan`` values per key over its physical range (log-spaced where
    the range spans more than a decade: the residuals of a sphere that sticks at one mu and
    slides at another have more than one minimum); the covariance
    s^2 (J^T J)^-1 with s^2 = |r|^2 / (n - p) and J by central differences at the estimate;
    intervals with Student's t; a key is flagged "not identifiable from this track" when its
    interval is wider than its physical range (``ranges``) or J^T J is near singular."""
    from scipy import optimize, stats

    keys = list(keys)
    interval, frames = track.grid()
    cols = ["xyz".index(c) for c in track.coordinates]
    x0 = np.array([float(_get(cfg, k)) for k in keys] if start is None else start, float)
    calls = {"n": 0}
    last: dict[str, Any] = {"X": None}

    def model(x: np.ndarray) -> tuple[np.ndarray, str, bool]:
        calls["n"] += 1
        # the step is refined to the stability limit of each trial (sampled_problem)
        c = vary(cfg, _link({**{k: float(v) for k, v in zip(keys, x, strict=True)},
                            "solver.allow_unstable": True}))
        X, status, carried = model_centre(c, interval, frames)
        return X[:, cols], status, carried

    def residual(x: np.ndarray) -> np.ndarray:
        try:
            M, _, _ = model(x)
        except ConfigError:  # a trial the config refuses: hold the last model (a wall)
            M = last["X"] if last["X"] is not None else np.zeros_like(track.xyz)
        # rows past a stop keep the last computed position: the residual grows, smoothly
        bad = ~np.isfinite(M[:, 0])
        if bad.any() and (~bad).any():
            M = M.copy()
            M[bad] = M[np.flatnonzero(~bad)[-1]]
        elif bad.all():
            M = np.zeros_like(track.xyz)
        last["X"] = M
        return (M - track.xyz).ravel()

    lower = np.zeros(len(keys))
    x0 = np.maximum(x0, 1e-12)
    if scan and ranges and all(k in ranges for k in keys):
        axes = []
        for k in keys:
            lo, hi = ranges[k]
            lo = max(lo, 1e-12)
            axes.append(np.geomspace(lo, hi, scan) if hi > 10 * lo else np.linspace(lo, hi, scan))
        grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(keys), -1).T
        costs = [float(np.sum(residual(x) ** 2)) for x in (x0, *grid)]
        x0 = ([x0, *grid])[int(np.argmin(costs))]
    sol = optimize.least_squares(residual, x0, bounds=(lower, np.full(len(keys), np.inf)),
                                 x_scale=np.abs(x0), diff_step=diff_step, method="trf",
                                 xtol=1e-10, ftol=1e-12, gtol=1e-10)
    x = sol.x
    # the Jacobian at the estimate by central differences (least_squares' own is one-sided)
    J = np.empty((track.xyz.size, len(keys)))
    for j in range(len(keys)):
        h = diff_step * max(abs(x[j]), 1e-12)
        up, dn = x.copy(), x.copy()
        up[j] += h
        dn[j] = max(dn[j] - h, 0.0)
        J[:, j] = (residual(up) - residual(dn)) / (up[j] - dn[j])
    M, status, carried = model(x)
    r = (M - track.xyz)
    n, p = r.size, len(keys)
    dof = max(n - p, 1)
    s2 = float(np.sum(r * r) / dof)
    JtJ = J.T @ J
    norms = np.sqrt(np.diag(JtJ))
    with np.errstate(divide="ignore", invalid="ignore"):
        scaled = JtJ / np.outer(norms, norms)
        condition = float(np.linalg.cond(scaled)) if np.all(norms > 0) else math.inf
    try:
        cov = s2 * np.linalg.inv(JtJ)
    except np.linalg.LinAlgError:
        cov = np.full((p, p), np.inf)
    stderr = np.sqrt(np.abs(np.diag(cov)))
    with np.errstate(divide="ignore", invalid="ignore"):
        corr = cov / np.outer(stderr, stderr)
    q = float(stats.t.ppf(0.5 + confidence / 2.0, dof))
    ival = np.column_stack([x - q * stderr, x + q * stderr])
    flags = {}
    for j, k in enumerate(keys):
        why = []
        if ranges and k in ranges:
            lo, hi = ranges[k]
            if ival[j, 1] - ival[j, 0] > hi - lo:
                why.append(f"its {confidence:.0%} interval ({ival[j, 1] - ival[j, 0]:.3g}) is "
                           f"wider than its physical range [{lo:g}, {hi:g}]")
        if not condition < SINGULAR_CONDITION:
            why.append(f"J^T J is near singular (condition {condition:.3g})")
        if why:
            flags[k] = "not identifiable from this track: " + "; ".join(why)
    return Fit(keys, x0, x, stderr, ival, corr, r, M, float(np.sqrt(np.mean(r * r))), s2, dof,
               condition, status, carried, calls["n"], str(sol.message), flags)


def _get(cfg: Any, key: str) -> Any:
    node = cfg
    for part in key.split("."):
        node = getattr(node, part)
    return node


# ------------------------------------------------------------------- design of experiment
def cramer_rao(cfg: DynamicConfig, camera: CameraConfig, frames: np.ndarray, key: str,
               rel_step: float, others: Sequence[str] = ()) -> dict[str, Any]:
    """The Cramer-Rao sigma of ``key`` for the camera on the frames (docs/model.md s.13.3):
    sigma_cam / sqrt(sum over frames |dX/dkey|^2), dX/dkey by central differences at the
    relative step; with ``others``, also the bound when those keys are unknown too
    (sqrt of the (key, key) entry of sigma_cam^2 (J^T J)^-1). A run whose status is not ok
    or that leaves its cavity makes the bounds NaN and ``lost`` true."""
    cols = ["xyz".index(c) for c in camera.coordinates]
    base = cfg
    _, status, carried = model_centre(base, camera.interval, frames)
    lost = not (status == "ok" and carried)
    columns = []
    for k in (key, *others):
        v = float(_get(base, k))
        h = rel_step * v
        lift = {"solver.allow_unstable": True}  # model_centre refines the step instead
        Xp, sp, cp = model_centre(vary(base, {k: v + h, **lift}), camera.interval, frames)
        Xm, sm, cm = model_centre(vary(base, {k: v - h, **lift}), camera.interval, frames)
        lost = lost or not (sp == "ok" and sm == "ok" and cp and cm)
        columns.append(((Xp - Xm)[:, cols] / (2.0 * h)).ravel())
    if lost:
        return {"sigma": math.nan, "sigma_joint": math.nan, "lost": True, "status": status}
    J = np.column_stack(columns)
    sigma = camera.noise_m / math.sqrt(float(np.sum(J[:, 0] ** 2)))
    joint = math.nan
    if others:
        try:
            joint = camera.noise_m * math.sqrt(float(np.linalg.inv(J.T @ J)[0, 0]))
        except np.linalg.LinAlgError:
            joint = math.inf
    return {"sigma": sigma, "sigma_joint": joint, "lost": False, "status": status}


def cycle_config(cfg: DynamicConfig, camera: CameraConfig, T: float, changes: Mapping[str, float]
           ) -> DynamicConfig:
    """The base on one cycle of length T, sampled on the camera's frame grid."""
    return vary(cfg, {"phases.T": T, "study.duration": T, "solver.dense_output": True,
                      "solver.output_interval": camera.interval, **changes})


def experiment_dataset(cfg: En05Config, progress: Callable[[str], None] | None = None) -> Any:
    """sigma_mu (Cramer-Rao, 1 mm 30 Hz camera by default) over cycle length x mu, at two
    relative steps, with eps also unknown, and which runs lose the sphere; the cycles whose
    bound pins mu to +-target at the confidence level."""
    import xarray as xr
    from scipy import stats

    des, cam = cfg.study.design, cfg.study.camera
    Ts, mus = list(des.cycles_s), list(des.mu)
    shape = (len(mus), len(Ts))
    sigma = {h: np.full(shape, np.nan) for h in des.steps}
    joint = np.full(shape, np.nan)
    lost = np.zeros(shape, dtype=np.int8)
    status = np.full(shape, "", dtype=object)
    for i, mu in enumerate(mus):
        for j, T in enumerate(Ts):
            c = cycle_config(cfg.base, cam, T, {"sphere.mu": mu})
            frames = np.arange(0, math.floor(T * cam.rate_hz + 1e-9) + 1, dtype=np.int64)
            for n, h in enumerate(des.steps):
                r = cramer_rao(c, cam, frames, "sphere.mu", h,
                               others=("sphere.eps",) if n == 0 else ())
                sigma[h][i, j] = r["sigma"]
                if n == 0:
                    joint[i, j] = r["sigma_joint"]
                    status[i, j] = r["status"]
                lost[i, j] |= int(r["lost"])
            if progress:
                progress(f"en05 experiment: mu {mu:g}, T {T:g} s: sigma_mu "
                         f"{sigma[des.steps[0]][i, j]:.3g} ({status[i, j]})")
    z = float(stats.norm.ppf(0.5 + des.confidence / 2.0))
    s0, s1 = sigma[des.steps[0]], sigma[des.steps[1]]
    with np.errstate(invalid="ignore"):
        agree = np.abs(s0 / s1 - 1.0)
        pins = (z * s0 <= des.target) & (lost == 0)
    dims = ("mu", "cycle")
    ds = xr.Dataset({
        "sigma_mu": (dims, s0, {"long_name": "Cramer-Rao standard error of mu (eps known)",
                                "units": "1"}),
        "sigma_mu_check": (dims, s1, {"long_name": f"the same at relative step "
                                      f"{des.steps[1]:g}", "units": "1"}),
        "step_disagreement": (dims, agree, {"long_name": "|sigma_mu / sigma_mu_check - 1|",
                                            "units": "1"}),
        "sigma_mu_eps_unknown": (dims, joint, {"long_name": "Cramer-Rao standard error of mu "
                                               "with eps fitted too", "units": "1"}),
        "lost": (dims, lost, {"long_name": "1 where a run (base or perturbed) does not carry "
                              "the sphere through the cycle", "units": "1"}),
        "status": (dims, status.astype(str), {"long_name": "status of the base run"}),
        "pins_mu": (dims, pins.astype(np.int8), {
            "long_name": f"1 where {z:.3g} sigma_mu <= {des.target:g} on a carried run",
            "units": "1"}),
    }, coords={"mu": ("mu", np.array(mus), {"long_name": "friction coefficient", "units": "1"}),
               "cycle": ("cycle", np.array(Ts), {"long_name": "cycle length T", "units": "s"})})
    ds.attrs.update({"camera_noise_m": cam.noise_m, "camera_hz": cam.rate_hz,
                     "camera_coordinates": " ".join(cam.coordinates),
                     "step": float(des.steps[0]), "check_step": float(des.steps[1]),
                     "target": des.target, "confidence": des.confidence, "z": z,
                     "eps": float(cfg.base.sphere.eps),
                     "title": "EN-05 design of the experiment: Cramer-Rao sigma_mu"})
    return ds


# -------------------------------------------------------------------------- calibration
def truth_config(cfg: En05Config) -> DynamicConfig:
    """EN-02 at the round trip's true values on its cycle, sampled on the camera's frames."""
    cal, cam = cfg.study.calibration, cfg.study.camera
    return cycle_config(cfg.base, cam, cal.cycle_s, dict(zip(cal.fit, cal.truth, strict=True)))


def calibration_dataset(cfg: En05Config, progress: Callable[[str], None] | None = None) -> Any:
    """The synthetic round trip (docs/model.md s.13.2): the model at the truth on the camera's
    frames, noise seed by seed, each track fitted from the base's values; the example seed's
    fit in full; the coverage of the intervals over seeds; the spread of the first key fitted
    alone over spread_seeds seeds beside its Cramer-Rao bound."""
    import xarray as xr

    cal, cam = cfg.study.calibration, cfg.study.camera
    truth_cfg = truth_config(cfg)
    start_cfg = cycle_config(cfg.base, cam, cal.cycle_s, {})
    start = [float(_get(start_cfg, k)) for k in cal.fit]
    frames = window_frames(cam, cal.window_s)
    X_true = model_centre(truth_cfg, cam.interval, frames)[0]
    ranges = physical_ranges(cfg.uncertainty.inputs)
    p = len(cal.fit)
    est = np.full((cal.seeds, p), np.nan)
    err = np.full((cal.seeds, p), np.nan)
    ival = np.full((cal.seeds, p, 2), np.nan)
    rms = np.full(cal.seeds, np.nan)
    evals = np.zeros(cal.seeds, dtype=np.int64)
    example = None
    # the example seed from the base's values, with the scan; the other seeds from the
    # example's estimate (the coverage is a property of the intervals at the minimum)
    order = [cal.example_seed, *[s for s in range(cal.seeds) if s != cal.example_seed]]
    for s in order:
        track = synthetic_track(start_cfg, cam, cal.window_s, s, truth_X=X_true)
        if example is None:
            f = fit_track(start_cfg, track, cal.fit, start, ranges)
        else:
            f = fit_track(start_cfg, track, cal.fit, example[1].estimate, ranges, scan=0)
        est[s], err[s], ival[s], rms[s], evals[s] = (f.estimate, f.stderr, f.interval,
                                                     f.residual_rms_m, f.evaluations)
        if example is None:
            example = (track, f)
        if progress and (s % 20 == 0 or s == cal.seeds - 1):
            progress(f"en05 calibration: seed {s + 1}/{cal.seeds}: {est[s]}")
    covered = (ival[:, :, 0] <= np.array(cal.truth)) & (np.array(cal.truth) <= ival[:, :, 1])
    # the first key alone (the others at the truth): its spread over seeds vs Cramer-Rao
    key = cal.fit[0]
    known = vary(start_cfg, dict(zip(cal.fit[1:], cal.truth[1:], strict=True)))
    alone = np.full(cal.spread_seeds, np.nan)
    for s in range(cal.spread_seeds):
        track = synthetic_track(known, cam, cal.window_s, 100_000 + s, truth_X=X_true)
        alone[s] = fit_track(known, track, [key], [cal.truth[0]], scan=0).estimate[0]
    cr = cramer_rao(truth_cfg, cam, frames, key, cfg.study.design.steps[0])["sigma"]
    track, f = example
    dims = ("frame", "coordinate")
    ds = xr.Dataset({
        "track": (dims, track.xyz, {"long_name": "synthetic track (example seed)", "units": "m"}),
        "model": (dims, f.model, {"long_name": "model at the estimate", "units": "m"}),
        "residual": (dims, f.residuals, {"long_name": "model - track", "units": "m"}),
        "truth_centre": (dims, X_true[:, ["xyz".index(c) for c in cam.coordinates]],
                         {"long_name": "model at the truth, no noise", "units": "m"}),
        "truth": (("parameter",), np.array(cal.truth), {"long_name": "true value"}),
        "start": (("parameter",), np.array(start), {"long_name": "start of every fit"}),
        "estimate": (("parameter",), f.estimate, {"long_name": "example seed's estimate"}),
        "stderr": (("parameter",), f.stderr, {"long_name": "standard error s^2 (J^T J)^-1"}),
        "interval_95": (("parameter", "bound"), f.interval, {"long_name": "95 % interval"}),
        "correlation": (("parameter", "parameter2"), f.correlation, {"units": "1"}),
        "seed_estimate": (("seed", "parameter"), est, {"long_name": "estimate per noise seed"}),
        "seed_stderr": (("seed", "parameter"), err, {"long_name": "standard error per seed"}),
        "seed_interval_95": (("seed", "parameter", "bound"), ival,
                             {"long_name": "95 % interval per seed"}),
        "seed_covered": (("seed", "parameter"), covered.astype(np.int8),
                         {"long_name": "1 where the seed's interval holds the truth",
                          "units": "1"}),
        "seed_residual_rms": (("seed",), rms, {"units": "m"}),
        "seed_evaluations": (("seed",), evals, {"long_name": "model runs of the fit",
                                                "units": "1"}),
        "alone_estimate": (("spread_seed",), alone, {
            "long_name": f"{key} fitted alone (the other keys at the truth) per noise seed"}),
        "coverage_95": (("parameter",), covered.mean(axis=0),
                        {"long_name": "fraction of seeds whose interval holds the truth",
                         "units": "1"}),
    }, coords={"time": ("frame", track.t, {"units": "s"}),
               "coordinate": ("coordinate", list(cam.coordinates)),
               "parameter": ("parameter", list(cal.fit)),
               "parameter2": ("parameter2", list(cal.fit)), "bound": ("bound", ["low", "high"]),
               "seed": ("seed", np.arange(cal.seeds)),
               "spread_seed": ("spread_seed", np.arange(cal.spread_seeds))})
    ds.attrs.update({
        "noise_m": cam.noise_m, "camera_hz": cam.rate_hz, "cycle_s": cal.cycle_s,
        "window_start_s": float(cal.window_s[0]), "window_end_s": float(cal.window_s[1]),
        "example_seed": cal.example_seed,
        "residual_rms_m": f.residual_rms_m, "condition": f.condition, "status": f.status,
        "evaluations": f.evaluations,
        "flags": "; ".join(f"{k}: {v}" for k, v in f.flags.items()),
        "alone_key": key, "alone_spread": float(np.std(alone, ddof=1)),
        "alone_mean": float(np.mean(alone)), "cramer_rao_sigma": float(cr),
        "title": "EN-05 calibration: synthetic round trip and coverage over noise seeds",
    })
    return ds


# ------------------------------------------------------------------------ study parts
def parts(cfg: En05Config) -> list[Part]:
    """EN-05's datasets computed by one job each (the Sobol' sample is the pipeline's)."""
    return [Part("en05_ishigami", {"kind": "ishigami"}),
            Part("en05_calibration", {"kind": "calibration"}),
            Part("en05_experiment", {"kind": "experiment"})]


def run(cfg: En05Config, kind: str) -> Any:
    """One dataset of EN-05 (ishigami, calibration or experiment)."""
    import logging

    say = logging.getLogger("creatio").info
    if kind == "ishigami":
        return ishigami_dataset(cfg)
    if kind == "calibration":
        return calibration_dataset(cfg, say)
    if kind == "experiment":
        return experiment_dataset(cfg, say)
    raise ValueError(f"kind must be ishigami, calibration or experiment, got {kind!r}")
