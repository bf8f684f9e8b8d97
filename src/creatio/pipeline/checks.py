"""Sanity checks of a sphere run's own figures: a run whose checks are absurd never ends ok.

A run carries its own checks: its energy books (kinetic + potential against the work of the
surface and of friction, ``max_energy_residual``) and its convergence partner (the same run
at dt / refine, whose centre should follow it). When these are not merely large but absurd,
nothing the run reports can be trusted, and no report is written from it:

* the output times must increase strictly (a run that stopped at its first output wrote a
  second row at t = 0, and its report failed half way);
* the timestep difference (the largest distance between the centres of the dt and the
  dt / refine run at common times) must stay within the membrane's size, R0 + dR: beyond,
  the two runs do not describe the same motion at all (one RK4 step over a 1 ms cycle: 487 m);
* the energy residual must stay within ENERGY_FACTOR x m g L (g at least 9.81 m/s^2,
  L = R0 + dR): a thousand times the work of lifting the sphere across the whole membrane.
  A resolved run's books balance to ~1e-14 J (the notebook's EN-02), and one of a cycle
  fast enough to approach the bound moves the sphere at km/s; the same 1 ms cycle: 1.8e26 J.
  A residual that is not finite where the run integrated its energy is absurd too.

Nothing here changes a dataset's numbers; a failure is a one-line :class:`ChecksFailed` (the
report step), or the dataset's status ``checks_failed`` with the reason (a dataset, a sweep
point), the run's own status kept beside it as ``run_status``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["ENERGY_FACTOR", "ChecksFailed", "dataset_problems", "mark", "run_problems"]

#: The energy residual's bound in units of m g (R0 + dR) (see the module's docstring).
ENERGY_FACTOR = 1e3
#: The smallest gravity the energy bound uses (m/s^2): microgravity runs keep Earth's scale.
G_FLOOR = 9.81


class ChecksFailed(Exception):
    """A run's own checks are absurd: its report is not written (exit status 1)."""


def _seconds(values: Any) -> np.ndarray:
    """A time coordinate in seconds (decoded timedeltas or plain numbers)."""
    arr = np.asarray(values)
    if arr.dtype.kind == "m":
        return arr.astype("timedelta64[ns]").astype(np.float64) / 1e9
    return arr.astype(np.float64)


def _scales(ds: Any) -> tuple[float, float] | None:
    """(L = R0 + dR in m, the energy bound in J) from a dataset's resolved config, or None
    when it carries none (then only the structural checks apply)."""
    import yaml

    from creatio.store.yamlio import load_yaml

    try:
        cfg = load_yaml(str(ds.attrs["config_yaml"]))
        L = float(cfg["geometry"]["R0"]) + float(cfg["geometry"]["dR"])
        m, g = float(cfg["sphere"]["m"]), float(cfg["sphere"]["g"])
    except (KeyError, TypeError, ValueError, yaml.YAMLError):
        return None
    return L, ENERGY_FACTOR * m * max(g, G_FLOOR) * L


def dataset_problems(ds: Any) -> list[str]:
    """What is absurd in one sphere dataset: output times that do not increase, an energy
    residual beyond the bound or not finite where the energy was integrated."""
    problems = []
    if "time" in ds.coords and ds.sizes.get("time", 0) > 1:
        t = _seconds(ds.time.values)
        repeated = int(np.sum(np.diff(t) <= 0))
        if repeated:
            problems.append(f"{repeated} output time(s) repeat or go back (first at t = "
                            f"{t[1:][np.diff(t) <= 0][0]:g} s)")
    residual = (ds["max_energy_residual"].values if "max_energy_residual" in ds.data_vars
                else ds.attrs.get("max_energy_residual"))
    if residual is not None:
        values = np.abs(np.atleast_1d(np.asarray(residual, dtype=np.float64)))
        integrated = int(ds.attrs.get("energy_integrated", 0)) == 1
        if integrated and not np.all(np.isfinite(values)):
            problems.append("the energy residual is not finite although the energy was "
                            "integrated")
        scales = _scales(ds)
        finite = values[np.isfinite(values)]
        if scales is not None and finite.size and finite.max() > scales[1]:
            problems.append(f"energy residual {finite.max():.3g} J exceeds "
                            f"{ENERGY_FACTOR:g} m g (R0 + dR) = {scales[1]:.3g} J")
    return problems


def _difference(coarse: Any, fine: Any) -> float:
    """The largest centre distance of two runs at their common output times (every case of
    a study that runs several), NaN rows (a run that stopped) left out."""
    tc, tf = np.round(_seconds(coarse.time.values), 9), np.round(_seconds(fine.time.values), 9)
    common, ic, jf = np.intersect1d(tc, tf, return_indices=True)
    if not common.size:
        return math.nan
    a = np.take(coarse.centre.values, ic, axis=coarse.centre.dims.index("time"))
    b = np.take(fine.centre.values, jf, axis=fine.centre.dims.index("time"))
    if a.shape != b.shape:
        return math.nan
    d = np.linalg.norm(a - b, axis=-1)
    return float(np.nanmax(d)) if np.isfinite(d).any() else math.nan


def run_problems(datasets: Sequence[Any]) -> list[str]:
    """What is absurd in a sphere study's datasets: each one's problems, and a timestep
    difference between its run at dt and at dt / refine (its first two datasets with a
    centre) beyond R0 + dR."""
    problems = [f"{ds.attrs.get('dt', '?')} s run: {p}" if "dt" in ds.attrs else p
                for ds in datasets for p in dataset_problems(ds)]
    pair = [ds for ds in datasets if "centre" in ds.data_vars and "dt" in ds.attrs][:2]
    if len(pair) == 2 and not any("repeat" in p for p in problems):
        scales = _scales(pair[0])
        diff = _difference(*pair)
        if scales is not None and math.isfinite(diff) and diff > scales[0]:
            problems.append(f"the runs at dt = {pair[0].attrs['dt']:g} s and "
                            f"{pair[1].attrs['dt']:g} s end up {diff:.3g} m apart, more than "
                            f"the membrane's size R0 + dR = {scales[0]:g} m (the run is not "
                            "resolved by its step)")
    return problems


def mark(ds: Any) -> Any:
    """The dataset, its status set to ``checks_failed`` with the reason when its own checks
    are absurd (the run's status kept as ``run_status``); unchanged otherwise."""
    problems = dataset_problems(ds)
    if problems:
        ds.attrs["run_status"] = str(ds.attrs.get("status", ""))
        ds.attrs["status"] = "checks_failed"
        ds.attrs["checks"] = "; ".join(problems)
    return ds
