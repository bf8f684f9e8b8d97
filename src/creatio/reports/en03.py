"""EN-03's report (docs/studies.md): EN-02 on a structure free to yaw, the inertia sweep and
the fixed-structure limit. From the study's datasets it writes ``en03.json``, ``.md``,
``.png``, ``_history.csv`` (the single run's histories), ``_trajectory.png`` (centre paths in
the structure's and the world frame) and ``_convergence.png``. :func:`en03_summary` gives the
JSON summary. Nothing here recomputes the study."""

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
    fmt,
    paths_figure,
    plt,
    run_difference,
    run_header,
    start_report,
    table,
    value_key,
    write_markdown,
)
from creatio.reports.sphere import history_csv

__all__ = ["en03_summary", "write_en03"]


def _single(ds: xr.Dataset, other: xr.Dataset | None) -> dict[str, Any]:
    """EN-03's figures of one single-run dataset (its dt / refine partner, if given)."""
    a = ds.attrs
    az = ds.centre_azimuth.values
    return {
        "status": str(a["status"]),
        "stop_time_s": float(a["stop_time"]),
        "structure_inertia_kg_m2": float(a["structure_inertia"]),
        "structure_rotation_deg": float(a["structure_rotation"]),
        "structure_rotation_point_mass_deg": float(a["structure_rotation_point_mass"]),
        "angular_displacement_deg": float(az[-1] - az[0]) if az.size else math.nan,
        "world_angular_displacement_deg": float(a["world_angular_displacement"]),
        "angular_momentum_drift": float(a["max_hz_drift"]),
        "angular_momentum_scale": float(a["hz_scale"]),
        "max_structure_rate_rad_s": float(a["max_structure_rate"]),
        "energy_residual_J": float(a["max_energy_residual"]),
        "timestep_difference_m": (float(run_difference(ds.centre, other.centre))
                                  if other is not None else math.nan),
        "min_normal_reaction_N": float(a["min_normal_reaction"]),
        "max_slip_speed_m_s": float(a["max_slip_speed"]),
        "cumulative_spin_deg": (float(ds.cumulative_spin.values[-1])
                                if ds.time.size else math.nan),
        "initial_radius_m": float(ds.centre_radius.values[0]) if ds.time.size else math.nan,
        "left_cavity_time_s": float(a["left_cavity_time"]),
        "carried": bool(a["carried"]),
        "confinement": str(a.get("confinement", "none")),
        "confining_force_N": float(a.get("confining_force", 0.0)),
    }


def en03_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-03 from its datasets in part order (single run at dt, at dt /
    refine, inertia sweep at dt, at dt / refine); any prefix of them works."""
    runs = as_list(datasets)
    singles = [d for d in runs if d.attrs.get("part", "single") == "single"]
    sweeps = [d for d in runs if d.attrs.get("part") == "inertia_sweep"]
    ds = singles[0]
    out: dict[str, Any] = {"study": ds.attrs.get("study", "en03")}
    out.update(_single(ds, singles[1] if len(singles) > 1 else None))
    out["dt_s"] = [float(d.attrs["dt"]) for d in singles]
    if sweeps:
        sw = sweeps[0]
        diff = (run_difference(sw.centre, sweeps[1].centre) if len(sweeps) > 1
                else np.full(sw.sizes["structure_inertia"], math.nan))
        table_ = {}
        for i, v in enumerate(sw.structure_inertia.values):
            table_[value_key(float(v))] = {
                "status": str(sw.status.values[i]),
                "structure_rotation_deg": float(sw.structure_rotation.values[i]),
                "structure_rotation_point_mass_deg":
                    float(sw.structure_rotation_point_mass.values[i]),
                "angular_displacement_deg": float(sw.angular_displacement.values[i]),
                "world_angular_displacement_deg": float(sw.world_angular_displacement.values[i]),
                "angular_momentum_drift": float(sw.max_hz_drift.values[i]),
                "angular_momentum_scale": float(sw.hz_scale.values[i]),
                "max_structure_rate_rad_s": float(sw.max_structure_rate.values[i]),
                "energy_residual_J": float(sw.max_energy_residual.values[i]),
                "timestep_difference_m": float(diff[i]),
            }
        # the sweep's own runs first, then the limit check: limit_inertia and inf
        n = int(sw.attrs.get("sweep_runs", sw.sizes["structure_inertia"]))
        out["inertia_sweep"] = dict(list(table_.items())[:n])
        iv = list(sw.structure_inertia.values)
        if len(iv) == n + 2:
            i, j = n, n + 1
            limit = float(iv[i])
            X = sw.centre.values
            out["limit_check"] = {
                "structure_inertia_kg_m2": limit,
                "difference_from_fixed_m": finite_max(np.linalg.norm(X[i] - X[j], axis=-1)),
                "fixed_timestep_difference_m": float(diff[j]),
                "structure_rotation_deg": float(sw.structure_rotation.values[i]),
            }
    out["config_sha256"] = ds.attrs.get("config_sha256", "")
    return out


def _en03_figure(runs: Sequence[xr.Dataset], s: dict, path: Path) -> None:
    ds = runs[0]
    t = ds.time.values
    hz = ds.hz.values
    panels = [
        ("structure yaw theta (deg)", ds.theta.values),
        ("yaw rate Theta (rad/s)", ds.theta_rate.values),
        ("azimuth: relative / world (deg)", None),
        ("H_z parts (kg m^2/s)", None),
        ("H_z - H_z(0) (kg m^2/s)", hz - hz[0] if hz.size else hz),
        ("energy residual (J)", ds.energy_residual.values),
    ]
    sweep = [d for d in runs if d.attrs.get("part") == "inertia_sweep"]
    rows = 3 if sweep else 2
    fig, axes = plt.subplots(rows, 3, figsize=(13, 3.2 * rows))
    for ax, (label, y) in zip(axes.flat, panels, strict=False):
        if label.startswith("azimuth"):
            ax.plot(t, ds.centre_azimuth.values, label="relative to the structure")
            ax.plot(t, ds.world_azimuth.values, label="world")
            ax.legend(fontsize=8)
        elif label.startswith("H_z parts"):
            for name, lab in (("hz_structure", "I_s Theta"), ("hz_orbital", "orbital"),
                              ("hz_spin", "spin")):
                ax.plot(t, ds[name].values, label=lab)
            ax.legend(fontsize=8)
        else:
            ax.plot(t, y, lw=1.0)
        ax.set_ylabel(label)
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    if sweep:
        table_ = s["inertia_sweep"]
        inertia = np.array([float(k) for k in table_])
        rot = np.array([v["structure_rotation_deg"] for v in table_.values()])
        pm = np.array([v["structure_rotation_point_mass_deg"] for v in table_.values()])
        drift = np.array([v["angular_momentum_drift"] for v in table_.values()])
        scale = np.array([v["angular_momentum_scale"] for v in table_.values()])
        ax = axes[2, 0]
        ax.semilogx(inertia, rot, "o-", label="computed")
        ax.semilogx(inertia, pm, "x--", label="point-mass estimate")
        ax.set_xlabel("I_s (kg m^2)")
        ax.set_ylabel("final structure angle (deg)")
        ax.legend(fontsize=8)
        ax = axes[2, 1]
        ax.semilogx(inertia, rot - pm, "o-")
        ax.set_xlabel("I_s (kg m^2)")
        ax.set_ylabel("computed - point mass (deg)")
        ax = axes[2, 2]
        ax.loglog(inertia, np.maximum(drift, 1e-20), "o-", label="H_z drift")
        ax.loglog(inertia, scale, "s--", label="scale max |I_s Theta|")
        ax.set_xlabel("I_s (kg m^2)")
        ax.legend(fontsize=8)
        for ax in axes[2]:
            ax.grid(alpha=0.3, which="both")
    fig.suptitle(f"EN-03 (I_s = {s['structure_inertia_kg_m2']:g} kg m^2, dt = "
                 f"{ds.attrs['dt']:g} s, status {s['status']})", fontsize=10)
    finish_figure(fig, path)


def _en03_convergence(singles: Sequence[xr.Dataset], path: Path) -> None:
    ds = singles[0]
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4))
    if len(singles) > 1:
        other = singles[1]
        common = np.intersect1d(np.round(ds.time.values, 9), np.round(other.time.values, 9))
        d = np.linalg.norm(ds.centre.sel(time=common, method="nearest").values
                           - other.centre.sel(time=common, method="nearest").values, axis=-1)
        ax1.semilogy(common, np.maximum(d, 1e-18))
        ax1.set_title(f"|X(dt={ds.attrs['dt']:g}) - X(dt={other.attrs['dt']:g})|")
    for d in singles:
        ax2.semilogy(d.time.values, np.maximum(np.abs(d.energy_residual.values), 1e-20),
                     label=f"dt = {d.attrs['dt']:g} s")
        hz = d.hz.values
        ax3.semilogy(d.time.values, np.maximum(np.abs(hz - hz[0]), 1e-20),
                     label=f"dt = {d.attrs['dt']:g} s")
    ax1.set_ylabel("centre-position difference (m)")
    ax2.set_ylabel("|E - E0 - W + D (- W_confine)| (J)")
    ax3.set_ylabel("|H_z - H_z(0)| (kg m^2/s)")
    for ax in (ax1, ax2, ax3):
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3, which="both")
    ax2.legend(fontsize=8)
    ax3.legend(fontsize=8)
    finish_figure(fig, path)


def _answer(s: dict, method: str) -> list[str]:
    """EN-03's plain-word answer, from its summary."""
    what = (f"the EN-02 cycle on a structure free to turn about its axis (inertia I_s = "
            f"{num(s['structure_inertia_kg_m2'], 'kg m^2')}), the sphere's reaction turning it"
            + (f", and over {len(s['inertia_sweep'])} inertias" if "inertia_sweep" in s else "")
            + ".")
    fate = ("the sphere is carried" if s["carried"] else
            f"the sphere is lost (it leaves its cavity at {num(s['left_cavity_time_s'], 's')})")
    answer = [f"the structure turns {num(s['structure_rotation_deg'], 'deg')} (point-mass "
              f"estimate {num(s['structure_rotation_point_mass_deg'], 'deg')}); {fate}, "
              f"{num(s['angular_displacement_deg'], 'deg')} around the structure and "
              f"{num(s['world_angular_displacement_deg'], 'deg')} in the world."]
    if "inertia_sweep" in s:
        answer.append("over the inertia sweep the structure turns " + ", ".join(
            f"{num(v['structure_rotation_deg'], 'deg')} at I_s = {k} kg m^2"
            for k, v in s["inertia_sweep"].items()) + ".")
    dts = ", ".join(f"{d:g}" for d in s["dt_s"])
    basis = (f"{method.upper()} at dt = {dts} s (centres differ by "
             f"{num(s['timestep_difference_m'], 'm', 3)}); angular momentum H_z kept to "
             f"{num(s['angular_momentum_drift'], 'kg m^2/s', 3)} of "
             f"{num(s['angular_momentum_scale'], 'kg m^2/s', 3)}; energy residual "
             f"{num(s['energy_residual_J'], 'J', 3)}.")
    return answer_lines(what, answer, basis)


def write_en03(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en03.json/.md/.png, _history.csv (the single run), _trajectory.png,
    _convergence.png."""
    runs, s, paths = start_report(datasets, outdir, en03_summary)
    singles = [d for d in runs if d.attrs.get("part", "single") == "single"]
    ds = singles[0]
    _en03_figure(runs, s, paths["png"])
    paths_figure([(f"I_s = {s['structure_inertia_kg_m2']:g} kg m^2", ds)],
                  paths["trajectory"], "EN-03: the sphere's centre relative to the structure "
                  "and in the world")
    _en03_convergence(singles, paths["convergence"])
    history_csv(ds, paths["csv"])
    rows = [
        ("structure inertia I_s (kg m^2)", s["structure_inertia_kg_m2"]),
        ("final structure angle (deg)", s["structure_rotation_deg"]),
        ("point-mass estimate (deg)", s["structure_rotation_point_mass_deg"]),
        ("angular displacement relative to the structure (deg)",
         s["angular_displacement_deg"]),
        ("angular displacement in the world (deg)", s["world_angular_displacement_deg"]),
        ("max |Theta| (rad/s)", s["max_structure_rate_rad_s"]),
        ("H_z drift max |H_z - H_z(0)| (kg m^2/s)", s["angular_momentum_drift"]),
        ("H_z scale max |I_s Theta| (kg m^2/s)", s["angular_momentum_scale"]),
        ("energy residual (J)", s["energy_residual_J"]),
        ("timestep difference (m)", s["timestep_difference_m"]),
        ("minimum normal reaction (N)", s["min_normal_reaction_N"]),
        ("carried (left cavity at, s)", f"{s['carried']} ({fmt(s['left_cavity_time_s'])})"),
        ("status", s["status"]),
    ]
    lines = run_header(ds, singles, s["study"])
    lines[2:2] = _answer(s, str(ds.attrs.get("method", "rk4")))
    lines += ["## Summary figures", ""]
    lines += table(["figure", "value"], rows)
    if "inertia_sweep" in s:
        lines += ["", "## Inertia sweep", "",
                  *table(["I_s (kg m^2)", "final angle (deg)", "point mass (deg)",
                          "world displacement (deg)", "H_z drift", "H_z scale",
                          "energy residual (J)", "dt difference (m)", "status"],
                         [(k, v["structure_rotation_deg"],
                           v["structure_rotation_point_mass_deg"],
                           v["world_angular_displacement_deg"], v["angular_momentum_drift"],
                           v["angular_momentum_scale"], v["energy_residual_J"],
                           v["timestep_difference_m"], v["status"])
                          for k, v in s["inertia_sweep"].items()])]
    if "limit_check" in s:
        lc = s["limit_check"]
        lines += ["", f"**I_s -> infinity:** at I_s = {lc['structure_inertia_kg_m2']:g} kg m^2 "
                  f"the centre (structure frame) differs from the fixed structure's by at most "
                  f"{fmt(lc['difference_from_fixed_m'])} m; the fixed structure's timestep "
                  f"difference is {fmt(lc['fixed_timestep_difference_m'])} m (structure turned "
                  f"{fmt(lc['structure_rotation_deg'])} deg)."]
    lines += ["", "The point-mass estimate uses the centre's initial horizontal radius and the "
              "simulated displacement relative to the structure (docs/model.md s.9.5).", "",
              f"![histories]({paths['png'].name})", "",
              f"![paths]({paths['trajectory'].name})", "",
              f"![convergence]({paths['convergence'].name})", ""]
    write_markdown(paths["md"], "\n".join(lines))
    return paths
