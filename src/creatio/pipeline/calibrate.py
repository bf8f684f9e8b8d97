"""`creatio calibrate`: fit a study's parameters to a measured track (docs/model.md s.13.2).

    creatio calibrate study=en02 track=track.csv 'fit=[sphere.mu,sphere.eps]' [KEY=VALUE ...]

``study``, ``track`` and ``fit`` are the command's own; ``noise=`` states the camera's noise
(m per coordinate) when the track does not, ``out=`` the output directory, ``start=[...]``
the first guess (default: the config's values); every other argument is a Hydra override of
the study (``phases.T=10``). A track is a CSV of the frame times and the centre's
coordinates with their units in the header (``t_s,x_m,y_m`` and optionally ``z_m``), after
optional ``# key: value`` lines (``study``, ``noise_m``, ``source``). Every refusal (a
missing column, a unit other than s or m, NaN, times not increasing, off one frame grid or
outside the run, a track of another study) is one line and exit 2, before anything is
written; so is a track whose points lie outside the membrane's annulus (R0 .. R0 + dR, give
or take the sphere's radius), with the unit its numbers look like. The fit stays within each
key's physical range (conf/uncertainty/<study>.yaml): a key whose best fit lies beyond it is
held at the bound (not identifiable when its whole interval lies beyond), and a key not
identifiable comes with what would pin it (EN-05's design of the experiment). The fit
searches on a cheap model (radau5 at the loosest tolerance whose error is within 1e-2 of the
noise, with one Jacobian reused), then polishes on the study's own solver; the model error,
checked at the estimate 100x tighter, is recorded ("numerical error <= X (budget Y, checked on
N points)"). Output
(default ``data/calibration/<track name>-<hash>/``): ``calibration.nc``, ``.json`` (the
record `creatio ls` lists), ``.md`` and ``.png`` (creatio.reports.calibration).
"""

from __future__ import annotations

import csv
import hashlib
import logging
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from creatio.errors import ConfigError
from creatio.pipeline.config import CONF_DIR, Resolved, resolve

__all__ = ["EXAMPLE_TRACK", "bounded_fit", "calibrate", "check_annulus", "design_pointer", "main",
           "read_track", "unit_of", "write_example_track"]

log = logging.getLogger("creatio")

#: The committed synthetic example track (made by the model: `creatio task en05 track`).
EXAMPLE_TRACK = Path(__file__).resolve().parents[3] / "examples" / "tracks" / "en02_synthetic.csv"
#: The overrides of EN-02 the example track was made with (its cycle).
EXAMPLE_OVERRIDES = ("phases.T=10.0",)
#: Column names and their units: time in seconds, coordinates in metres.
UNITS = {"t": "s", "x": "m", "y": "m", "z": "m"}
#: Units of the keys a calibration may fit, as its tables print them (1: dimensionless).
KEY_UNITS = {"sphere.mu": "1", "sphere.eps": "m/s", "sphere.b": "m", "sphere.m": "kg",
             "sphere.g": "m/s^2", "phases.T": "s", "study.duration": "s", "geometry.A": "m",
             "geometry.R0": "m", "geometry.dR": "m"}
#: Scales a track in another unit needs to be in metres, by the unit's name.
SCALES = (("millimetres", 1e-3), ("centimetres", 1e-2), ("kilometres", 1e3))
#: EN-05's report (its design of the experiment says which cycle lengths pin mu).
EN05_REPORT = Path("data") / "reports" / "en05.json"


class TrackError(ConfigError):
    """A track the calibration refuses (one line: the file, what and why)."""

    def __init__(self, path: Path | str, rule: str) -> None:
        super().__init__("track", str(path), rule)


def read_track(path: Path | str, study: str, duration: float) -> Any:
    """Read and check a track CSV for a run of ``study`` lasting ``duration`` seconds."""
    from creatio.studies.en05 import Track, frame_grid

    path = Path(path)
    if not path.is_file():
        raise TrackError(path, "no such file")
    meta: dict[str, str] = {}
    rows: list[list[str]] = []
    header: list[str] | None = None
    with path.open(newline="") as fh:
        for line_no, row in enumerate(csv.reader(fh), start=1):
            if not row or not "".join(row).strip():
                continue
            if row[0].lstrip().startswith("#"):
                key, sep, value = ",".join(row).lstrip("# ").partition(":")
                if sep:
                    meta[key.strip()] = value.strip()
                continue
            if header is None:
                header = [c.strip() for c in row]
                continue
            if len(row) != len(header):
                raise TrackError(path, f"line {line_no} has {len(row)} fields for "
                                 f"{len(header)} columns")
            rows.append(row)
    if header is None:
        raise TrackError(path, "has no header line (t_s,x_m,y_m[,z_m])")
    columns: dict[str, int] = {}
    for i, name in enumerate(header):
        quantity, _, unit = name.partition("_")
        if quantity not in UNITS:
            raise TrackError(path, f"column {name!r} is not one of t_s, x_m, y_m, z_m")
        if unit != UNITS[quantity]:
            raise TrackError(path, f"column {name!r}: {quantity} must be in "
                             f"{'seconds' if quantity == 't' else 'metres'} "
                             f"({quantity}_{UNITS[quantity]})")
        if quantity in columns:
            raise TrackError(path, f"column {name!r} appears twice")
        columns[quantity] = i
    for needed in ("t", "x", "y"):
        if needed not in columns:
            raise TrackError(path, f"missing column {needed}_{UNITS[needed]}")
    if meta.get("study") and meta["study"] != study:
        raise TrackError(path, f"is a track of study {meta['study']}, not {study}")
    if len(rows) < 3:
        raise TrackError(path, f"has {len(rows)} rows: a fit needs at least 3")
    data = np.empty((len(rows), len(columns)))
    order = [q for q in "txyz" if q in columns]
    for r, row in enumerate(rows):
        for c, q in enumerate(order):
            text = row[columns[q]].strip()
            try:
                value = float(text)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise TrackError(path, f"row {r + 1}, column {header[columns[q]]}: {text!r} is "
                                 "not a finite number")
            data[r, c] = value
    t = data[:, 0]
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        i = int(bad[0]) + 1
        raise TrackError(path, f"times must increase: row {i + 1} has t = {t[i]:g} s after "
                         f"{t[i - 1]:g} s")
    if t[0] < 0.0 or t[-1] > duration * (1.0 + 1e-12):
        raise TrackError(path, f"times [{t[0]:g}, {t[-1]:g}] s lie outside the run "
                         f"[0, {duration:g}] s of {study}")
    try:
        frame_grid(t)
    except ValueError as e:
        raise TrackError(path, str(e)) from None
    noise = math.nan
    if "noise_m" in meta:
        try:
            noise = float(meta["noise_m"])
        except ValueError:
            noise = math.nan
        if not (math.isfinite(noise) and noise > 0.0):
            raise TrackError(path, f"noise_m = {meta['noise_m']!r} must be a number > 0 (m)")
    coords = tuple(q for q in order if q != "t")
    return Track(t, data[:, 1:], coords, noise, meta.get("study", ""), meta.get("source", ""))


def unit_of(key: str) -> str:
    """The unit of a fitted config key as tables print it (so no number goes without one)."""
    return KEY_UNITS.get(key, "config units")


def _unit_suffix(key: str) -> str:
    """" m/s" after a number of the key, nothing after a dimensionless one."""
    unit = unit_of(key)
    return "" if unit == "1" else f" {unit}"


def check_annulus(cfg: Any, track: Any, path: Path | str) -> None:
    """Refuse a track whose points lie outside the membrane's annulus R0 .. R0 + dR by more
    than the sphere's radius (a track in other units), saying which unit they look like."""
    cols = list(track.coordinates)
    if "x" not in cols or "y" not in cols:
        return
    r = np.hypot(track.xyz[:, cols.index("x")], track.xyz[:, cols.index("y")])
    g, b = cfg.geometry, float(cfg.sphere.b)
    inner, outer = float(g.R0), float(g.R0 + g.dR)
    off = (r < inner - b) | (r > outer + b)
    if not off.any():
        return
    typical = float(np.median(r[off]))
    hint = "they do not look like metres of this geometry, nor mm, cm or km"
    for name, scale in SCALES:
        if inner - b <= typical * scale <= outer + b:
            hint = (f"they look like {name} (x 1e{round(math.log10(scale))} puts them in "
                    "the annulus)")
            break
    raise TrackError(path, f"{int(off.sum())} of {r.size} points lie outside the membrane's "
                     f"annulus [{inner:g}, {outer:g}] m (R0 .. R0 + dR, +- the sphere's radius "
                     f"{b:g} m): the points lie ~{typical:.3g} m from the centre; {hint}")


def bounded_fit(cfg: Any, track: Any, keys: Sequence[str], start: Sequence[float] | None,
                ranges: dict[str, tuple[float, float]]
                ) -> tuple[Any, dict[str, tuple[float, float]]]:
    """EN-05's least-squares fit kept within each key's physical range (an active set): a
    key whose best fit lies beyond its range is held at the bound it crosses and the others
    refitted, so no estimate outside the range is reported. A held key keeps the part of its
    unconstrained interval inside the range (the track agrees with the bound); when none
    is, it is not identifiable within its range. Returns the fit of all keys and each held
    key's unconstrained (estimate, stderr): what the track pointed to, not an estimate."""
    from creatio.studies.en05 import Fit, fit_track, model_centre
    from creatio.studies.schema import vary

    keys = list(keys)
    first = fit_track(cfg, track, keys, start, ranges)
    fit: Any = first
    held: dict[str, float] = {}
    beyond: dict[str, tuple[float, float]] = {}
    kept: dict[str, tuple[np.ndarray, str | None]] = {}
    evaluations, rhs = first.evaluations, first.rhs_evals
    while True:
        out = [j for j, (k, x) in enumerate(zip(fit.keys, fit.estimate, strict=True))
               if k in ranges and not ranges[k][0] <= x <= ranges[k][1]]
        if not out:
            break
        for j in out:
            k, x = fit.keys[j], float(fit.estimate[j])
            held[k] = ranges[k][0] if x < ranges[k][0] else ranges[k][1]
            beyond[k] = (x, float(fit.stderr[j]))
            kept[k] = (fit.interval[j].copy(), fit.flags.get(k))
        changes: dict[str, Any] = {**held, "solver.allow_unstable": True}
        if "phases.T" in held:  # study.duration follows phases.T (studies.en05._link)
            changes["study.duration"] = held["phases.T"]
        fixed = vary(cfg, changes)
        free = [k for k in keys if k not in held]
        if not free:
            fit = None
            break
        guess = [min(max(float(x), ranges[k][0]), ranges[k][1]) if k in ranges else float(x)
                 for k, x in zip(fit.keys, fit.estimate, strict=True) if k in free]
        fit = fit_track(fixed, track, free, guess, ranges,
                        rung=first.verification.rung if first.verification else None)
        evaluations += fit.evaluations
        rhs += fit.rhs_evals
    if not held:
        return first, {}
    p = len(keys)
    estimate = np.array([held.get(k, math.nan) for k in keys])
    stderr, ival = np.full(p, math.nan), np.full((p, 2), math.nan)
    corr = np.full((p, p), math.nan)
    flags = {}
    for k, (x, se) in beyond.items():
        (a, b), why = kept[k]
        lo, hi = ranges[k]
        j = keys.index(k)
        if why:
            flags[k] = why
        elif max(a, lo) <= min(b, hi):
            ival[j] = (max(a, lo), min(b, hi))
        else:
            flags[k] = (f"not identifiable within its physical range [{lo:g}, {hi:g}]"
                        f"{_unit_suffix(k)}: the track's best fit lies "
                        f"{'below' if x < lo else 'above'} it (unconstrained {x:.3g} +- "
                        f"{se:.2g}, its 95 % interval outside the range); held at the bound "
                        f"{held[k]:g}")
    if fit is not None:
        idx = [keys.index(k) for k in fit.keys]
        estimate[idx], stderr[idx], ival[idx] = fit.estimate, fit.stderr, fit.interval
        corr[np.ix_(idx, idx)] = fit.correlation
        flags.update(fit.flags)
        M, r, status, carried = fit.model, fit.residuals, fit.status, fit.carried
        s2, dof, condition, message = fit.s2, fit.dof, fit.condition, fit.optimizer
    else:
        interval, frames = track.grid()
        cols = ["xyz".index(c) for c in track.coordinates]
        X, status, carried = model_centre(fixed, interval, frames)
        M = X[:, cols]
        r = M - track.xyz
        dof = r.size
        s2, condition, message = float(np.sum(r * r) / dof), math.nan, "every key held"
    return Fit(keys, first.start, estimate, stderr, ival, corr, r, M,
               float(np.sqrt(np.mean(r * r))), s2, dof, condition, status, carried,
               evaluations, message, {k: flags[k] for k in keys if k in flags},
               fit.verification if fit is not None and fit.verification else first.verification,
               rhs), beyond


def design_pointer(report: Path = EN05_REPORT) -> str:
    """What would pin mu: the cycle lengths EN-05's design of the experiment found (from its
    report when built, else the command that computes them)."""
    import json

    what = "EN-05's design of the experiment (Cramer-Rao sigma_mu against the cycle length T)"
    try:
        des = json.loads(report.read_text())["design"]
        pins = des["pins_mu_to_0_01"]
        noise, rate, target = des["camera_noise_m"], des["camera_hz"], des["target"]
    except (OSError, ValueError, KeyError, TypeError):
        return (f"what would pin it: {what}, which cycle lengths pin mu; not built here: "
                f"`snakemake en05 -c 2` computes it ({report}, design.pins_mu_to_0_01)")
    cycles = "; ".join(f"mu = {mu}: T = {', '.join(f'{t:g}' for t in Ts)} s" if Ts
                       else f"mu = {mu}: no cycle" for mu, Ts in pins.items())
    return (f"what would pin it: a track of the cycle lengths that pin mu to +-{target:g} "
            f"with a {noise * 1e3:g} mm, {rate:g} Hz camera, {cycles} ({what}, {report})")


def _ranges(study: str) -> dict[str, tuple[float, float]]:
    """The physical ranges of a study's uncertain inputs (conf/uncertainty/<study>.yaml)."""
    from omegaconf import OmegaConf

    from creatio.studies.en05 import physical_ranges
    from creatio.studies.en05_schema import UncertaintyConfig

    path = CONF_DIR / "uncertainty" / f"{study}.yaml"
    if not path.is_file():
        return {}
    unc = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(UncertaintyConfig),
                                              OmegaConf.load(path)))
    return physical_ranges(unc.inputs)


def _parse(args: Sequence[str]) -> dict[str, Any]:
    """The command's own arguments and the study's overrides."""
    own: dict[str, Any] = {"study": "en02", "track": None, "fit": None, "noise": None,
                           "out": None, "start": None}
    overrides = []
    for a in args:
        key, sep, value = a.partition("=")
        if not sep:
            raise ConfigError(a, "", "an argument is KEY=VALUE (study=, track=, fit=[...], "
                              "noise=, out=, start=[...], or a Hydra override)")
        if key in own:
            own[key] = value
        else:
            overrides.append(a)
    if own["track"] is None:
        raise ConfigError("track", "", "needs the track CSV: track=path/to/track.csv")
    for key in ("fit", "start"):
        if own[key] is not None:
            own[key] = [v.strip() for v in own[key].strip().strip("[]").split(",") if v.strip()]
    own["overrides"] = overrides
    return own


def _float(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise ConfigError(key, text, "must be a number > 0")
    return value


def calibrate(args: Sequence[str]) -> dict[str, Path]:
    """Run `creatio calibrate` with its arguments; return the files written."""
    from creatio.reports.calibration import write_calibration_report
    from creatio.store.netcdf import write_dataset

    own = _parse(args)
    resolved: Resolved = resolve(own["study"], own["overrides"])
    cfg = resolved.obj
    if resolved.entry.kind.name != "sphere" or not hasattr(cfg, "sphere_problem"):
        raise ConfigError("study", own["study"], "must be a sphere study (en02, en02r, ...)")
    keys = own["fit"] or ["sphere.mu", "sphere.eps"]
    for k in keys:
        node: Any = cfg
        for part in k.split("."):
            node = getattr(node, part, None)
        if not isinstance(node, float):
            raise ConfigError("fit", k, f"must name a number of {own['study']}'s config "
                              "(sphere.mu, sphere.eps, sphere.b, geometry.A, ...)")
    track = read_track(own["track"], own["study"], cfg.study.duration)
    noise = _float("noise", own["noise"]) if own["noise"] is not None else track.noise_m
    start = None
    if own["start"] is not None:
        if len(own["start"]) != len(keys):
            raise ConfigError("start", own["start"], f"needs one value per key of fit {keys}")
        start = [_float("start", v) for v in own["start"]]
    check_annulus(cfg, track, own["track"])
    interval, frames = track.grid()
    sampled = _sampled(cfg, interval)
    ranges = _ranges(own["study"])
    fit, beyond = bounded_fit(sampled, track, keys, start, ranges)
    digest = hashlib.sha256("\0".join([resolved.sha256, Path(own["track"]).read_text(),
                                       *keys, str(noise), str(start)]).encode()).hexdigest()
    out = Path(own["out"]) if own["out"] else (
        Path("data") / "calibration" / f"{Path(own['track']).stem}-{digest[:12]}")
    ds = _dataset(resolved, track, fit, noise, own["track"], ranges, beyond)
    for j, k in enumerate(fit.keys):
        held = " (held at the bound of its physical range)" if k in beyond else ""
        log.info("%s = %.4g%s%s", k, fit.estimate[j], _unit_suffix(k), held)
    if fit.verification:
        log.info("model: %s", fit.verification.describe())
    for k, why in fit.flags.items():
        log.warning("%s: %s", k, why)
    if fit.flags:
        ds.attrs["next_step"] = design_pointer()
        log.warning("%s", ds.attrs["next_step"])

    paths = {"nc": write_dataset(ds, out / "calibration.nc")}
    paths.update(write_calibration_report(ds, out))
    return paths


def _sampled(cfg: Any, interval: float) -> Any:
    """The study's config sampled on the track's frame grid (dense output), its step lifted
    from the config's stability check (the fit refines it to each trial's limit)."""
    from creatio.studies.schema import vary

    return vary(cfg, {"solver.dense_output": True, "solver.output_interval": interval,
                      "solver.allow_unstable": True})


def _dataset(resolved: Resolved, track: Any, fit: Any, noise: float, source: str,
             ranges: dict[str, tuple[float, float]],
             beyond: dict[str, tuple[float, float]]) -> Any:
    """The calibration dataset: track, model, residuals, estimates and their statistics,
    each key's unit and physical range, the keys held at a bound."""
    import xarray as xr

    from creatio.pipeline.provenance import provenance

    dims = ("frame", "coordinate")
    ds = xr.Dataset({
        "track": (dims, track.xyz, {"long_name": "measured centre", "units": "m"}),
        "model": (dims, fit.model, {"long_name": "model centre at the estimate", "units": "m"}),
        "residual": (dims, fit.residuals, {"long_name": "model - track", "units": "m"}),
        "start": (("parameter",), fit.start, {"long_name": "first guess (in the unit of "
                                              "each parameter)"}),
        "estimate": (("parameter",), fit.estimate, {"long_name": "estimate (in the unit of "
                                                    "each parameter)"}),
        "stderr": (("parameter",), fit.stderr,
                   {"long_name": "standard error from s^2 (J^T J)^-1"}),
        "interval_95": (("parameter", "bound"), fit.interval, {"long_name": "95 % interval"}),
        "correlation": (("parameter", "parameter2"), fit.correlation, {"units": "1"}),
        "physical_range": (("parameter", "bound"),
                           np.array([ranges.get(k, (math.nan, math.nan)) for k in fit.keys],
                                    float).reshape(-1, 2),
                           {"long_name": "physical range (conf/uncertainty), NaN: none"}),
        "at_bound": (("parameter",), np.array([k in beyond for k in fit.keys], np.int8),
                     {"long_name": "1 where the best fit lies beyond the range: held at "
                      "the bound", "units": "1"}),
        "unconstrained": (("parameter",),
                          np.array([beyond.get(k, (math.nan, math.nan))[0] for k in fit.keys]),
                          {"long_name": "where the fit of a held key went beyond its range "
                           "(NaN: not held), not an estimate"}),
        "unconstrained_stderr": (("parameter",),
                                 np.array([beyond.get(k, (math.nan, math.nan))[1]
                                           for k in fit.keys]),
                                 {"long_name": "its standard error (NaN: not held)"}),
    }, coords={"time": ("frame", track.t, {"units": "s"}),
               "coordinate": ("coordinate", list(track.coordinates)),
               "parameter": ("parameter", list(fit.keys)),
               "unit": ("parameter", [unit_of(k) for k in fit.keys]),
               "parameter2": ("parameter2", list(fit.keys)), "bound": ("bound", ["low", "high"])})
    title = f"calibration of {resolved.id} to {Path(source).name}"
    ds.attrs = {**provenance(resolved.id, resolved.yaml, resolved.sha256, title),
                "track_file": str(source), "track_source": track.source,
                "noise_m": noise, "residual_rms_m": fit.residual_rms_m,
                "s2": fit.s2, "dof": fit.dof, "condition": fit.condition,
                "status": fit.status, "carried": int(fit.carried),
                "evaluations": fit.evaluations, "rhs_evals": fit.rhs_evals,
                "optimizer": fit.optimizer,
                **(fit.verification.attrs() if fit.verification else {}),
                "flags": "\n".join(f"{k}: {v}" for k, v in fit.flags.items())}
    return ds


def write_example_track(resolved: Resolved, out: Path | None = None) -> Path:
    """The synthetic example track of EN-05's calibration settings (the model at the truth
    on EN-02 with EN05's cycle, the camera's frames within the window, noise of the example
    seed), written as a track CSV that says what it is."""
    from creatio.store.atomic import atomic_write
    from creatio.studies.en05 import synthetic_track, truth_config

    cfg = resolved.obj
    cal, cam = cfg.study.calibration, cfg.study.camera
    track = synthetic_track(truth_config(cfg), cam, cal.window_s, cal.example_seed)
    truth = " ".join(f"{k}={v!r}" for k, v in zip(cal.fit, cal.truth, strict=True))
    out = Path(out) if out else EXAMPLE_TRACK
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(out) as fh:
        fh.write("# SYNTHETIC track, made by the model, not a measurement: EN-02 at "
                 f"{truth} phases.T={cal.cycle_s!r}, the centre every 1/{cam.rate_hz:g} s "
                 f"over [{cal.window_s[0]:g}, {cal.window_s[1]:g}] s plus Gaussian noise of "
                 f"{cam.noise_m:g} m per coordinate (seed {cal.example_seed})\n")
        fh.write("# made by: creatio task en05 track (from conf/study/en05.yaml)\n")
        fh.write(f"# study: {cfg.uncertainty.study}\n")
        fh.write(f"# noise_m: {cam.noise_m!r}\n")
        fh.write(f"# source: synthetic, model at {truth} phases.T={cal.cycle_s!r}, "
                 f"seed {cal.example_seed}\n")
        fh.write(",".join(["t_s", *(f"{c}_m" for c in track.coordinates)]) + "\n")
        for t, row in zip(track.t, track.xyz, strict=True):
            fh.write(",".join([repr(float(t)), *(repr(float(v)) for v in row)]) + "\n")
    return out


def main(argv: Sequence[str]) -> int:
    """Entry point of `creatio calibrate`: one line and exit 2 for anything refused."""
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__.split("\n\n", 1)[1].split("\n\n")[0].strip())
        print("\n" + __doc__.split("\n\n", 2)[2].strip())
        return 0
    try:
        paths = calibrate(argv)
    except ConfigError as e:
        print(f"creatio calibrate: {e}", file=sys.stderr)
        return 2
    log.info("calibration: %s", ", ".join(str(p) for p in paths.values()))
    return 0
