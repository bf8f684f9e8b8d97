"""Report of EN-02F: separation, flight and impact (docs/studies.md, docs/model.md s.11).

From the study's datasets (the (T, e) sweep at the configured dt, then at dt / refine, then
the drop test) the sphere kind's files: ``en02f.json`` (the contract keys for the default
case T = phases.T, e = flight.restitution, the drop test, every case under ``cases`` and
the cycle-length boundaries), ``en02f.md`` (the event statistics per case), ``en02f.png``
(centre height and events per case), ``en02f_history.csv`` (per-case figures),
``en02f_trajectory.png`` (top view with events) and ``en02f_convergence.png`` (the drop
test against its closed forms, and the energy residual at both timesteps). Nothing here
recomputes a study.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import (
    FAILURES,
    finite_max,
    fmt,
    plt,
    run_difference,
    save_figure,
    start_report,
    table,
    write_markdown,
    write_text,
)

__all__ = ["en02f_summary", "write_en02f"]

_KINDS = ("separation", "impact", "contact")
_MARK = {"separation": ("^", "tab:red"), "impact": ("v", "tab:blue"),
         "contact": ("o", "tab:green")}


def _split(datasets: Sequence[xr.Dataset]) -> tuple[list[xr.Dataset], xr.Dataset | None]:
    sweeps = [ds for ds in datasets if "case" in ds.dims]
    drops = [ds for ds in datasets if "drop_height" in ds.attrs]
    return sweeps, (drops[0] if drops else None)


def _case(ds: xr.Dataset, i: int, diff: float) -> dict[str, Any]:
    """The contract figures of case i."""
    return {
        "cycle_s": float(ds.cycle.values[i]),
        "restitution": float(ds.restitution.values[i]),
        "status": str(ds.status.values[i]),
        "stop_time_s": float(ds.stop_time.values[i]),
        "flights": int(ds.flights.values[i]),
        "impacts": int(ds.impacts.values[i]),
        "flight_time_s": float(ds.flight_time.values[i]),
        "max_flight_height_m": float(ds.max_flight_height.values[i]),
        "impact_loss_J": float(ds.impact_loss.values[i]),
        "energy_residual_J": float(ds.max_energy_residual.values[i]),
        "ends_in_cavity": bool(ds.ends_in_cavity.values[i]),
        "left_cavity_time_s": float(ds.left_cavity_time.values[i]),
        "timestep_difference_m": diff,
    }


def en02f_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-02F: the default case's figures at the top, every case under
    ``cases`` (keyed T_e), the drop test, the cycle-length boundaries."""
    runs = [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)
    sweeps, drop = _split(runs)
    out: dict[str, Any] = {"study": "en02f"}
    if sweeps:
        ds = sweeps[0]
        diff = (run_difference(ds.centre, sweeps[1].centre) if len(sweeps) > 1
                else np.full(ds.sizes["case"], math.nan))
        cases = {f"{float(ds.cycle.values[i]):g}_{float(ds.restitution.values[i]):g}":
                 _case(ds, i, float(diff[i])) for i in range(ds.sizes["case"])}
        default = ds.attrs.get("default_case", 0)
        top = _case(ds, int(default), float(diff[int(default)]))
        failed = any(c["status"] in (*FAILURES, "foot_point_failed") for c in cases.values())
        out.update({k: v for k, v in top.items() if k not in ("status",)})
        out["status"] = "failed" if failed else "ok"
        out["cases"] = cases
        out["dt"] = float(ds.attrs["dt"])
        out["method"] = str(ds.attrs["method"])
        out["boundary"] = {
            "with_flight": {f"{float(e):g}": [float(a), float(b)] for e, a, b in zip(
                ds.boundary_restitution.values, ds.boundary_cycle_fail.values,
                ds.boundary_cycle_ok.values, strict=True)},
            "without_flight": [float(ds.attrs["boundary_cycle_no_flight_fail"]),
                               float(ds.attrs["boundary_cycle_no_flight_ok"])],
        }
    if drop is not None:
        out["drop_test"] = {
            "first_impact_time_error_s": float(drop.attrs["first_impact_time_error_s"]),
            "apex_ratio_error": float(drop.attrs["apex_ratio_error"]),
            "apex_ratios_checked": int(drop.attrs["apex_ratios_checked"]),
            "impacts": int(drop.attrs["impacts"]),
            "max_spin_rate_rad_s": float(drop.attrs["max_spin_rate"]),
            "energy_residual_J": float(drop.attrs["max_energy_residual"]),
            "status": str(drop.attrs["status"]),
        }
    return out


def _events(ds: xr.Dataset, i: int) -> xr.Dataset:
    return ds.isel(event=np.flatnonzero(ds.event_case.values == i))


def _figure(ds: xr.Dataset, path: Path) -> None:
    """Centre height against time for each case, events marked."""
    n = ds.sizes["case"]
    Ts = sorted(set(ds.cycle.values.tolist()), reverse=True)
    es = sorted(set(ds.restitution.values.tolist()))
    fig, axes = plt.subplots(len(es), 1, figsize=(10, 3.2 * len(es)), squeeze=False)
    for j, e in enumerate(es):
        ax = axes[j, 0]
        for i in range(n):
            if float(ds.restitution.values[i]) != e:
                continue
            T = float(ds.cycle.values[i])
            line, = ax.plot(ds.time, ds.centre.values[i, :, 2], lw=1,
                            label=f"T = {T:g} s ({ds.status.values[i]})")
            ev = _events(ds, i)
            for k, name in enumerate(_KINDS):
                sel = ev.event_kind.values == k
                m, c = _MARK[name]
                ax.plot(ev.event_time.values[sel], ev.event_centre.values[sel, 2], m, color=c,
                        ms=5, label=name if T == Ts[0] else None)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("centre height z (m)")
        ax.set_title(f"EN-02F, e = {e:g}: events (separation ^, impact v, contact o)")
        ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _trajectory(ds: xr.Dataset, path: Path) -> None:
    """Top view of the centre paths, annulus edges and events."""
    fig, ax = plt.subplots(figsize=(7, 7))
    a = np.linspace(0, 2 * np.pi, 400)
    for r in (0.68, 0.68 + 1.72):
        ax.plot(r * np.cos(a), r * np.sin(a), color="0.6", lw=0.8)
    for i in range(ds.sizes["case"]):
        x = ds.centre.values[i]
        ax.plot(x[:, 0], x[:, 1], lw=1, label=f"T = {float(ds.cycle.values[i]):g} s, "
                f"e = {float(ds.restitution.values[i]):g}")
        ev = _events(ds, i)
        for k, name in enumerate(_KINDS):
            sel = ev.event_kind.values == k
            m, c = _MARK[name]
            ax.plot(ev.event_centre.values[sel, 0], ev.event_centre.values[sel, 1], m,
                    color=c, ms=4)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("EN-02F centre paths (annulus edges grey; events marked)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _convergence(sweeps: Sequence[xr.Dataset], drop: xr.Dataset | None, path: Path) -> None:
    """The drop test against its closed forms, and the energy residual at both timesteps."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.2))
    if drop is not None:
        h0 = float(drop.attrs["drop_height"])
        e = float(drop.attrs["restitution"])
        b = float(drop.centre.values[0, 2]) - h0
        a1.plot(drop.time, drop.centre.values[:, 2] - b, lw=1, label="gap (centre height - b)")
        imp = drop.event_kind.values == 1
        heights = drop.event_flight_height.values[imp]
        times = drop.event_time.values[imp]
        a1.plot(times, heights, "v", color="tab:blue", label="located flight heights")
        k = np.arange(heights.size)
        a1.plot(times, h0 * (e * e) ** k, "x", color="k", label="h e^(2k) (closed form)")
        t1 = math.sqrt(2 * h0 / 9.81)
        a1.axvline(t1, color="0.5", ls=":", label="sqrt(2h/g)")
        a1.set_title(f"drop test: first impact error {fmt(drop.attrs['first_impact_time_error_s'])}"
                     f" s, apex ratio error {fmt(drop.attrs['apex_ratio_error'])}", fontsize=9)
        a1.set_xlabel("t (s)")
        a1.set_ylabel("m")
        a1.legend(fontsize=7)
    for ds in sweeps:
        for i in range(ds.sizes["case"]):
            r = np.abs(ds.energy_residual.values[i])
            a2.semilogy(ds.time, np.where(r > 0, r, np.nan), lw=0.8,
                        label=f"T = {float(ds.cycle.values[i]):g}, e = "
                        f"{float(ds.restitution.values[i]):g}, dt = {ds.attrs['dt']:g}")
    a2.set_xlabel("t (s)")
    a2.set_ylabel("|E - E0 - W + D + impact losses| (J)")
    a2.set_title("energy balance with impact losses", fontsize=9)
    a2.legend(fontsize=5, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _answer(s: dict, sweeps: Sequence[xr.Dataset]) -> list[str]:
    """EN-02F's plain-word answer, from its summary."""
    what, answers, basis = [], [], []
    cases = list(s.get("cases", {}).values())
    if cases:
        Ts = sorted({c["cycle_s"] for c in cases})
        es = sorted({c["restitution"] for c in cases})
        what.append(f"one cycle of each length T = {', '.join(f'{t:g}' for t in Ts)} s at "
                    f"restitution e = {', '.join(f'{e:g}' for e in es)}, the sphere free to "
                    "leave the surface, fly and land")
        kept = sum(c["ends_in_cavity"] for c in cases)
        flew = [c for c in cases if c["flights"] > 0]
        highest = max((c["max_flight_height_m"] for c in flew), default=math.nan)
        bounds = "; ".join(f"e = {e}: fails at T = {num(a, 's')}, carried again from "
                           f"{num(b, 's')}" for e, (a, b) in s["boundary"]["with_flight"].items())
        nf = s["boundary"]["without_flight"]
        answers.append(f"{kept} of {len(cases)} cases end the cycle in their starting cavity; "
                       f"{len(flew)} leave the surface at least once"
                       + (f" (highest flight {num(highest, 'm')})" if flew else "") + ".")
        answers.append(f"boundary along T with flight: {bounds}; without flight contact is "
                       f"lost at T = {num(nf[0], 's')} and kept from {num(nf[1], 's')}.")
        diff = finite_max([c["timestep_difference_m"] for c in cases])
        residual = finite_max([c["energy_residual_J"] for c in cases])
        basis.append(f"{s['method'].upper()} at dt = {num(s['dt'], 's')}"
                     + (f" against dt = {num(float(sweeps[1].attrs['dt']), 's')} (centres "
                        f"differ by at most {num(diff, 'm', 3)})" if len(sweeps) > 1 else "")
                     + f", energy residual at most {num(residual, 'J', 3)}")
    if "drop_test" in s:
        d = s["drop_test"]
        what.append("a drop on a flat still surface")
        answers.append(f"the drop test lands within {num(d['first_impact_time_error_s'], 's', 3)}"
                       f" of free fall and bounces to e^2 of its height within "
                       f"{num(d['apex_ratio_error'], digits=3)} over {d['apex_ratios_checked']} "
                       "bounces.")
        basis.append("the drop test's closed forms sqrt(2h/g) and e^2")
    if not answers:
        return []
    return answer_lines("; ".join(what) + ".", answers[:3], "; ".join(basis) + ".")


def write_en02f(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en02f.json/.md/.png, _history.csv (per-case figures), _trajectory.png,
    _convergence.png."""
    runs, s, paths = start_report(datasets, outdir, en02f_summary)
    sweeps, drop = _split(runs)
    keys = ["status", "stop_time_s", "flights", "impacts", "flight_time_s",
            "max_flight_height_m", "impact_loss_J", "energy_residual_J", "ends_in_cavity",
            "timestep_difference_m"]
    cases = s.get("cases", {})
    rows = [(c["cycle_s"], c["restitution"], *[c[k] for k in keys]) for c in cases.values()]
    header = ["cycle_s", "restitution", *keys]
    write_text(paths["csv"], "\n".join([",".join(header)] + [",".join(
        str(float(v)) if isinstance(v, float) else str(v) for v in row) for row in rows]) + "\n")
    if sweeps:
        _figure(sweeps[0], paths["png"])
        _trajectory(sweeps[0], paths["trajectory"])
    _convergence(sweeps, drop, paths["convergence"])
    ds = sweeps[0] if sweeps else drop
    lines = [f"# {ds.attrs.get('title', 'EN-02F separation, flight and impact')}", "",
             *_answer(s, sweeps)]
    if sweeps:
        lines += [f"{s['method'].upper()} at dt = {s['dt']:g} s"
                  + (f", compared with dt = {sweeps[1].attrs['dt']:g} s" if len(sweeps) > 1
                     else "") + "; every run is one cycle of its T, started at rest at a "
                  "cavity bottom, flight on (docs/model.md s.11).", "",
                  "## Event statistics per case", "",
                  *table(["T (s)", "e", "status", "stop (s)", "flights", "impacts",
                          "flight time (s)", "max height (m)", "impact loss (J)",
                          "energy residual (J)", "ends in cavity", "dt difference (m)"], rows),
                  "", "Impact loss is the mechanical energy lost at impacts and at the "
                  "resumptions of contact; on the moving membrane it can be negative (the "
                  "membrane strikes the sphere and gives it energy). The energy residual "
                  "includes these losses. Height: the largest gap between the sphere and the "
                  "surface during a flight.", "",
                  "## Boundary along T", "",
                  *table(["", "fails at T (s)", "comes back at T (s)"],
                         [(f"flight, e = {e}", a, b)
                          for e, (a, b) in s["boundary"]["with_flight"].items()]
                         + [("no flight (contact_lost)", *s["boundary"]["without_flight"])]),
                  "", "With flight the boundary is where the sphere no longer ends the cycle "
                  "in contact inside its starting cavity's cell; without flight, where "
                  "contact is lost. Bisected from the sweep's neighbouring cycles to 1e-3 "
                  "relative, T a multiple of dt.", ""]
    if "drop_test" in s:
        d = s["drop_test"]
        lines += ["## Drop test (flat, still surface)", "",
                  *table(["figure", "value"], [
                      ("first impact time error vs sqrt(2h/g) (s)",
                       d["first_impact_time_error_s"]),
                      ("apex ratio error vs e^2 (max over bounces)", d["apex_ratio_error"]),
                      ("bounces checked", d["apex_ratios_checked"]),
                      ("impacts", d["impacts"]),
                      ("max spin rate (rad/s)", d["max_spin_rate_rad_s"]),
                      ("energy residual (J)", d["energy_residual_J"]),
                      ("status", d["status"])]), ""]
    lines += [f"![events]({paths['png'].name})", "",
              f"![paths]({paths['trajectory'].name})", "",
              f"![verification]({paths['convergence'].name})", ""]
    write_markdown(paths["md"], "\n".join(lines))
    return paths
