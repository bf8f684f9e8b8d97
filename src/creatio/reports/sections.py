"""Feature sections of a report: every feature a run used (a controller, flight) declares the
section that reports it, so that a run of any study that switches the feature on gets it.

A feature is a :class:`Feature`: its name, ``applies(config, dataset)`` (did this run use
it?) and ``section(datasets, config, outdir, stem)`` (the markdown lines, the figures it
drew and the JSON keys it adds). :data:`FEATURES` is the registry; :func:`feature_sections`
gives the sections of every feature a run used, in registry order. A new feature (tilt,
rib surfaces) is one more entry. Sections read the datasets' histories and attributes and
the resolved config; they recompute nothing of the study.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.common import finish_figure, fmt, plt, table

__all__ = ["FEATURES", "Feature", "Section", "control_applies", "control_section",
           "feature_sections", "flight_applies", "flight_section", "tilt_applies",
           "tilt_section"]


@dataclass
class Section:
    """What a feature adds to a report: markdown lines (a ``##`` heading first), the figures
    it drew (embedded by its lines), JSON keys for the contract and answer lines for the
    report's opening paragraph."""

    name: str
    lines: list[str]
    figures: list[Path] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    answer: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class Feature:
    """A feature a run may use: whether this run used it, and its report section."""

    name: str
    applies: Callable[[Mapping[str, Any], xr.Dataset], bool]
    section: Callable[[Sequence[xr.Dataset], Mapping[str, Any], Path, str], Section]


def _num(x: Any) -> float:
    """An attribute as a float (NaN when missing or not a number)."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _lost(ds: xr.Dataset) -> bool:
    """Whether the run lost its sphere or stopped early (its arrival means nothing then)."""
    return str(ds.attrs.get("status", "ok")) != "ok" or not bool(ds.attrs.get("carried", 1))


# ------------------------------------------------------------------------------ control
def control_applies(config: Mapping[str, Any], ds: xr.Dataset) -> bool:
    """A run is controlled when its config sets the control group (or its dataset says so)."""
    return bool(config.get("control")) or bool(ds.attrs.get("control", 0))


#: The control group's keys as the section lists them: (key, label, unit).
CONTROL_KEYS = (
    ("theta_goal_deg", "commanded travel of the contact angle", "deg"),
    ("arrival_tol_deg", "arrival tolerance", "deg"),
    ("omega_c", "outer loop pole frequency omega_c", "rad/s"),
    ("zeta_c", "outer loop damping zeta_c", ""),
    ("omega_n", "servo frequency omega_n", "rad/s"),
    ("zeta", "servo damping zeta", ""),
    ("omega_max", "speed limit of the sphere's alpha", "rad/s"),
    ("delta_max_deg", "lead limit", "deg"),
    ("u_max", "servo acceleration limit", "rad/s^2"),
)

#: The controlled run's readouts (dataset attributes, EN-04's arrival rule): (attribute,
#: JSON key, label).
CONTROL_READOUTS = (
    ("arrival_time", "arrival_s", "arrival (s)"),
    ("settling_time", "settling_s", "settling (s)"),
    ("overshoot_deg", "overshoot_deg", "overshoot past the goal (deg)"),
    ("final_error_deg", "final_error_deg", "final error (deg)"),
    ("max_lead_deg", "max_lead_deg", "largest lead of the carrying cavity (deg)"),
    ("max_phase_a_rate", "max_phidot_a_rad_s", "actuator peak: phase rate |phi_a'| (rad/s)"),
    ("max_phase_a_acceleration", "max_u_rad_s2",
     "actuator peak: servo output |u| = |phi_a''| (rad/s^2)"),
)
#: Readouts that mean nothing for a sphere that was lost.
_ARRIVAL = ("arrival_s", "settling_s")


def _control_figure(ds: xr.Dataset, Ka: float, path: Path) -> None:
    """The closed loop over the run: the travel of the contact angle and of the pattern
    beside the goal band, the lead against its command, and the actuator's rate and output."""
    t = ds.time.values
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    goal = _num(ds.attrs.get("control_goal_deg"))
    tol = _num(ds.attrs.get("control_arrival_tol_deg"))
    ax = axes[0]
    ax.plot(t, ds.travel.values, lw=1.2, label="sphere: travel theta = alpha - alpha(0)")
    pa = ds.phase_a.values
    ax.plot(t, -(pa - pa[0]) / Ka, lw=1.0, ls="--",
            label=f"pattern: travel -(phi_a - phi_a(0)) / Ka (Ka = {Ka:g})")
    if math.isfinite(goal) and math.isfinite(tol):
        ax.axhspan(goal - tol, goal + tol, color="0.85", label="arrival band")
    arrival = _num(ds.attrs.get("arrival_time"))
    if math.isfinite(arrival) and not _lost(ds):
        ax.axvline(arrival, color="tab:green", lw=0.8, label=f"arrival {arrival:g} s")
    ax.set_ylabel("travel (deg)")
    ax.legend(fontsize=8)
    axes[1].plot(t, ds.lead.values, lw=1.1, label="lead delta")
    axes[1].plot(t, ds.lead_command.values, lw=0.9, ls="--", label="commanded lead")
    axes[1].set_ylabel("lead (deg)")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, ds.phase_a_rate.values, lw=1.0, label="phase rate phi_a' (rad/s)")
    ax2 = axes[2].twinx()
    ax2.plot(t, ds.phase_a_acceleration.values, lw=0.8, color="tab:red", alpha=0.7)
    ax2.set_ylabel("servo output u (rad/s^2)", color="tab:red")
    axes[2].set_ylabel("phase rate (rad/s)")
    axes[2].set_xlabel("time (s)")
    # a loop that settles early is still for the rest of the run: show up to three times
    # its settling (or arrival) time, the whole run otherwise
    settle = _num(ds.attrs.get("settling_time"))
    until = settle if math.isfinite(settle) else arrival
    shown = ""
    if math.isfinite(until) and 3 * until < float(t[-1]):
        axes[2].set_xlim(float(t[0]), max(3 * until, 1.0))
        shown = f", first {max(3 * until, 1.0):g} s of {float(t[-1]):g} s"
    for a in axes:
        a.grid(alpha=0.3)
    fig.suptitle(f"Closed loop (dt = {ds.attrs.get('dt', math.nan):g} s, status "
                 f"{ds.attrs.get('status', '')}{shown})", fontsize=10)
    finish_figure(fig, path)


def control_section(datasets: Sequence[xr.Dataset], config: Mapping[str, Any], outdir: Path,
                    stem: str) -> Section:
    """The controller's gains and limits (config and the gains derived from it), the run's
    arrival, settling, overshoot and actuator peaks (dataset attributes), the closed-loop
    figure. A lost sphere's arrival and settling are not shown."""
    ds = datasets[0]
    group = dict(config.get("control") or {})
    gains = [(f"{label} ({unit})" if unit else label,
              "none" if group.get(key) is None else group.get(key))
             for key, label, unit in CONTROL_KEYS if key in group]
    gains += [("outer gain K_theta (from omega_c)", _num(ds.attrs.get("control_k_theta"))),
              ("outer gain K_omega (from omega_c, zeta_c)",
               _num(ds.attrs.get("control_k_omega")))]
    lost = _lost(ds)
    readouts = {key: _num(ds.attrs.get(attr)) for attr, key, _ in CONTROL_READOUTS}
    rows = []
    for _, key, label in CONTROL_READOUTS:
        value: Any = readouts[key]
        if key in _ARRIVAL and lost:
            value = f"not shown: the sphere was lost (status {ds.attrs.get('status')})"
            readouts[key] = math.nan
        elif not math.isfinite(value):
            value = "not reached" if key in _ARRIVAL else "not computed"
        rows.append((label, value))
    figure = outdir / f"{stem}_control.png"
    Ka = float((config.get("geometry") or {}).get("Ka", 1.0) or 1.0)
    drawn = all(v in ds for v in ("travel", "phase_a", "lead", "lead_command",
                                  "phase_a_rate", "phase_a_acceleration"))
    if drawn:
        _control_figure(ds, Ka, figure)
    goal = _num(ds.attrs.get("control_goal_deg"))
    tol = _num(ds.attrs.get("control_arrival_tol_deg"))
    if lost:
        answer = (f"the controller ran (goal {fmt(goal)} deg), but the sphere was lost "
                  f"(status {ds.attrs.get('status')}): no arrival.")
    elif math.isfinite(readouts["arrival_s"]):
        settle = readouts["settling_s"]
        answer = (f"the controller brought the contact angle within {fmt(tol)} deg of its "
                  f"goal ({fmt(goal)} deg) at {fmt(readouts['arrival_s'])} s"
                  + (f" and kept it there from {fmt(settle)} s" if math.isfinite(settle)
                     else ", but it did not stay within the band to the end")
                  + f"; overshoot {fmt(readouts['overshoot_deg'])} deg.")
    else:
        answer = (f"the controller ran but the contact angle never came within {fmt(tol)} "
                  f"deg of its goal ({fmt(goal)} deg).")
    lines = ["## Control", "",
             "A controller drove the angular phase in closed loop (`control` group): the "
             "outer loop commands the lead of the carrying cavity from the travel error, a "
             "servo drives the phase toward it. Arrival is the first time the travel is "
             "within the arrival tolerance of its goal, settling the time from which it stays "
             "so to the end (EN-04's rule).", "",
             "Gains and limits:", "", *table(["setting", "value"], gains), "",
             "What the closed loop did (dt run):", "", *table(["readout", "value"], rows), ""]
    if drawn:
        lines += [f"![closed loop: travel, lead and actuator over time]({figure.name})", ""]
    summary = {"control": {"gains": {key: group.get(key) for key, _, _ in CONTROL_KEYS
                                     if key in group}
                           | {"k_theta": _num(ds.attrs.get("control_k_theta")),
                              "k_omega": _num(ds.attrs.get("control_k_omega"))},
                           "lost": lost, **readouts}}
    return Section("control", lines, [figure] if drawn else [], summary, [answer])


# ------------------------------------------------------------------------------ flight
def flight_applies(config: Mapping[str, Any], ds: xr.Dataset) -> bool:
    """A run used flight when its dataset carries an event table or flight figures."""
    return "event_kind" in ds or "flights" in ds.attrs or "flights" in ds


def _event_names(ds: xr.Dataset) -> list[str]:
    meanings = str(ds.event_kind.attrs.get("flag_meanings", "")).split()
    return meanings


def flight_section(datasets: Sequence[xr.Dataset], config: Mapping[str, Any], outdir: Path,
                   stem: str) -> Section:
    """The run's flight events: how many flights and impacts, when, the largest flight
    height and the energy the impacts took (the default case of a stacked dataset)."""
    ds = datasets[0]
    case = int(ds.attrs.get("default_case", 0)) if "case" in ds.dims else None

    def figure(name: str) -> float:
        if name in ds.data_vars and case is not None:
            return _num(ds[name].values[case])
        return _num(ds.attrs.get(name))

    figures = {k: figure(k) for k in ("flights", "impacts", "flight_time",
                                      "max_flight_height", "impact_loss")}
    rows: list[tuple[Any, ...]] = []
    if "event_kind" in ds:
        names = _event_names(ds)
        keep = np.ones(ds.sizes.get("event", 0), bool)
        if case is not None and "event_case" in ds:
            keep = ds.event_case.values == case
        times = ds.event_time.values[keep]
        kinds = ds.event_kind.values[keep]
        heights = ds.event_flight_height.values[keep] if "event_flight_height" in ds else \
            np.full(times.shape, math.nan)
        for t, k, h in list(zip(times, kinds, heights, strict=True))[:12]:
            name = names[int(k)] if 0 <= int(k) < len(names) else str(int(k))
            rows.append((float(t), name, float(h)))
    lines = ["## Flight", "",
             "Flight was on: the sphere may leave the surface, fly and land (impact with "
             "restitution)." + (f" Figures of the default case (case {case})." if case is not
                                None else ""), "",
             *table(["figure", "value"], [
                 ("flights", figures["flights"]), ("impacts", figures["impacts"]),
                 ("total flight time (s)", figures["flight_time"]),
                 ("largest flight height (m)", figures["max_flight_height"]),
                 ("energy taken by impacts (J)", figures["impact_loss"])]), ""]
    if rows:
        lines += ["First events:", "", *table(["time (s)", "event", "flight height (m)"], rows),
                  ""]
    n = figures["flights"]
    answer = ("the sphere never left the surface." if n == 0 else
              f"the sphere flew {fmt(n)} time(s), {fmt(figures['flight_time'])} s in all, at "
              f"most {fmt(figures['max_flight_height'])} m above the surface.")
    return Section("flight", lines, [], {"flight": figures}, [answer])


def tilt_applies(config: Mapping[str, Any], ds: xr.Dataset) -> bool:
    """Whether the membrane was mounted off level (a tilted run records its tilt)."""
    return "tilt_beta_deg" in ds.attrs


def tilt_section(datasets: Sequence[xr.Dataset], config: Mapping[str, Any], outdir: Path,
                 stem: str) -> Section:
    """The tilt and the gravity vector it gave, and what the sphere felt of it."""
    ds = datasets[0]
    beta, psi = _num(ds.attrs["tilt_beta_deg"]), _num(ds.attrs.get("tilt_psi_deg", 0.0))
    g = [_num(ds.attrs.get(f"gravity_{c}")) for c in "xyz"]
    n_min = _num(ds.attrs.get("min_normal_reaction"))
    lines = ["## Tilt", "",
             "The membrane's plane was mounted off level: gravity is the vector g (sin beta cos "
             "psi, sin beta sin psi, -cos beta) in the equations of motion, the normal reaction "
             "and the energy books (docs/model.md).", "",
             *table(["figure", "value"], [
                 ("tilt beta (deg)", beta), ("toward azimuth psi (deg)", psi),
                 ("gravity x (m/s^2)", g[0]), ("gravity y (m/s^2)", g[1]),
                 ("gravity z (m/s^2)", g[2]),
                 ("minimum normal reaction (N)", n_min)]), ""]
    answer = (f"the membrane was tilted {fmt(beta)} deg toward azimuth {fmt(psi)} deg, so "
              f"gravity had a horizontal part of {fmt(math.hypot(g[0], g[1]))} m/s^2.")
    return Section("tilt", lines, [], {"tilt": {"beta_deg": beta, "psi_deg": psi,
                                                "gravity_m_s2": g}}, [answer])


#: Every feature with a report section, in the order a report shows them.
FEATURES: tuple[Feature, ...] = (
    Feature("control", control_applies, control_section),
    Feature("flight", flight_applies, flight_section),
    Feature("tilt", tilt_applies, tilt_section),
)


def feature_sections(datasets: Sequence[xr.Dataset], config: Mapping[str, Any],
                     outdir: str | Path, stem: str) -> list[Section]:
    """The section of every feature the run (its first dataset) used."""
    ds = datasets[0]
    return [f.section(datasets, config, Path(outdir), stem) for f in FEATURES
            if f.applies(config, ds)]
