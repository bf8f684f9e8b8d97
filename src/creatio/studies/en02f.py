"""EN-02F: separation, flight and impact (docs/studies.md, docs/model.md s.11).

EN-02 over one cycle of each length T, at each restitution e, with flight on: the run
continues through separations and impacts. One dataset per timestep: the runs along
``case`` (coordinates ``cycle`` and ``restitution``) on the longest run's output grid, their
event statistics, and the event table of every run along ``event``. The drop test is a
dataset of its own (part ``en02f_drop``) with its closed-form errors. The boundary along T
is bisected with flight (where the sphere no longer comes back to its cavity) and without
(where contact is lost), from the sweep's neighbouring cycles.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from creatio.dynamics import SimulationResult, SphereProblem, simulate
from creatio.dynamics.layout import (
    EV_ALPHA,
    EV_HEIGHT,
    EV_IMPACT,
    EV_KIND,
    EV_LOSS,
    EV_R,
    EV_SEPARATION,
    EV_T,
    EV_VN,
    EV_VN_AFTER,
    EV_X,
    EVENT_KINDS,
)
from creatio.model.cavity import in_cavity_cell
from creatio.studies.en02f_schema import En02fConfig
from creatio.studies.run_datasets import output_grid, run_dataset, stack
from creatio.studies.schema import with_cycle

__all__ = ["HISTORIES", "cycle_boundary", "event_figures", "run", "run_drop"]

#: The histories kept per run.
HISTORIES = ("centre", "centre_radius", "centre_azimuth", "contact_R", "contact_alpha", "speed",
             "normal_reaction", "slip_speed", "spin_rate", "energy_residual", "cavity_cell_u",
             "cavity_cell_v")


def event_figures(res: SimulationResult) -> dict[str, float]:
    """Event statistics of one run: flights, impacts, total flight time (an unfinished
    flight counts to the stop), largest flight height, total impact loss (the impacts'
    and the resumptions' projections), and whether the run ends in its starting cavity."""
    ev = res.events.table
    kind = ev[:, EV_KIND] if ev.size else np.empty(0)
    flights = int(np.sum(kind == EV_SEPARATION)) + (1 if _starts_in_flight(res) else 0)
    start = 0.0 if _starts_in_flight(res) else math.nan
    flight_time = 0.0
    for row in ev:
        k = int(row[EV_KIND])
        if k == EV_SEPARATION:
            start = row[EV_T]
        elif k != EV_IMPACT and not math.isnan(start):
            flight_time += row[EV_T] - start
            start = math.nan
    if not math.isnan(start):
        flight_time += res.counts.stop_time - start
    h = res.histories
    in_cavity = bool(h.t.size) and bool(in_cavity_cell(h.cell_u[-1], h.cell_v[-1]))
    return {
        "flights": flights,
        "impacts": int(np.sum(kind == EV_IMPACT)),
        "flight_time": float(flight_time),
        "max_flight_height": float(res.events.max_flight_height) if flights else 0.0,
        "impact_loss": float(np.sum(ev[:, EV_LOSS])) if ev.size else 0.0,
        "ends_in_cavity": int(in_cavity and not res.events.ends_in_flight
                              and res.counts.status == "ok"),
    }


def _starts_in_flight(res: SimulationResult) -> bool:
    h = res.histories
    return bool(h.t.size) and h.N.size > 0 and h.N[0] == 0.0 and np.isnan(h.slip_speed[0])


def _event_table(results: list[SimulationResult]) -> dict[str, tuple]:
    """The event tables of the runs, concatenated along ``event`` with their case index."""
    rows = [np.column_stack([np.full(len(r.events.table), i), r.events.table])
            for i, r in enumerate(results)]
    ev = np.concatenate(rows) if rows else np.empty((0, 12))
    ev = ev if ev.size else np.empty((0, 12))
    col = 1
    return {
        "event_case": ("event", ev[:, 0].astype(np.int32),
                       {"long_name": "case index of the event's run"}),
        "event_time": ("event", ev[:, col + EV_T], {"long_name": "event time", "units": "s"}),
        "event_kind": ("event", ev[:, col + EV_KIND].astype(np.int8),
                       {"long_name": "event kind",
                        "flag_values": np.arange(len(EVENT_KINDS), dtype=np.int8),
                        "flag_meanings": " ".join(EVENT_KINDS)}),
        "event_vn": ("event", ev[:, col + EV_VN],
                     {"long_name": "relative normal velocity before the event",
                      "units": "m s-1"}),
        "event_vn_after": ("event", ev[:, col + EV_VN_AFTER],
                           {"long_name": "relative normal velocity after the event",
                            "units": "m s-1"}),
        "event_energy_lost": ("event", ev[:, col + EV_LOSS],
                              {"long_name": "mechanical energy lost at the event",
                               "units": "J"}),
        "event_centre": (("event", "component"), ev[:, col + EV_X:col + EV_X + 3],
                         {"long_name": "sphere centre at the event", "units": "m"}),
        "event_R": ("event", ev[:, col + EV_R], {"long_name": "foot point R", "units": "m"}),
        "event_alpha": ("event", np.degrees(ev[:, col + EV_ALPHA]),
                        {"long_name": "foot point alpha", "units": "degree"}),
        "event_flight_height": ("event", ev[:, col + EV_HEIGHT],
                                {"long_name": "largest gap of the flight an impact ends",
                                 "units": "m"}),
    }


def _returns(prob: SphereProblem) -> bool:
    """Whether a run completes with the sphere in its starting cavity: with flight, back in
    its cell and in contact at the end; without, simply status ok (contact never lost)."""
    res = simulate(prob)
    if not prob.events.flight:
        return res.counts.status == "ok"
    return bool(event_figures(res)["ends_in_cavity"])


def cycle_boundary(cfg: En02fConfig, dt: float, restitution: float, flight: bool,
                   rtol: float = 1e-3) -> tuple[float, float]:
    """Bracket (T_fail, T_ok) of the cycle length below which the sphere no longer comes
    back to its cavity (with flight) or loses contact (without): bisection from the sweep's
    neighbouring cycles, T a multiple of dt, to a relative width rtol. NaN, NaN when the
    sweep has no such pair."""
    probs = {T: p for T, e, p in cfg.run_problems(dt) if e == restitution}
    base = next(iter(probs.values()))
    base = base.replace(flight=flight)

    def at(T: float) -> SphereProblem:
        return base.replace(motion=with_cycle(base.model.motion, T), t_end=T)

    verdict = {T: _returns(at(T)) for T in sorted(probs)}
    pairs = [(a, b) for a, b in zip(sorted(verdict), sorted(verdict)[1:], strict=False)
             if not verdict[a] and verdict[b]]
    if not pairs:
        return math.nan, math.nan
    lo, hi = pairs[-1]
    while hi - lo > rtol * hi:
        mid = round(0.5 * (lo + hi) / dt) * dt
        if mid <= lo or mid >= hi:
            break
        if _returns(at(mid)):
            hi = mid
        else:
            lo = mid
    return float(lo), float(hi)


def run(cfg: En02fConfig, dt: float | None = None, drop: bool = False) -> xr.Dataset:
    """Every (T, e) run of EN-02F at timestep dt, in one dataset (docs/studies.md); with
    drop, the drop-test dataset instead."""
    if drop:
        return run_drop(cfg)
    dt = cfg.solver.dt if dt is None else dt
    problems = cfg.run_problems(dt)
    grid = output_grid(max(T for T, _, _ in problems), cfg.solver.output_interval)
    datasets, results = [], []
    for _, _, prob in problems:
        res = simulate(prob)
        ds = run_dataset(prob, res)
        ds.attrs.update(event_figures(res))
        datasets.append(ds)
        results.append(res)
    figures = ("flights", "impacts", "flight_time", "max_flight_height", "impact_loss",
               "ends_in_cavity")
    out = stack(datasets, "case", list(range(len(problems))),
                {"long_name": "run index (cycle, restitution)", "units": "1"}, grid, HISTORIES,
                figures)
    out = out.assign_coords(
        cycle=("case", np.array([T for T, _, _ in problems]),
               {"long_name": "cycle length T", "units": "s"}),
        restitution=("case", np.array([e for _, e, _ in problems]),
                     {"long_name": "restitution coefficient e", "units": "1"}))
    out = out.assign(_event_table(results))
    es = list(dict.fromkeys(float(e) for e in cfg.study.restitutions))
    brackets = np.array([cycle_boundary(cfg, dt, e, True) for e in es]).reshape(-1, 2)
    out = out.assign_coords(boundary_restitution=("boundary_restitution", np.array(es), {
        "long_name": "restitution of the cycle-length boundary", "units": "1"}))
    out["boundary_cycle_fail"] = ("boundary_restitution", brackets[:, 0], {
        "long_name": "largest cycle length found at which the sphere does not come back to "
                     "its cavity with flight", "units": "s"})
    out["boundary_cycle_ok"] = ("boundary_restitution", brackets[:, 1], {
        "long_name": "smallest cycle length found at which it does", "units": "s"})
    stop = cycle_boundary(cfg, dt, es[0], False) if es else (math.nan, math.nan)
    default = [i for i, (T, e, _) in enumerate(problems)
               if T == cfg.phases.T and e == cfg.flight.restitution]
    out.attrs.update({
        "dt": dt,
        "method": str(cfg.solver.method),
        "default_case": default[0] if default else 0,
        "resume_speed": cfg.flight.resume_speed,
        "impact_cap": cfg.flight.impact_cap,
        "boundary_cycle_no_flight_fail": stop[0],
        "boundary_cycle_no_flight_ok": stop[1],
        "comment": "extrema over every integration step; histories NaN after a run stops; "
                   "max_energy_residual includes the impact losses",
    })
    if cfg.solver.adaptive:
        rtol, atol = cfg.solver.tolerances(dt)
        out.attrs.update({"rtol": rtol, "atol": atol})
    return out


def run_drop(cfg: En02fConfig) -> xr.Dataset:
    """The drop-test verification dataset: histories, events, and the errors against the
    closed forms (first impact at sqrt(2 h / g), apex ratio e^2)."""
    prob = cfg.drop_problem()
    res = simulate(prob)
    ds = run_dataset(prob, res)
    ds = ds.assign(_event_table([res]))
    kind = res.events.table[:, EV_KIND]
    imp = res.events.table[kind == EV_IMPACT]
    h, g, e = prob.start.height, prob.model.sphere.g, prob.events.restitution
    first = float(imp[0, EV_T]) if len(imp) else math.nan
    heights = imp[:, EV_HEIGHT]
    # apexes clearly above the located-event resolution (the run resumes contact below)
    heights = heights[heights > 1e3 * prob.events.resume_speed ** 2 / (2 * g)]
    ratios = heights[1:] / heights[:-1] if heights.size > 1 else np.empty(0)
    ds.attrs.update(event_figures(res))
    ds.attrs.update({
        "drop_height": h,
        "restitution": e,
        "first_impact_time": first,
        "first_impact_time_exact": math.sqrt(2 * h / g),
        "first_impact_time_error_s": abs(first - math.sqrt(2 * h / g)),
        "apex_ratio_error": float(np.max(np.abs(ratios - e * e))) if ratios.size else math.nan,
        "apex_ratios_checked": int(ratios.size),
        "max_spin_rate": (float(np.nanmax(res.histories.spin_rate)) if res.histories.t.size
                          else math.nan),
    })
    return ds
