"""Reports of the studies beyond the notebook (EN-02G, EN-03, EN-03M; docs/studies.md).

Each writer derives, from its study's datasets (configured dt first, then dt / refine), the
sphere kind's files: ``<id>.json`` (the contract keys of issue 16 and more), ``<id>.md``,
``<id>.png`` (the study's main figure), ``<id>_history.csv`` (a table: per-run figures for
EN-02G, the single run's histories for EN-03, the search's runs for EN-03M),
``<id>_trajectory.png`` and ``<id>_convergence.png`` (dt vs dt / refine and the conservation
checks). ``*_summary`` give the JSON summary of one dataset or of a dt pair (a sweep
aggregates its scalar figures). Nothing here recomputes a study.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.ticker import ScalarFormatter

from creatio.reports.common import (
    fmt,
    plt,
    save_figure,
    strict_json,
    table,
    write_markdown,
    write_text,
)
from creatio.reports.sphere import history_csv
from creatio.store.atomic import atomic_write

__all__ = ["en02g_summary", "en03_summary", "en03m_summary", "run_difference",
           "write_en02g", "write_en03", "write_en03m"]

#: Statuses of a numerical failure (the others are physical outcomes, recorded per run).
FAILURES = ("non_finite", "step_failed")


# ------------------------------------------------------------------------------ shared
def _as_list(datasets: xr.Dataset | Sequence[xr.Dataset]) -> list[xr.Dataset]:
    return [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)


def run_difference(coarse: xr.DataArray, fine: xr.DataArray) -> np.ndarray:
    """Max over the common output times of |centre_coarse - centre_fine| for each run of a
    stacked centre (run, time, component) or one run (time, component); NaN where a run has
    no common sample (before the last dim pair: any leading run dimensions are kept)."""
    common = np.intersect1d(np.round(coarse.time.values, 9), np.round(fine.time.values, 9))
    a = coarse.sel(time=common, method="nearest").values
    b = fine.sel(time=common, method="nearest").values
    d = np.linalg.norm(a - b, axis=-1)
    with np.errstate(all="ignore"):
        finite = np.isfinite(d)
        out = np.where(finite.any(axis=-1), np.nanmax(np.where(finite, d, -np.inf), axis=-1),
                       np.nan)
    return out


def _nanmax(values: Any) -> float:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(v.max()) if v.size else math.nan


def _status(statuses: Sequence[str]) -> str:
    """A study's status: "ok" unless one of its runs failed numerically."""
    return "failed" if any(s in FAILURES for s in statuses) else "ok"


def _counts(statuses: Sequence[str]) -> dict[str, int]:
    out: dict[str, int] = {}
    for s in statuses:
        out[str(s)] = out.get(str(s), 0) + 1
    return out


def _key(x: float) -> str:
    """A coordinate value as a JSON key: 5, 0.5, inf."""
    return "inf" if math.isinf(x) else f"{x:g}"


def _f(x: Any) -> float:
    return float(x)


def _pair_line(runs: Sequence[xr.Dataset]) -> str:
    a = runs[0].attrs
    method = str(a.get("method", "rk4"))
    if "rtol" in a:
        return (f"{method} (adaptive) at rtol = {a['rtol']:g} compared with rtol = "
                f"{runs[-1].attrs.get('rtol', math.nan):g}")
    return f"{method.upper()} at dt = {a['dt']:g} s compared with dt = {runs[-1].attrs['dt']:g} s"


def _header(ds: xr.Dataset, runs: Sequence[xr.Dataset], study: str) -> list[str]:
    return [f"# {ds.attrs.get('title', study)}", "",
            f"{_pair_line(runs)}; config sha256 `{ds.attrs.get('config_sha256', '')[:12]}`, "
            f"creatio {ds.attrs.get('creatio_version')}, commit "
            f"{str(ds.attrs.get('git_commit', ''))[:10]}.", ""]


def _write_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
    with atomic_write(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(header))
        w.writerows([[v if not isinstance(v, float | np.floating) else float(v) for v in row]
                     for row in rows])


def _paths(outdir: Path, study: str) -> dict[str, Path]:
    return {"json": outdir / f"{study}.json", "md": outdir / f"{study}.md",
            "html": outdir / f"{study}.html", "png": outdir / f"{study}.png",
            "csv": outdir / f"{study}_history.csv",
            "trajectory": outdir / f"{study}_trajectory.png",
            "convergence": outdir / f"{study}_convergence.png"}


def _load(datasets: Sequence[Path]) -> tuple[list[xr.Dataset], dict]:
    from creatio.store.netcdf import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    return [ds for ds, _ in loaded], loaded[0][1]


def _start(datasets: Sequence[Path], outdir: str | Path,
           summary: Any) -> tuple[list[xr.Dataset], dict, dict[str, Path]]:
    """What every writer here does first: load the datasets, summarise them with
    summary(runs), write the JSON contract; returns (runs, summary, output paths)."""
    runs, _ = _load(datasets)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    s = summary(runs)
    paths = _paths(outdir, s["study"])
    write_text(paths["json"], strict_json(s))
    return runs, s, paths


def _finish(fig: Any, path: Path) -> None:
    """Save and close a figure, with no offset notation on any linear y axis (an offset
    such as 1e-6 - 3.6e2 hides the values a reader looks for)."""
    for ax in fig.axes:
        if isinstance(ax.yaxis.get_major_formatter(), ScalarFormatter):
            ax.ticklabel_format(axis="y", useOffset=False)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


# ------------------------------------------------------------------------------ EN-02G
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
        out[_key(float(x))] = row
    return out


def en02g_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-02G from its datasets (configured dt first; one alone gives no
    timestep difference)."""
    runs = _as_list(datasets)
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
        "status": _status(statuses),
        "status_counts": _counts(statuses),
        "timestep_difference_m": _nanmax([r["timestep_difference_m"]
                                          for r in (*per.values(), *osc.values())]),
        "energy_residual_J": _nanmax([r["energy_residual_J"]
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
        "energy_residual_by_dt_J": {repr(float(d.attrs["dt"])): _nanmax(np.concatenate(
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
    _finish(fig, path)


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
    _finish(fig, path)


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
    _finish(fig, path)


def write_en02g(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en02g.json/.md/.png, _history.csv (per-run figures), _trajectory.png,
    _convergence.png."""
    runs, s, paths = _start(datasets, outdir, en02g_summary)
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
    _write_csv(paths["csv"], ["law", "gamma_or_gamma0_deg", *keys], rows)
    lines = _header(ds, runs, s["study"])
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


# ------------------------------------------------------------------------------ EN-03
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
    runs = _as_list(datasets)
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
            table_[_key(float(v))] = {
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
                "difference_from_fixed_m": _nanmax(np.linalg.norm(X[i] - X[j], axis=-1)),
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
    _finish(fig, path)


def _paths_figure(named: Sequence[tuple[str, xr.Dataset]], path: Path, title: str) -> None:
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 6))
    for label, ds in named:
        X = ds.centre.values
        W = ds.world_centre.values if "world_centre" in ds else X
        ax1.plot(X[:, 0], X[:, 1], lw=0.8, label=label)
        ax2.plot(W[:, 0], W[:, 1], lw=0.8, label=label)
    for ax, name in ((ax1, "in the structure's frame"), (ax2, "in the world frame")):
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"centre path {name}", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    _finish(fig, path)


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
    _finish(fig, path)


def write_en03(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en03.json/.md/.png, _history.csv (the single run), _trajectory.png,
    _convergence.png."""
    runs, s, paths = _start(datasets, outdir, en03_summary)
    singles = [d for d in runs if d.attrs.get("part", "single") == "single"]
    ds = singles[0]
    _en03_figure(runs, s, paths["png"])
    _paths_figure([(f"I_s = {s['structure_inertia_kg_m2']:g} kg m^2", ds)],
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
    lines = _header(ds, singles, s["study"]) + ["## Summary figures", ""]
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


# ------------------------------------------------------------------------------ EN-03M
def _confinement_work(ds: xr.Dataset, i: int, j: int, kind: str, force: float) -> float:
    """The confining force's work over the figure run: normal, the accumulated
    integral of -P n . c_t; base, the pull's potential drop -P (z_X(end) - z_X(0))."""
    if kind == "normal":
        w = ds.confinement_work.values[i, j]
        w = w[np.isfinite(w)]
        return float(w[-1]) if w.size else math.nan
    z = ds.centre.values[i, j, :, 2]
    z = z[np.isfinite(z)]
    return float(-force * (z[-1] - z[0])) if z.size else math.nan


def _search_figures(ds: xr.Dataset, i: int, j: int) -> dict[str, Any]:
    """How far the search's runs carried the sphere: the carrying run's angle, or the
    farthest non-carrying one's, with the lag reached there."""
    carried = ds.probe_carried.values[i, j].astype(bool)
    angle = ds.probe_angle.values[i, j]
    lag = ds.probe_lag.values[i, j]
    force = ds.probe_force.values[i, j]
    if carried.any():
        q = int(np.flatnonzero(carried)[0])
    else:
        finite = np.isfinite(angle)
        if not finite.any():
            return {"carried_angle_deg": math.nan, "lag_deg": math.nan,
                    "farthest_force_N": math.nan}
        q = int(np.nanargmax(np.where(finite, np.abs(angle), -np.inf)))
    return {"carried_angle_deg": float(angle[q]), "lag_deg": float(lag[q]),
            "farthest_force_N": float(force[q])}


def _en03m_cell(ds: xr.Dataset, other: xr.Dataset | None, i: int, j: int) -> dict[str, Any]:
    kind = str(ds.confinement.values[i])
    force = float(ds.figure_force.values[i, j])
    az = ds.centre_azimuth.values[i, j]
    az = az[np.isfinite(az)]
    diff = math.nan
    other_min = math.nan
    if other is not None:
        other_min = float(other.min_confining_force.values[i, j])
        if float(other.figure_force.values[i, j]) == force:
            diff = float(run_difference(ds.centre[i, j], other.centre[i, j]))
    n_probe = int(np.isfinite(ds.probe_force.values[i, j]).sum())
    out = {
        "min_confining_force_N": float(ds.min_confining_force.values[i, j]),
        "bracket_N": [float(ds.bracket_low.values[i, j]), float(ds.bracket_high.values[i, j])],
        "min_confining_force_at_refined_dt_N": other_min,
        **_search_figures(ds, i, j),
        "figure_force_N": force,
        "figure_dt_s": float(ds.dt.values[i, j]),
        "status": str(ds.status.values[i, j]),
        "carried": bool(ds.carried.values[i, j]),
        "left_cavity_time_s": float(ds.left_cavity_time.values[i, j]),
        "structure_rotation_deg": float(ds.structure_rotation.values[i, j]),
        "structure_rotation_point_mass_deg": float(
            ds.structure_rotation_point_mass.values[i, j]),
        "angular_displacement_deg": float(az[-1] - az[0]) if az.size else math.nan,
        "world_angular_displacement_deg": float(ds.world_angular_displacement.values[i, j]),
        "confinement_work_J": _confinement_work(ds, i, j, kind, force),
        "angular_momentum_drift": float(ds.max_hz_drift.values[i, j]),
        "angular_momentum_scale": float(ds.hz_scale.values[i, j]),
        "max_structure_rate_rad_s": float(ds.max_structure_rate.values[i, j]),
        "energy_residual_J": float(ds.max_energy_residual.values[i, j]),
        "timestep_difference_m": diff,
        "min_normal_reaction_N": float(ds.min_normal_reaction.values[i, j]),
        "search_runs": n_probe,
    }
    return out


def en03m_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-03M: per confinement kind the figures of the first structure
    inertia (the free structure by default), and every inertia under by_structure_inertia."""
    runs = _as_list(datasets)
    ds = runs[0]
    other = runs[1] if len(runs) > 1 else None
    out: dict[str, Any] = {"study": ds.attrs.get("study", "en03m")}
    cells = []
    for i, kind in enumerate(ds.confinement.values):
        by = {}
        for j, v in enumerate(ds.structure_inertia.values):
            cell = _en03m_cell(ds, other, i, j)
            cell["structure_inertia_kg_m2"] = float(v)
            by[_key(float(v))] = cell
            cells.append(cell)
        first = dict(next(iter(by.values())))
        first["by_structure_inertia"] = by
        out[str(kind)] = first
    statuses = [c["status"] for c in cells] + [str(x) for x in ds.probe_status.values.ravel()
                                               if str(x)]
    out.update({
        "status": _status(statuses),
        "timestep_difference_m": _nanmax([c["timestep_difference_m"] for c in cells]),
        "energy_residual_J": _nanmax([c["energy_residual_J"] for c in cells]),
        "angular_momentum_drift": _nanmax([c["angular_momentum_drift"] for c in cells]),
        "reference_force_N": float(ds.attrs.get("reference_force", math.nan)),
        "max_force_N": float(ds.attrs.get("max_force", math.nan)),
        "gravity_m_s2": float(ds.attrs.get("gravity", math.nan)),
        "dt_s": [float(d.attrs["dt"]) for d in runs],
        "config_sha256": ds.attrs.get("config_sha256", ""),
    })
    return out


def _en03m_figure(ds: xr.Dataset, s: dict, path: Path) -> None:
    kinds = [str(k) for k in ds.confinement.values]
    inertias = ds.structure_inertia.values
    fig, axes = plt.subplots(2, 3, figsize=(15, 8))
    ax = axes[0, 0]
    for i, kind in enumerate(kinds):
        for j, v in enumerate(inertias):
            P = ds.probe_force.values[i, j]
            ang = ds.probe_angle.values[i, j]
            ok = np.isfinite(P)
            order = np.argsort(P[ok])
            c = ds.probe_carried.values[i, j][ok][order].astype(bool)
            x, y = P[ok][order], np.abs(ang[ok][order])
            line, = ax.semilogx(x, y, "-", lw=0.8, label=f"{kind}, I_s = {_key(float(v))}")
            ax.scatter(x[c], y[c], color=line.get_color(), marker="o")
            ax.scatter(x[~c], y[~c], color=line.get_color(), marker="x")
    ax.set_xlabel("confining force P (N)")
    ax.set_ylabel("|angle carried| (deg) (o carried, x not)")
    ax.legend(fontsize=7)
    panels = [("structure yaw (deg)", "theta"), ("W_confine (J)", "confinement_work"),
              ("normal reaction (N)", "normal_reaction"), ("angular lag (deg)", "angular_lag"),
              ("energy residual (J)", "energy_residual")]
    t = ds.time.values
    for ax, (label, name) in zip(axes.flat[1:], panels, strict=True):
        for i, kind in enumerate(kinds):
            for j, v in enumerate(inertias):
                ax.plot(t, ds[name].values[i, j], lw=0.8,
                        label=f"{kind}, I_s = {_key(float(v))}, P = "
                              f"{fmt(float(ds.figure_force.values[i, j]))} N")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0, 1].legend(fontsize=6)
    fig.suptitle("EN-03M: the search for the smallest carrying force, and the figure runs",
                 fontsize=10)
    _finish(fig, path)


def _en03m_convergence(runs: Sequence[xr.Dataset], path: Path) -> None:
    ds = runs[0]
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4))
    t = ds.time.values
    for i, kind in enumerate(ds.confinement.values):
        for j, v in enumerate(ds.structure_inertia.values):
            label = f"{kind}, I_s = {_key(float(v))}"
            if len(runs) > 1 and (float(runs[1].figure_force.values[i, j])
                                  == float(ds.figure_force.values[i, j])):
                d = np.linalg.norm(ds.centre.values[i, j] - runs[1].centre.sel(
                    time=t, method="nearest").values[i, j], axis=-1)
                ax1.semilogy(t, np.maximum(d, 1e-18), lw=0.8, label=label)
            ax2.semilogy(t, np.maximum(np.abs(ds.energy_residual.values[i, j]), 1e-20), lw=0.8,
                         label=label)
            hz = ds.hz.values[i, j]
            if np.isfinite(hz).any():
                ax3.semilogy(t, np.maximum(np.abs(hz - hz[0]), 1e-20), lw=0.8, label=label)
    ax1.set_ylabel("centre-position difference, dt vs dt / refine (m)")
    ax2.set_ylabel("|E - E0 - W + D - W_confine| (J)")
    ax3.set_ylabel("|H_z - H_z(0)| (kg m^2/s)")
    for ax in (ax1, ax2, ax3):
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    _finish(fig, path)


def _or(value: Any, text: str) -> Any:
    """value formatted, or text where it is absent (None or NaN: nothing carried, or no
    structure to conserve H_z for)."""
    return text if value is None or (isinstance(value, float) and math.isnan(value)) \
        else fmt(value)


def write_en03m(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en03m.json/.md/.png, _history.csv (every run of the search), _trajectory.png,
    _convergence.png."""
    runs, s, paths = _start(datasets, outdir, en03m_summary)
    ds = runs[0]
    _en03m_figure(ds, s, paths["png"])
    named = []
    for i, kind in enumerate(ds.confinement.values):
        for j, v in enumerate(ds.structure_inertia.values):
            cell = ds.isel(confinement=i, structure_inertia=j)
            named.append((f"{kind}, I_s = {_key(float(v))}", cell))
    _paths_figure(named, paths["trajectory"], "EN-03M figure runs")
    _en03m_convergence(runs, paths["convergence"])
    rows = []
    for i, kind in enumerate(ds.confinement.values):
        for j, v in enumerate(ds.structure_inertia.values):
            for q in range(ds.sizes["probe"]):
                P = ds.probe_force.values[i, j, q]
                if np.isfinite(P):
                    rows.append([str(kind), float(v), q, P, ds.probe_dt.values[i, j, q],
                                 str(ds.probe_status.values[i, j, q]),
                                 int(ds.probe_carried.values[i, j, q]),
                                 ds.probe_left_cavity_time.values[i, j, q],
                                 ds.probe_angle.values[i, j, q], ds.probe_lag.values[i, j, q]])
    _write_csv(paths["csv"], ["confinement", "structure_inertia_kg_m2", "run", "force_N",
                              "dt_s", "status", "carried", "left_cavity_time_s", "angle_deg",
                              "lag_deg"], rows)
    lines = _header(ds, runs, s["study"])
    lines += [f"g = {fmt(s['gravity_m_s2'])} m/s^2; forces searched from "
              f"{fmt(s['reference_force_N'])} x 10^k N up to {fmt(s['max_force_N'])} N.", "",
              "## Per confinement and structure", ""]
    head = ["confinement", "I_s (kg m^2)", "smallest carrying P (N)", "bracket (N)",
            "carried angle (deg)", "lag there (deg)", "figure P (N)", "figure status",
            "structure angle (deg)", "W_confine (J)", "H_z drift", "energy residual (J)",
            "dt difference (m)"]
    body: list[tuple] = []
    for kind in ds.confinement.values:
        for key, c in s[str(kind)]["by_structure_inertia"].items():
            lo, hi = (_or(v, "none") for v in c["bracket_N"])
            body.append((str(kind), key, _or(c["min_confining_force_N"], "none"),
                         f"[{lo}, {hi}]",
                         c["carried_angle_deg"], c["lag_deg"], c["figure_force_N"],
                         c["status"], c["structure_rotation_deg"], c["confinement_work_J"],
                         _or(c["angular_momentum_drift"], "-"), c["energy_residual_J"],
                         c["timestep_difference_m"]))
    lines += table(head, body)
    lines += ["", "A smallest force of none means no force up to the maximum carried the sphere "
              "through the cycle; the carried angle and lag are then those of the search's run "
              "that got farthest. Figure runs are at figure_factor x the smallest carrying "
              "force, or at the fallback force. W_confine is the work of the confining force: "
              "the integral of -P n . c_t for normal, the pull's potential drop for base. "
              "H_z drift is - for the fixed structure (I_s = inf), which takes any torque.", "",
              f"![search and figure runs]({paths['png'].name})", "",
              f"![paths]({paths['trajectory'].name})", "",
              f"![convergence]({paths['convergence'].name})", ""]
    write_markdown(paths["md"], "\n".join(lines))
    return paths
