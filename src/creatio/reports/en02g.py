"""EN-02G's report (docs/studies.md): EN-02 at each constant inclination and under the
oscillating one. From the study's datasets (configured dt first, then dt / refine) it writes
``en02g.json`` (the contract keys and the per-run figures), ``.md``, ``.png`` (per-run
figures against the inclination), ``_history.csv`` (one row a run), ``_trajectory.png`` and
``_convergence.png`` (dt against dt / refine). :func:`en02g_summary` gives the JSON summary
of one dataset or a dt pair. Nothing here recomputes the study."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import (
    as_list,
    finish_figure,
    finite_max,
    plt,
    run_difference,
    run_header,
    start_report,
    status_counts,
    study_status,
    table,
    value_key,
    write_csv,
    write_markdown,
)

__all__ = ["en02g_summary", "write_en02g"]


def _f(x: Any) -> float:
    return float(x)


_RUN_FIGURES = (
    ("status", "status", str),
    ("stop_time_s", "stop_time", _f),
    ("carried", "carried", bool),
    ("left_cavity_time_s", "left_cavity_time", _f),
    ("angular_displacement_deg", "angular_displacement", _f),
    ("min_normal_reaction_N", "min_normal_reaction", _f),
    ("max_slip_speed_m_s", "max_slip_speed", _f),
    ("cumulative_spin_deg", "cumulative_spin", _f),
    ("cavity_tracking_error_m", "max_cavity_tracking_error", _f),
    ("min_edge_clearance_m", "min_edge_clearance", _f),
    ("energy_residual_J", "max_energy_residual", _f),
    ("max_b_kappa", "max_b_kappa", _f),
    ("initial_radius_m", "initial_radius", _f),
    ("final_radius_m", "final_radius", _f),
    ("equilibrium_R_m", "start_R", _f),
)


def _per_run(ds: xr.Dataset, dim: str, prefix: str, diff: np.ndarray) -> dict[str, dict]:
    out = {}
    for i, x in enumerate(ds[dim].values):
        row = {key: conv(ds[f"{prefix}{var}"].values[i]) for key, var, conv in _RUN_FIGURES}
        row["timestep_difference_m"] = float(diff[i])
        row["equilibrium_offset_m"] = float(ds[f"{prefix}start_R"].values[i]
                                            - ds[f"{prefix}cavity_R"].values[i][0]
                                            if np.isfinite(ds[f"{prefix}cavity_R"].values[i][0])
                                            else math.nan)
        out[value_key(float(x))] = row
    return out


def en02g_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-02G from its datasets (configured dt first; one alone gives no
    timestep difference)."""
    runs = as_list(datasets)
    ds = runs[0]
    n_inc = ds.sizes["inclination"]
    diff = (run_difference(ds.centre, runs[1].centre) if len(runs) > 1
            else np.full(n_inc, math.nan))
    per = _per_run(ds, "inclination", "", diff)
    osc = {}
    if "gamma0" in ds.dims:
        odiff = (run_difference(ds.oscillating_centre, runs[1].oscillating_centre)
                 if len(runs) > 1 else np.full(ds.sizes["gamma0"], math.nan))
        osc = _per_run(ds, "gamma0", "oscillating_", odiff)
    carried_max = math.nan
    for g, row in sorted(per.items(), key=lambda kv: abs(float(kv[0]))):
        if not row["carried"] or row["status"] != "ok":
            break
        carried_max = float(g)
    statuses = [r["status"] for r in (*per.values(), *osc.values())]
    return {
        "study": ds.attrs.get("study", "en02g"),
        "status": study_status(statuses),
        "status_counts": status_counts(statuses),
        "timestep_difference_m": finite_max([r["timestep_difference_m"]
                                          for r in (*per.values(), *osc.values())]),
        "energy_residual_J": finite_max([r["energy_residual_J"]
                                      for r in (*per.values(), *osc.values())]),
        "max_carried_inclination_deg": carried_max,
        "carried_inclinations_deg": [float(g) for g, r in per.items() if r["carried"]
                                     and r["status"] == "ok"],
        "equilibrium_limit_deg": float(ds.attrs.get("equilibrium_limit_deg", math.nan)),
        "per_inclination": per,
        "oscillating": {"amplitude_deg": float(ds.attrs.get("oscillation_amplitude_deg",
                                                            math.nan)),
                        "omega_rad_s": float(ds.attrs.get("oscillation_omega", math.nan)),
                        "per_gamma0": osc},
        "energy_residual_by_dt_J": {repr(float(d.attrs["dt"])): finite_max(np.concatenate(
            [d.max_energy_residual.values,
             d.oscillating_max_energy_residual.values if "gamma0" in d.dims else []]))
            for d in runs},
        "dt_s": [float(d.attrs["dt"]) for d in runs],
        "config_sha256": ds.attrs.get("config_sha256", ""),
    }


def _en02g_figure(ds: xr.Dataset, s: dict, path: Path) -> None:
    per = s["per_inclination"]
    g = np.array([float(k) for k in per])
    panels = [
        ("left cavity at (s)", "left_cavity_time_s"),
        ("angular displacement (deg)", "angular_displacement_deg"),
        ("min normal reaction (N)", "min_normal_reaction_N"),
        ("max slip speed (m/s)", "max_slip_speed_m_s"),
        ("cavity tracking error (m)", "cavity_tracking_error_m"),
        ("min edge clearance (m)", "min_edge_clearance_m"),
        ("equilibrium R - R_c (m)", "equilibrium_offset_m"),
        ("timestep difference (m)", "timestep_difference_m"),
        ("energy residual (J)", "energy_residual_J"),
    ]
    fig, axes = plt.subplots(3, 3, figsize=(13, 9), sharex=True)
    carried = np.array([per[k]["carried"] and per[k]["status"] == "ok" for k in per])
    for ax, (label, key) in zip(axes.flat, panels, strict=True):
        y = np.array([per[k][key] for k in per], float)
        log = key in ("timestep_difference_m", "energy_residual_J")
        plot = ax.semilogy if log else ax.plot
        ok = np.isfinite(y) & (y > 0 if log else True)
        plot(g[ok], y[ok], "-", color="0.6", lw=0.8)
        ax.scatter(g[ok & carried], y[ok & carried], color="tab:blue", s=18, label="carried")
        ax.scatter(g[ok & ~carried], y[ok & ~carried], color="tab:red", s=18,
                   label="not carried")
        if np.isfinite(s["max_carried_inclination_deg"]):
            ax.axvline(s["max_carried_inclination_deg"], color="tab:blue", ls="--", lw=0.8)
        if np.isfinite(s["equilibrium_limit_deg"]):
            ax.axvline(s["equilibrium_limit_deg"], color="k", ls=":", lw=0.8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    axes.flat[0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("inclination gamma (deg)")
    no_eq = [k for k in per if per[k]["status"] == "no_equilibrium"]
    fig.suptitle(f"EN-02G per inclination (dashed: last carried inclination; dotted: "
                 f"equilibrium limit {s['equilibrium_limit_deg']:.2f} deg; no equilibrium at "
                 f"{', '.join(no_eq) or 'none'} deg)", fontsize=10)
    finish_figure(fig, path)


def _en02g_trajectory(ds: xr.Dataset, path: Path) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 6))
    cmap = plt.get_cmap("viridis")
    gs = ds.inclination.values
    for i, g in enumerate(gs):
        X = ds.centre.values[i]
        if not np.isfinite(X).any():
            continue
        c = cmap(i / max(1, len(gs) - 1))
        ax1.plot(X[:, 0], X[:, 1], color=c, lw=0.8, label=f"{g:g} deg")
        ax2.plot(ds.time.values, ds.angular_lag.values[i], color=c, lw=0.8)
    if "gamma0" in ds.dims:
        for j, g0 in enumerate(ds.gamma0.values):
            ax2.plot(ds.time.values, ds.oscillating_angular_lag.values[j], "--", lw=0.8,
                     label=f"oscillating, gamma0 = {g0:g} deg")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.set_title("centre paths in top view (runs with an equilibrium)", fontsize=9)
    ax1.legend(fontsize=7, loc="upper right")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("angular lag: centre azimuth - pattern angle (deg)")
    ax2.legend(fontsize=7)
    ax2.grid(alpha=0.3)
    finish_figure(fig, path)


def _en02g_convergence(runs: Sequence[xr.Dataset], path: Path) -> None:
    ds = runs[0]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4))
    if len(runs) > 1:
        common = np.intersect1d(np.round(ds.time.values, 9), np.round(runs[1].time.values, 9))
        a = ds.centre.sel(time=common, method="nearest").values
        b = runs[1].centre.sel(time=common, method="nearest").values
        d = np.linalg.norm(a - b, axis=-1)
        for i, g in enumerate(ds.inclination.values):
            if np.isfinite(d[i]).any():
                ax1.semilogy(common, np.maximum(d[i], 1e-18), lw=0.8, label=f"{g:g} deg")
        ax1.set_title(f"|X(dt={ds.attrs['dt']:g}) - X(dt={runs[1].attrs['dt']:g})|")
        ax1.legend(fontsize=6, ncol=2)
    for i in range(ds.sizes["inclination"]):
        r = np.abs(ds.energy_residual.values[i])
        if np.isfinite(r).any():
            ax2.semilogy(ds.time.values, np.maximum(r, 1e-20), lw=0.8)
    ax1.set_xlabel("time (s)")
    ax1.set_ylabel("centre-position difference (m)")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("|E - E0 - W + D| (J)")
    ax2.set_title(f"energy residual, every inclination (dt = {ds.attrs['dt']:g} s)")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    finish_figure(fig, path)


def _answer(s: dict, method: str) -> list[str]:
    """EN-02G's plain-word answer, from its summary."""
    per = s["per_inclination"]
    osc = s["oscillating"]["per_gamma0"]
    gammas = ", ".join(per)
    carried = len(s["carried_inclinations_deg"])
    what = (f"one EN-02 cycle on the inclined surface at each constant inclination gamma = "
            f"{gammas} deg, started at its equilibrium"
            + (f", and with gamma oscillating by {num(s['oscillating']['amplitude_deg'], 'deg')}"
               f" around gamma0 = {', '.join(osc)} deg" if osc else "") + ".")
    answer = [f"the sphere is carried through the whole cycle from 0 deg up to "
              f"{num(s['max_carried_inclination_deg'], 'deg')} ({carried} of {len(per)} "
              f"inclinations); an equilibrium exists up to "
              f"{num(s['equilibrium_limit_deg'], 'deg')}."]
    if osc:
        kept = sum(1 for r in osc.values() if r["carried"] and r["status"] == "ok")
        answer.append(f"with the oscillating inclination {kept} of {len(osc)} runs carry it.")
    dts = ", ".join(f"{d:g}" for d in s["dt_s"])
    basis = (f"{method.upper()} at dt = {dts} s (centres differ by at "
             f"most {num(s['timestep_difference_m'], 'm', 3)}, energy residual at most "
             f"{num(s['energy_residual_J'], 'J', 3)}); runs by status: "
             + ", ".join(f"{k} {v}" for k, v in s["status_counts"].items()) + ".")
    return answer_lines(what, answer, basis)


def write_en02g(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en02g.json/.md/.png, _history.csv (per-run figures), _trajectory.png,
    _convergence.png."""
    runs, s, paths = start_report(datasets, outdir, en02g_summary)
    ds = runs[0]
    _en02g_figure(ds, s, paths["png"])
    _en02g_trajectory(ds, paths["trajectory"])
    _en02g_convergence(runs, paths["convergence"])
    keys = ["status", "carried", "left_cavity_time_s", "angular_displacement_deg",
            "min_normal_reaction_N", "max_slip_speed_m_s", "cavity_tracking_error_m",
            "min_edge_clearance_m", "equilibrium_offset_m", "timestep_difference_m",
            "energy_residual_J"]
    rows = [["constant", g, *[r[k] for k in keys]] for g, r in s["per_inclination"].items()]
    rows += [["oscillating", g, *[r[k] for k in keys]]
             for g, r in s["oscillating"]["per_gamma0"].items()]
    write_csv(paths["csv"], ["law", "gamma_or_gamma0_deg", *keys], rows)
    lines = run_header(ds, runs, s["study"])
    lines[2:2] = _answer(s, str(ds.attrs.get("method", "rk4")))
    lines += ["## Summary figures", "",
              *table(["figure", "value"], [
                  ("largest inclination carried (from 0 deg up)",
                   s["max_carried_inclination_deg"]),
                  ("largest inclination with an equilibrium (deg)", s["equilibrium_limit_deg"]),
                  ("runs by status", ", ".join(f"{k}: {v}"
                                               for k, v in s["status_counts"].items())),
                  ("timestep difference, max over runs (m)", s["timestep_difference_m"]),
                  ("energy residual, max over runs (J)", s["energy_residual_J"]),
                  ("status", s["status"])]), "",
              "## Per inclination (constant gamma, equilibrium start)", "",
              *table(["gamma (deg)", "status", "carried", "left cavity (s)", "displacement "
                      "(deg)", "min N (N)", "max slip (m/s)", "tracking (m)", "clearance (m)",
                      "R_eq - R_c (m)", "dt difference (m)", "energy residual (J)"],
                     [(g, *[r[k] for k in keys]) for g, r in s["per_inclination"].items()]),
              "", f"## Oscillating inclination gamma0 + {s['oscillating']['amplitude_deg']:g} "
              f"deg sin({s['oscillating']['omega_rad_s']:g} t)", "",
              *table(["gamma0 (deg)", "status", "carried", "left cavity (s)", "displacement "
                      "(deg)", "min N (N)", "max slip (m/s)", "tracking (m)", "clearance (m)",
                      "R_eq - R_c (m)", "dt difference (m)", "energy residual (J)"],
                     [(g, *[r[k] for k in keys])
                      for g, r in s["oscillating"]["per_gamma0"].items()]),
              "", "The tracking error on the cone includes the static offset of the "
              "equilibrium from the cavity bottom (R_eq - R_c). Extrema are taken over every "
              "integration step.", "",
              f"![per inclination]({paths['png'].name})", "",
              f"![paths and lag]({paths['trajectory'].name})", "",
              f"![convergence]({paths['convergence'].name})", ""]
    write_markdown(paths["md"], "\n".join(lines))
    return paths
