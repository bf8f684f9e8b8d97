"""Reports of the sphere studies (EN-02 family) and the EN-02 / EN-02R comparison: JSON
contract, markdown with the published figures, time histories, trajectory, convergence and
energy-residual figures, CSV histories (docs/studies.md).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import (
    PUBLISHED_HEADER,
    RunCase,
    config_label,
    config_paragraph,
    config_title,
    draw_figures,
    fixed_layout,
    fmt,
    plt,
    published_row,
    readable_y,
    run_case,
    save_figure,
    strict_json,
    table,
    write_markdown,
    write_text,
)
from creatio.store.atomic import atomic_write
from creatio.studies import registry

__all__ = ["dynamic_summary", "energy_check", "history_csv", "printed_half_unit",
           "timestep_check", "timestep_difference", "write_comparison", "write_report"]


def centre_difference(coarse: xr.Dataset, fine: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Common output times of two runs and |X_coarse - X_fine| at each of them."""
    common = np.intersect1d(np.round(coarse.time.values, 9), np.round(fine.time.values, 9))
    a = coarse.centre.sel(time=common, method="nearest").values
    b = fine.centre.sel(time=common, method="nearest").values
    return common, np.linalg.norm(a - b, axis=-1)


def timestep_difference(coarse: xr.Dataset, fine: xr.Dataset) -> float:
    """Max centre-position difference between two runs over their common output times."""
    _, d = centre_difference(coarse, fine)
    return float(np.max(d)) if d.size else float("nan")


def dynamic_summary(datasets: Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of an EN-02-family study from its runs (configured dt first)."""
    ds = datasets[0]
    a = ds.attrs
    azimuth = ds.centre_azimuth.values
    out: dict[str, Any] = {
        "study": a["study"],
        "angular_displacement_deg": float(azimuth[-1] - azimuth[0]),
        "initial_radius_m": float(ds.centre_radius.values[0]),
        "final_radius_m": float(ds.centre_radius.values[-1]),
        "min_normal_reaction_N": float(a["min_normal_reaction"]),
        "max_slip_speed_m_s": float(a["max_slip_speed"]),
        "cumulative_spin_deg": float(ds.cumulative_spin.values[-1]),
        "cavity_tracking_error_m": float(a["max_cavity_tracking_error"]),
        "min_edge_clearance_m": float(a["min_edge_clearance"]),
        "timestep_difference_m": (timestep_difference(ds, datasets[1])
                                  if len(datasets) > 1 else float("nan")),
        "energy_residual_J": float(a["max_energy_residual"]),
        "dt_s": [float(d.attrs["dt"]) for d in datasets],
        "status": str(a["status"]),
        "stop_time_s": float(a["stop_time"]),
        "status_by_dt": {repr(float(d.attrs["dt"])): str(d.attrs["status"]) for d in datasets},
        "energy_residual_by_dt_J": {
            repr(float(d.attrs["dt"])): float(d.attrs["max_energy_residual"]) for d in datasets
        },
        "max_b_kappa": float(a["max_b_kappa"]),
        "stability_limit_dt_s": float(a["stability_limit_dt"]),
        "warnings": [w for d in datasets for w in str(d.attrs.get("warnings", "")).split("\n")
                     if w],
        "config_sha256": a.get("config_sha256", ""),
    }
    return out


def _surface_top_view(ax, config: dict, t: float = 0.0) -> Any:
    """The surface height c_z in top view at time t; returns the mesh (for a colour bar)."""
    from omegaconf import OmegaConf

    from creatio.model.surface import Frame, Motion, Surface
    from creatio.studies.schema import PhasesConfig

    g = config["geometry"]
    surface = Surface(g["R0"], g["dR"], g["A"], g["Kr"], g["Ka"])
    phases = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(PhasesConfig),
                                                 config["phases"]))
    fr = Frame(surface, Motion(*phases.laws()),
               np.linspace(0, 2 * np.pi, 241)[:, None], np.linspace(0, g["dR"], 61)[None, :], t)
    p = fr.position
    mesh = ax.pcolormesh(p[..., 0], p[..., 1], p[..., 2], shading="gouraud", cmap="Greys",
                         alpha=0.55)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return mesh


def _history_figure(ds: xr.Dataset, path: Path) -> None:
    t = ds.time.values
    fric = np.linalg.norm(ds.friction.values, axis=-1)
    panels = [
        ("centre radius (m)", ds.centre_radius.values, "centre azimuth (deg)",
         ds.centre_azimuth.values),
        ("speed (m/s)", ds.speed.values, None, None),
        ("normal reaction N (N)", ds.normal_reaction.values, None, None),
        ("slip speed (m/s)", ds.slip_speed.values, None, None),
        ("|friction| (N)", fric, None, None),
        ("spin rate (rad/s)", ds.spin_rate.values, None, None),
        ("cumulative spin (deg)", ds.cumulative_spin.values, None, None),
        ("angular lag (deg)", ds.angular_lag.values, None, None),
        ("E - E(0) (J)", ds.energy.values - ds.energy.values[0], None, None),
    ]
    fig, axes = plt.subplots(3, 3, figsize=(13, 9), sharex=True)
    for ax, (label, y, label2, y2) in zip(axes.flat, panels, strict=True):
        ax.plot(t, y, lw=1.2)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        readable_y(ax, y)
        if y2 is not None:
            ax2 = ax.twinx()
            ax2.plot(t, y2, color="tab:orange", lw=1.0)
            ax2.set_ylabel(label2, color="tab:orange")
            readable_y(ax2, y2)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"{ds.attrs.get('title', '')}: time histories (dt = {ds.attrs['dt']:g} s, "
                 f"status {ds.attrs['status']})")
    fixed_layout(fig, left=1.0, right=0.2, bottom=0.6, top=0.5, wgap=1.45, hgap=0.35)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


#: A path whose extent is below this fraction of the annulus's outer diameter is hidden
#: under its markers at full scale: it gets a magnified inset (EN-02V moves about 4 cm).
ZOOM_BELOW = 0.15
#: Per run of a comparison: colour and line style (the time is marked along each path).
RUN_STYLES = (("tab:blue", "-"), ("tab:orange", "--"), ("tab:green", ":"), ("tab:red", "-."))


def zoom_box(runs: Sequence[tuple[str, xr.Dataset]], outer: float
             ) -> tuple[float, float, float, float] | None:
    """(x0, x1, y0, y1) of a square around every path when it is too small to read at the
    scale of the annulus (outer radius ``outer``), else None."""
    xy = np.concatenate([ds.centre.values[:, :2] for _, ds in runs])
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if xy.size == 0:
        return None
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    side = float(max(hi - lo))
    if side >= ZOOM_BELOW * 2 * outer:
        return None
    side = max(side * 1.3, 1e-3)  # a margin around the path; a still sphere gets 1 mm
    cx, cy = (lo + hi) / 2
    return cx - side / 2, cx + side / 2, cy - side / 2, cy + side / 2


#: Where each run's time labels sit beside their marks (points): runs that cross at the
#: same time mark keep their labels apart.
LABEL_OFFSETS = ((4, 4), (4, -12), (-26, 4), (-26, -12))


def _time_ticks(ax, x: np.ndarray, y: np.ndarray, t: np.ndarray, color: str, marker: str,
                every: float, offset: tuple[int, int] = LABEL_OFFSETS[0]) -> None:
    """Markers every ``every`` seconds along a path, each labelled with its time."""
    for tk in np.arange(0.0, t[-1] + 1e-9, every)[1:]:
        k = int(np.argmin(np.abs(t - tk)))
        ax.plot(x[k], y[k], marker, ms=5, color=color, zorder=4)
        ax.annotate(f"{tk:g} s", (x[k], y[k]), textcoords="offset points", xytext=offset,
                    fontsize=7, color=color, zorder=4,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                          "alpha": 0.8})


def _draw_paths(ax, runs: Sequence[tuple[str, xr.Dataset]], norm: Any, legend: bool) -> Any:
    """The centre paths on ax: one run coloured by time (returns the mappable); several
    runs each in its own colour and line style, time marked along them (returns None)."""
    mappable = None
    markers = ["o", "s", "^", "D"]
    for k, (label, ds) in enumerate(runs):
        x, y, t = ds.centre.values[:, 0], ds.centre.values[:, 1], ds.time.values
        if len(runs) == 1:
            ax.plot(x, y, lw=0.8, color="k", alpha=0.4, zorder=2)
            mappable = ax.scatter(x[::10], y[::10], c=t[::10], cmap="viridis", norm=norm,
                                  s=10, marker="o", label=label if legend else None, zorder=3)
        else:
            color, style = RUN_STYLES[k % len(RUN_STYLES)]
            ax.plot(x, y, lw=2.0, color=color, ls=style, label=label if legend else None,
                    zorder=3)
            _time_ticks(ax, x, y, t, color, markers[k % len(markers)],
                        every=_tick_interval(float(t[-1])),
                        offset=LABEL_OFFSETS[k % len(LABEL_OFFSETS)])
        # A start and an end that coincide (a whole cycle) must both stay visible: an open
        # circle around the start, a cross inside it for the end.
        ax.plot(x[0], y[0], "o", ms=13, mfc="none", mec="green", mew=2.2, zorder=5)
        ax.plot(x[-1], y[-1], "x", ms=9, color="red", mew=2.2, zorder=6)
    return mappable


def _tick_interval(duration: float) -> float:
    """A round time step giving at most four labelled marks over a run."""
    for step in (1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 60.0, 120.0, 300.0):
        if duration / step <= 4:
            return step
    return duration / 4


def trajectory_figure(runs: Sequence[tuple[str, xr.Dataset]], config: dict) -> Any:
    """The centre paths in top view over the surface height at t = 0 (a matplotlib figure).

    One run is coloured by time (colour bar). Several runs (the comparison) are told apart by
    colour, line style and legend, with their times marked along each path. A path too small
    to read at the annulus's scale (EN-02V) gets a magnified inset, its region outlined."""
    fig, ax = plt.subplots(figsize=(8.4, 6.4))
    height = _surface_top_view(ax, config)
    tmax = max(float(ds.time.values[-1]) for _, ds in runs)
    norm = plt.Normalize(0.0, tmax)
    mappable = _draw_paths(ax, runs, norm, legend=True)
    g = config["geometry"]
    box = zoom_box(runs, float(g["R0"]) + float(g["dR"]))
    if box is not None:  # the inset goes to the right, in the half the path is not in
        bottom = 0.03 if box[2] + box[3] > 0 else 0.6
        inset = ax.inset_axes((0.6, bottom, 0.37, 0.37))
        _surface_top_view(inset, config)
        _draw_paths(inset, runs, norm, legend=False)
        inset.set_xlim(box[0], box[1])
        inset.set_ylim(box[2], box[3])
        inset.set_xlabel("")
        inset.set_ylabel("")
        inset.tick_params(labelsize=6)
        side_mm = 1000.0 * (box[1] - box[0])
        inset.set_title(f"magnified: {side_mm:.3g} mm across", fontsize=7)
        ax.indicate_inset_zoom(inset, edgecolor="0.2")
    ax.plot([], [], "o", ms=9, mfc="none", mec="green", mew=2, label="start")
    ax.plot([], [], "x", ms=8, color="red", mew=2, label="end")
    if mappable is not None:
        fig.colorbar(mappable, ax=ax, label="time (s)", pad=0.02)
    fig.colorbar(height, ax=ax, label="surface height c_z at t = 0 (m)", pad=0.02)
    ax.legend(loc="upper left", fontsize=8)
    what = ("centre path in top view" if len(runs) == 1 else
            "centre paths in top view, time marked along each")
    ax.set_title(f"{what}, over the surface height at t = 0", fontsize=9)
    fixed_layout(fig, left=0.7, right=0.15, bottom=0.6, top=0.35)
    return fig


def _trajectory_figure(runs: Sequence[tuple[str, xr.Dataset]], config: dict, path: Path) -> None:
    fig = trajectory_figure(runs, config)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _convergence_figure_dynamic(datasets: Sequence[xr.Dataset], path: Path) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    if len(datasets) > 1:
        coarse, fine = datasets[0], datasets[1]
        common, d = centre_difference(coarse, fine)
        ax1.semilogy(common, np.maximum(d, 1e-18))
        ax1.set_title(f"|X(dt={coarse.attrs['dt']:g}) - X(dt={fine.attrs['dt']:g})|")
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("centre-position difference (m)")
    for ds in datasets:
        ax2.semilogy(ds.time.values, np.maximum(np.abs(ds.energy_residual.values), 1e-20),
                     label=f"dt = {ds.attrs['dt']:g} s")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("|E - E0 - W + D| (J)")
    ax2.set_title("energy residual")
    ax2.legend()
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    fixed_layout(fig, left=0.9, right=0.15, bottom=0.6, top=0.4, wgap=0.9)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def history_csv(ds: xr.Dataset, path: Path) -> None:
    """Every history of a sphere dataset as CSV columns (vectors one column per component,
    units in the headers); every sphere-kind report writes its _history.csv with it."""
    cols: dict[str, np.ndarray] = {"time_s": ds.time.values}
    for name, var in ds.data_vars.items():
        unit = var.attrs.get("units", "")
        suffix = f" ({unit})" if unit else ""
        if var.dims == ("time",):
            cols[f"{name}{suffix}"] = var.values
        elif var.dims[0] == "time" and var.ndim == 2:
            for j, c in enumerate(var[var.dims[1]].values):
                cols[f"{name}_{c}{suffix}"] = var.values[:, j]
    with atomic_write(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        w.writerows(zip(*(np.asarray(v).tolist() for v in cols.values()), strict=True))


SUMMARY_ROWS = [
    ("angular displacement (deg)", "angular_displacement_deg"),
    ("initial centre radius (m)", "initial_radius_m"),
    ("final centre radius (m)", "final_radius_m"),
    ("minimum normal reaction (N)", "min_normal_reaction_N"),
    ("maximum slip speed (m/s)", "max_slip_speed_m_s"),
    ("cumulative spin (deg)", "cumulative_spin_deg"),
    ("radial cavity-tracking error (m)", "cavity_tracking_error_m"),
    ("minimum edge clearance (m)", "min_edge_clearance_m"),
    ("timestep difference (m)", "timestep_difference_m"),
    ("energy residual (J)", "energy_residual_J"),
    ("status", "status"),
]


#: A residual below this many machine epsilons of the run's energy scale (m |g| (R0 + dR))
#: is rounding: its fall with dt cannot be measured.
ROUNDING_EPS = 100.0
#: The energy residual's observed order q is consistent with the scheme's order p when
#: q >= p - ORDER_SLACK.
ORDER_SLACK = 0.5


def _method_order(method: str) -> int | None:
    """The order of an integration method from the method registry (None if unknown)."""
    from creatio.dynamics.solvers import METHODS

    m = METHODS.get(method)
    return None if m is None else int(m.order)


def _scales(config: Mapping[str, Any], runs: Sequence[xr.Dataset]) -> tuple[float, float]:
    """(L = R0 + dR in m, the energy scale in J: m |g| L, or the largest |E| without gravity)."""
    g = config.get("geometry") or {}
    sph = config.get("sphere") or {}
    L = float(g.get("R0", math.nan)) + float(g.get("dR", math.nan))
    E = float(sph.get("m", math.nan)) * abs(float(sph.get("g", math.nan))) * L
    if not (math.isfinite(E) and E > 0):
        E = max((float(np.nanmax(np.abs(r.energy.values))) for r in runs if "energy" in r),
                default=math.nan)
    return L, E


def printed_half_unit(x: float) -> float:
    """Half a unit of the last digit :func:`fmt` prints of x (4 significant digits)."""
    if not (math.isfinite(x) and x != 0):
        return math.nan
    return 0.5 * 10.0 ** (math.floor(math.log10(abs(x))) - 3)


def _check(made: bool, passed: bool | None, measured: dict[str, float], bound: float,
           rule: str, verdict: str) -> dict[str, Any]:
    return {"made": made, "passed": passed if made else None, **measured, "bound": bound,
            "rule": rule, "verdict": verdict}


def timestep_check(runs: Sequence[xr.Dataset], config: Mapping[str, Any],
                   s: Mapping[str, Any]) -> dict[str, Any]:
    """Is the dt run's step fine enough for what the report prints? Fixed step: the
    Richardson estimate of its position error, e = d r^p / (r^p - 1) from the difference d
    to the dt / r run (p the scheme's order), against half a unit of the last printed digit
    of the positions. Adaptive: d against the requested rtol times the size R0 + dR."""
    d = float(s["timestep_difference_m"])
    a = runs[0].attrs
    method = str(a.get("method", "rk4"))
    p = _method_order(method)
    if len(runs) < 2 or not math.isfinite(d) or p is None:
        why = ("only one run" if len(runs) < 2 else "no common output time" if
               not math.isfinite(d) else f"the order of {method} is unknown")
        return _check(False, None, {"difference_m": d}, math.nan,
                      "needs the dt run and the dt / refine run",
                      f"not made: {why}")
    if "rtol" in a:
        L, _ = _scales(config, runs)
        bound = float(a["rtol"]) * L
        ok = d <= bound
        return _check(True, ok, {"difference_m": d, "adaptive": True}, bound,
                      f"adaptive {method}: the difference to the run at tolerances divided by "
                      f"refine^{p} must stay within rtol x (R0 + dR) = {fmt(float(a['rtol']))}"
                      f" x {fmt(L)} m",
                      "passes: the positions agree within the requested tolerance" if ok else
                      "FAILS: the positions move by more than the requested tolerance; "
                      "tighten solver.rtol")
    r = float(runs[0].attrs["dt"]) / float(runs[1].attrs["dt"])
    error = d * r ** p / (r ** p - 1.0)
    position = max(abs(float(s["initial_radius_m"])), abs(float(s["final_radius_m"])))
    bound = printed_half_unit(position)
    ok = error <= bound
    return _check(True, ok, {"difference_m": d, "richardson_error_m": error, "order": p,
                             "refine": r}, bound,
                  f"Richardson estimate of the dt run's position error, d x {fmt(r)}^{p} / "
                  f"({fmt(r)}^{p} - 1) (order {p} of {method}), within half a unit of the "
                  f"last digit of the positions printed to 4 significant digits ({position:#.4g} "
                  f"m: {fmt(bound)} m)",
                  "passes: the printed positions do not depend on the step" if ok else
                  "FAILS: the step moves the printed positions; reduce solver.dt")


def energy_check(runs: Sequence[xr.Dataset], config: Mapping[str, Any]) -> dict[str, Any]:
    """Does the energy residual fall with the step as the scheme says? Its observed order
    q = log(R(dt) / R(dt / r)) / log r against the scheme's order p (an adaptive run's
    tolerances are divided by r^p, so q should again reach p); not made when the residual
    is at rounding level (below ROUNDING_EPS machine epsilons of m |g| (R0 + dR))."""
    res = [float(r.attrs.get("max_energy_residual", math.nan)) for r in runs]
    method = str(runs[0].attrs.get("method", "rk4"))
    p = _method_order(method)
    _, scale = _scales(config, runs)
    floor = ROUNDING_EPS * float(np.finfo(float).eps) * scale
    measured = {"residual_J": res[0], "residual_fine_J": res[-1] if len(res) > 1 else math.nan,
                "rounding_level_J": floor}
    rule = (f"observed order q = log(R(dt) / R(dt / refine)) / log(refine) >= p - "
            f"{ORDER_SLACK:g} (p = {p} for {method}); not measurable below "
            f"{ROUNDING_EPS:g} eps x m |g| (R0 + dR) = {fmt(floor)} J")
    if len(res) < 2 or not all(math.isfinite(x) for x in res) or p is None:
        return _check(False, None, measured, math.nan, rule,
                      "not made: the energy was not integrated at both steps"
                      if len(res) > 1 else "not made: only one run")
    if min(res) <= floor:
        measured["rounding"] = True
        return _check(False, None, measured, floor, rule,
                      "not made: the residual is at rounding level (the books balance to "
                      "rounding), so its order cannot be measured")
    r = float(runs[0].attrs["dt"]) / float(runs[1].attrs["dt"])
    q = math.log(res[0] / res[1]) / math.log(r)
    ok = q >= p - ORDER_SLACK
    measured["observed_order"] = q
    measured["order"] = p
    return _check(True, ok, measured, p - ORDER_SLACK, rule,
                  f"passes: the residual falls at order {q:.2f} (scheme order {p})" if ok else
                  f"FAILS: the residual falls at order {q:.2f}, below the scheme's {p}: "
                  "the step is not in the asymptotic range, or the books leak")


#: What each check means, as the report says it.
CHECK_MEANING = {
    "timestep": "Timestep difference: the largest distance between the centres of the dt "
                "run and the dt / refine run at common output times. It estimates the dt "
                "run's own error; the check asks whether the printed positions can be "
                "trusted to their last digit.",
    "energy": "Energy residual: the largest |E - E(0) - W_surface + D_friction| over the "
              "run, the integrator's bookkeeping error. A correct scheme makes it fall with "
              "the step at (at least) its order; the check measures that fall.",
}


def _rests_on(t: Mapping[str, Any], e: Mapping[str, Any]) -> str:
    """The answer's last line: what the step and the energy checks showed, in words."""
    refine = t.get("refine", 2.0)
    how = "halving dt" if refine == 2.0 else f"dividing dt by {fmt(refine)}"
    if t.get("adaptive"):
        how = "tightening the tolerances"
    d = num(t["difference_m"], "m")
    step = (f"{how} moves the centre by at most {d}, so the printed positions do not "
            "depend on the step" if t["passed"] else
            f"{how} moves the centre by {d}, more than the printed digits allow (the step "
            "check FAILS)" if t["made"] else f"the step was not checked ({t['verdict']})")
    R = num(e["residual_J"], "J")
    if e["made"]:
        q, p = e["observed_order"], e["order"]
        energy = (f"the energy residual ({R}) falls with dt at order {q:.1f} (scheme order "
                  f"{p})" if e["passed"] else f"the energy residual ({R}) falls with dt at "
                  f"order {q:.1f} only, below the scheme's {p} (the energy check FAILS)")
    elif e.get("rounding"):
        energy = (f"the energy books balance to {R} ({num(e['residual_fine_J'], 'J')} at the "
                  "finer step): rounding level, where their fall with dt cannot be measured")
    else:
        energy = f"the energy residual was not checked ({e['verdict']})"
    return f"{step}; {energy}"


def _answer(ds: xr.Dataset, runs: Sequence[xr.Dataset], s: Mapping[str, Any],
            checks: Mapping[str, Any], case: RunCase, compared: Sequence[Sequence[str]],
            extra: Sequence[str]) -> list[str]:
    """The opening lines (creatio.reports.answer): what was computed for which config, the
    answer (the motion, then each used feature's), what it rests on (the run's own checks,
    and the notebook's figures for the published case)."""
    a = ds.attrs
    method = str(a.get("method", "rk4"))
    if "rtol" in a:
        how = (f"{method} (adaptive, rtol {num(float(a['rtol']))}), again with tolerances "
               f"divided by {num(float(a['dt']) / float(runs[-1].attrs['dt']))}^"
               f"{_method_order(method)}")
    else:
        how = f"{method.upper()} at dt = {s['dt_s'][0]:g} s, again at dt = {s['dt_s'][-1]:g} s"
    computed = (f"{num(s['stop_time_s'], 's')} of the sphere's motion ({config_label(case)}) "
                f"with {how} to check the step.")
    ok = s["status"] == "ok"
    contact = (f"it stayed in contact (minimum normal reaction "
               f"{num(s['min_normal_reaction_N'], 'N')})" if ok else
               f"the run stopped at t = {num(s['stop_time_s'], 's')} with status {s['status']}")
    motion = (f"the sphere travelled {s['angular_displacement_deg']:+.1f} deg around the annulus"
              f" and ended at radius {s['final_radius_m']:#.4g} m (from "
              f"{s['initial_radius_m']:#.4g} m); {contact}.")
    rests = f"{_rests_on(checks['timestep'], checks['energy'])}."
    if case.published_case and compared:
        good = sum(1 for row in compared if row[4] in ("agrees to the printed digits",
                                                       "below the bound", "same order"))
        rests += (f" Beside the notebook: {good} of {len(compared)} published figures agree "
                  "to their printed digits or stay below their bounds.")
    elif case.has_published:
        rests += " No published figure applies to this config."
    return answer_lines(computed, [motion, *extra][:3], rests)


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write <study>.json/.md/.html/.png, _history.csv, _trajectory.png, _convergence.png
    (and each used feature's figures): the config named first, then the answer, the checks
    derived from the run itself, the published comparison only for the published case."""
    from creatio.reports.sections import feature_sections
    from creatio.store.netcdf import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    runs = [ds for ds, _ in loaded]
    config = loaded[0][1]
    ds = runs[0]
    study = ds.attrs["study"]
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    s = dynamic_summary(runs)
    case = run_case(datasets, ds)
    checks = {"timestep": timestep_check(runs, config, s), "energy": energy_check(runs, config)}
    paths = {
        "json": outdir / f"{study}.json",
        "md": outdir / f"{study}.md",
        "html": outdir / f"{study}.html",
        "png": outdir / f"{study}.png",
        "csv": outdir / f"{study}_history.csv",
        "trajectory": outdir / f"{study}_trajectory.png",
        "convergence": outdir / f"{study}_convergence.png",
    }
    # the figures are independent: drawn at once where a core is free (creatio.store.forked),
    # one each (0.36, 0.23 + the CSV, 0.32 s of CPU): on 2 idle cores the report took 0.71 s
    # (0.65-0.75) against 0.78 s (0.68-0.85) in two halves, 10 pairs
    draw_figures([lambda: _history_figure(ds, paths["png"]),
                  lambda: (_trajectory_figure([(study, ds)], config, paths["trajectory"]),
                           history_csv(ds, paths["csv"])),
                  lambda: _convergence_figure_dynamic(runs, paths["convergence"])])
    sections = feature_sections(runs, config, outdir, study)
    pub = dict(registry.get(study).published) if case.published_case else {}
    compared = [published_row(label, s[key], pub[key]) for label, key in SUMMARY_ROWS
                if key in pub]
    rows = [(label, s[key]) for label, key in SUMMARY_ROWS if key not in pub]
    method = str(ds.attrs.get("method", "rk4"))
    if "rtol" in ds.attrs:
        pair = (f"{method} (adaptive) at rtol = {ds.attrs['rtol']:g} compared with rtol = "
                f"{runs[-1].attrs['rtol']:g} (datasets named dt = {s['dt_s'][0]:g}, "
                f"{s['dt_s'][-1]:g} s).")
    else:
        pair = (f"{method.upper()} at dt = {s['dt_s'][0]:g} s compared with dt = "
                f"{s['dt_s'][-1]:g} s.")
    answer = _answer(ds, runs, s, checks, case, compared,
                     [a for sec in sections for a in sec.answer])
    lines = [config_title(ds, case), "", *answer, *config_paragraph(ds, case),
             "## Summary figures", "", pair, ""]
    if compared:
        lines += ["Computed beside the figures the notebook publishes, with the digits it "
                  "prints; a value agrees when it is within half a unit of the last printed "
                  "digit. The published timestep difference and energy residual are upper "
                  "bounds (the notebook's code used approximate derivatives; these runs use "
                  "exact derivatives).", ""]
        lines += table(PUBLISHED_HEADER, compared)
        lines += ["", "The notebook publishes no other figure of this study:", ""]
    lines += table(["figure", "computed"], rows)
    lines += ["", "Extrema are taken over every integration step. Energy residual per dt: "
              + ", ".join(f"{k} s: {fmt(v)} J" for k, v in s["energy_residual_by_dt_J"].items())
              + f". {method.upper()} stability limit of the friction: "
              f"{fmt(s['stability_limit_dt_s'])} s; "
              f"max b kappa on the path: {fmt(s['max_b_kappa'])}.", ""]
    lines += ["## Checks of this run", "",
              "Judged by what this run shows about itself (its dt and dt / refine runs), "
              "against bounds computed for this run. A check that cannot be made is said so, "
              "not passed.", ""]
    lines += table(["check", "measured", "rule", "verdict"], [
        ("timestep difference", f"{fmt(checks['timestep']['difference_m'])} m",
         checks["timestep"]["rule"], checks["timestep"]["verdict"]),
        ("energy residual", f"{fmt(checks['energy']['residual_J'])} J at dt, "
         f"{fmt(checks['energy']['residual_fine_J'])} J at dt / refine",
         checks["energy"]["rule"], checks["energy"]["verdict"])])
    lines += ["", *[f"* {text}" for text in CHECK_MEANING.values()], ""]
    for sec in sections:
        lines += sec.lines
        for fig in sec.figures:
            paths[f"{sec.name}_{fig.stem.removeprefix(study + '_')}"] = fig
    if s["warnings"]:
        lines += ["## Warnings", "", *[f"* {w}" for w in s["warnings"]], ""]
    lines += [f"![time histories]({paths['png'].name})", "",
              f"![trajectory]({paths['trajectory'].name})", "",
              f"![convergence]({paths['convergence'].name})", ""]
    s.update(case.json())
    s["checks"] = checks
    s["answer"] = [line for line in answer if line]
    for sec in sections:
        s.update(sec.summary)
    write_text(paths["json"], strict_json(s))
    write_markdown(paths["md"], "\n".join(lines))
    return paths


def write_comparison(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """EN-02 vs EN-02R: both centre paths on shared time over the surface, and a table."""
    from creatio.store.netcdf import read_dataset
    from creatio.store.regular import read_text

    loaded = [read_dataset(p) for p in datasets]
    outdir = Path(outdir)
    summaries = [json.loads(read_text(outdir / f"{ds.attrs['study']}.json"))
                 for ds, _ in loaded]
    names = [s["study"] for s in summaries]
    paths = {"md": outdir / "compare_en02_en02r.md", "png": outdir / "compare_en02_en02r.png"}
    _trajectory_figure([(n, ds) for n, (ds, _) in zip(names, loaded, strict=True)],
                       loaded[0][1], paths["png"])
    rows = [(label, *[s[key] for s in summaries]) for label, key in SUMMARY_ROWS]
    lines = ["# EN-02 / EN-02R comparison", "",
             "Both centre paths in top view on shared time (colour), over the surface height "
             "at t = 0.", "", f"![paths]({paths['png'].name})", ""]
    lines += table(["figure", *names], rows)
    write_text(paths["md"], "\n".join(lines) + "\n")
    return paths
