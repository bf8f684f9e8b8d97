"""Reports derived from datasets (never recomputing a study): JSON contract, markdown with
published vs computed side by side, CSV tables and figures.

JSON keys follow the report contract: ``fd_error`` and ``observed_order`` are nested
{derivative: {h: value}}, h written as Python writes the float (0.01, 0.0003, 1e-05); an
observed order is keyed by the finer step of its pair (order between the previous h and it).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from creatio import published  # noqa: E402
from creatio.studies._checks import observed_order  # noqa: E402

__all__ = ["kinematic_summary", "write_kinematic_report", "h_key"]


def _json(data: Any) -> str:
    """Strict JSON: NaN and infinities (a figure not computed) become null."""
    def clean(x: Any) -> Any:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, list | tuple):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(data), indent=2, allow_nan=False) + "\n"


def h_key(h: float) -> str:
    """The h label of the report contract: Python's shortest float repr (0.01, 1e-05)."""
    return repr(float(h))


def _nested(names: Sequence[str], keys: Sequence[str], values: np.ndarray) -> dict:
    return {n: {k: float(v) for k, v in zip(keys, row, strict=True)}
            for n, row in zip(names, values, strict=True)}


def kinematic_summary(ds: xr.Dataset) -> dict[str, Any]:
    """The JSON report of CT-02 or EN-01 from its dataset."""
    study = ds.attrs["study"]
    hs = ds.h.values
    names = [str(d) for d in ds.derivative.values]
    if study == "ct02":
        fd = np.maximum(ds.fd_error.max("inclination").values, ds.fd_error_varying.values)
    else:
        fd = ds.fd_error.max("law").values
    keys = [h_key(h) for h in hs]
    order = observed_order(hs, fd)
    out: dict[str, Any] = {
        "study": study,
        "fd_error": _nested(names, keys, fd),
        "observed_order": _nested(names, keys[1:], order),
        "j_min": float(ds.attrs["j_lower_bound"]),
        "j_min_sampled": float(ds.j_min_sampled.min()),
    }

    def worst(name: str) -> float:
        values = [ds[name].max()]
        if f"{name}_varying" in ds:
            values.append(ds[f"{name}_varying"])
        return float(max(float(v) for v in values))

    out["j_identity_error"] = worst("j_identity_error")
    out["normal_tangent_dot"] = worst("normal_tangent_dot")
    out["normal_length_error"] = worst("normal_length_error")
    if study == "ct02":
        out["seam_closure"] = worst("seam_closure")
        out["feature_velocity_error"] = float(ds.feature_velocity_error.max())
        out["feature_acceleration_error"] = float(ds.feature_acceleration_error.max())
        out["pitch_error"] = float(np.abs(ds.pitch_formula - ds.pitch_measured).max())
        out["surface_class"] = {f"{float(g):g}": str(c) for g, c in
                                zip(ds.inclination.values, ds.surface_class.values, strict=True)}
    else:
        rate = np.abs(ds.pattern_rate.values)
        i = int(np.argmax(rate))
        out["pattern_max_rate_rad_s"] = float(rate[i])
        out["pattern_max_rate_time_s"] = float(ds.time.values[i])
        out["pattern_travel_deg"] = float(
            np.rad2deg(ds.pattern_angle.values[-1] - ds.pattern_angle.values[0]))
        out["pattern_fd_error"] = float(np.abs(ds.pattern_rate - ds.pattern_rate_fd).max())
    out["config_sha256"] = ds.attrs.get("config_sha256", "")
    return out


def _fmt(x: Any) -> str:
    if isinstance(x, float | np.floating):
        return "nan" if math.isnan(x) else f"{x:.4g}" if abs(x) >= 1e-3 or x == 0 else f"{x:.3e}"
    return str(x)


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_fmt(c) for c in row) + " |" for row in rows]
    return lines


def _fd_rows(summary: dict, study: str) -> tuple[list[str], list[list[Any]]]:
    names = list(summary["fd_error"])
    keys = list(summary["fd_error"][names[0]])
    header = ["h"]
    for n in names:
        header += [f"{n} computed", f"{n} order"]
        if study == "en01":
            header += [f"{n} published", f"{n} ratio"]
    rows = []
    for k in keys:
        row: list[Any] = [k]
        for n in names:
            e = summary["fd_error"][n][k]
            row += [e, summary["observed_order"][n].get(k, "")]
            if study == "en01":
                p = published.EN01_FD_ERROR[n].get(k, float("nan"))
                row += [p, e / p]
        rows.append(row)
    return header, rows


def _convergence_figure(summary: dict, study: str, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for n, errs in summary["fd_error"].items():
        hs = [float(k) for k in errs]
        (line,) = ax.loglog(hs, list(errs.values()), "o-", label=f"{n} computed")
        if study == "en01":
            pub = published.EN01_FD_ERROR[n]
            ax.loglog([float(k) for k in pub], list(pub.values()), "x--",
                      color=line.get_color(), alpha=0.6, label=f"{n} published")
    h = np.array([1e-2, 1e-4])
    ax.loglog(h, 1.5 * h**2, "k:", label="slope 2")
    ax.set_xlabel("finite-difference step h")
    ax.set_ylabel("max Euclidean error")
    ax.set_title(f"{study.upper()}: analytic derivatives vs central differences")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_kinematic_report(dataset: str | Path, outdir: str | Path) -> dict[str, Path]:
    """Write <study>.json, .md, _fd_error.csv and .png for a CT-02/EN-01 dataset."""
    from creatio.io import read_dataset

    ds, _ = read_dataset(dataset)
    study = ds.attrs["study"]
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    summary = kinematic_summary(ds)
    paths = {ext: outdir / f"{study}.{ext}" for ext in ("json", "md", "png")}
    paths["csv"] = outdir / f"{study}_fd_error.csv"
    paths["json"].write_text(_json(summary))
    header, rows = _fd_rows(summary, study)
    with paths["csv"].open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    _convergence_figure(summary, study, paths["png"])
    paths["md"].write_text(_kinematic_markdown(ds, summary, header, rows, paths))
    return paths


def _kinematic_markdown(ds: xr.Dataset, s: dict, header, rows, paths) -> str:
    study = s["study"]
    lines = [f"# {ds.attrs.get('title', study)}", "",
             f"Dataset config sha256 `{s['config_sha256'][:12]}`, creatio "
             f"{ds.attrs.get('creatio_version')}, commit {ds.attrs.get('git_commit', '')[:10]}"
             f"{' (dirty)' if int(ds.attrs.get('git_dirty', 0)) else ''}.", "",
             "## Derivative check (max Euclidean error, analytic vs central difference)", "",
             f"Samples: {ds.attrs.get('n_samples')}. Observed order between the previous h "
             "and this one.", ""]
    lines += _table(header, rows)
    if study == "en01":
        lines += ["", "Rows below h = 1e-4 are rounding-dominated. The angular sampling starts "
                  "at alpha = 0; the notebook does not state its own, and c_alpha / c_t come "
                  "out slightly below the published values (ratio column)."]
    lines += ["", f"![convergence]({paths['png'].name})", "", "## Regularity", ""]
    reg = [
        ("max | J identity - |c_R x c_alpha| |", s["j_identity_error"],
         published.EN01_REGULARITY["j_identity_error"] if study == "en01" else ""),
        ("max normalised normal-tangent dot", s["normal_tangent_dot"],
         published.EN01_REGULARITY["normal_tangent_dot"] if study == "en01" else ""),
        ("max | |n| - 1 |", s["normal_length_error"],
         published.EN01_REGULARITY["normal_length_error"] if study == "en01" else ""),
        ("analytic lower bound of J (R0 - A)", s["j_min"],
         published.EN01_REGULARITY["j_min"] if study == "en01" else ""),
        ("smallest sampled J", s["j_min_sampled"], ""),
    ]
    if study == "ct02":
        reg += [("angular seam closure", s["seam_closure"], "")]
    lines += _table(["figure", "computed", "published"], reg)
    if study == "ct02":
        lines += ["", "## Cavity trajectories and pitch", ""]
        lines += _table(["figure", "computed"], [
            ("max |C' - central difference|", s["feature_velocity_error"]),
            ("max |C'' - second difference|", s["feature_acceleration_error"]),
            ("max |pitch formula - displacement over one turn|", s["pitch_error"]),
        ])
        lines += ["", "Surface class per inclination: " + ", ".join(
            f"{k} deg {v}" for k, v in s["surface_class"].items()) + "."]
    else:
        lines += ["", "## Pattern velocity over the EN-02 cycle", ""]
        lines += _table(["figure", "computed", "published"], [
            (k, s[k], v) for k, v in published.EN01_PATTERN.items()])
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------ dynamic studies
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


def _surface_top_view(ax, config: dict, t: float = 0.0) -> None:
    """Filled contour of the surface height c_z in top view at time t."""
    from omegaconf import OmegaConf

    from creatio.config import PhasesConfig
    from creatio.geometry import Frame, Motion, Surface

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
        if y2 is not None:
            ax2 = ax.twinx()
            ax2.plot(t, y2, color="tab:orange", lw=1.0)
            ax2.set_ylabel(label2, color="tab:orange")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"{ds.attrs.get('title', '')}: time histories (dt = {ds.attrs['dt']:g} s, "
                 f"status {ds.attrs['status']})")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _trajectory_figure(runs: Sequence[tuple[str, xr.Dataset]], config: dict, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 6.4))
    _surface_top_view(ax, config)
    tmax = max(float(ds.time.values[-1]) for _, ds in runs)
    norm = plt.Normalize(0.0, tmax)
    markers = ["o", "s", "^", "D"]
    for (label, ds), mk in zip(runs, markers, strict=False):
        x, y = ds.centre.values[:, 0], ds.centre.values[:, 1]
        ax.plot(x, y, lw=0.8, color="k", alpha=0.4)
        sc = ax.scatter(x[::10], y[::10], c=ds.time.values[::10], cmap="viridis", norm=norm,
                        s=10, marker=mk, label=label)
        ax.plot(x[0], y[0], "g*", ms=12)
        ax.plot(x[-1], y[-1], "r*", ms=12)
    fig.colorbar(sc, ax=ax, label="time (s) (shared)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("centre path in top view over the surface height at t = 0 "
                 "(green start, red end)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
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
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _history_csv(ds: xr.Dataset, path: Path) -> None:
    cols: dict[str, np.ndarray] = {"time_s": ds.time.values}
    for name, var in ds.data_vars.items():
        unit = var.attrs.get("units", "")
        suffix = f" ({unit})" if unit else ""
        if var.dims == ("time",):
            cols[f"{name}{suffix}"] = var.values
        elif var.dims[0] == "time" and var.ndim == 2:
            for j, c in enumerate(var[var.dims[1]].values):
                cols[f"{name}_{c}{suffix}"] = var.values[:, j]
    with path.open("w", newline="") as fh:
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


def write_dynamic_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write <study>.json/.md/.png, _history.csv, _trajectory.png, _convergence.png."""
    from creatio.io import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    runs = [ds for ds, _ in loaded]
    config = loaded[0][1]
    ds = runs[0]
    study = ds.attrs["study"]
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    s = dynamic_summary(runs)
    paths = {
        "json": outdir / f"{study}.json",
        "md": outdir / f"{study}.md",
        "png": outdir / f"{study}.png",
        "csv": outdir / f"{study}_history.csv",
        "trajectory": outdir / f"{study}_trajectory.png",
        "convergence": outdir / f"{study}_convergence.png",
    }
    paths["json"].write_text(_json(s))
    _history_figure(ds, paths["png"])
    _trajectory_figure([(study, ds)], config, paths["trajectory"])
    _convergence_figure_dynamic(runs, paths["convergence"])
    _history_csv(ds, paths["csv"])
    pub = published.EN02 if study == "en02" else {}
    rows = [(label, s[key], pub.get(key, "")) for label, key in SUMMARY_ROWS]
    method = str(ds.attrs.get("method", "rk4"))
    if "rtol" in ds.attrs:
        pair = (f"{method} (adaptive) at rtol = {ds.attrs['rtol']:g} compared with rtol = "
                f"{runs[-1].attrs['rtol']:g} (datasets named dt = {s['dt_s'][0]:g}, "
                f"{s['dt_s'][-1]:g} s); ")
    else:
        pair = (f"{method.upper()} at dt = {s['dt_s'][0]:g} s compared with dt = "
                f"{s['dt_s'][-1]:g} s; ")
    lines = [f"# {ds.attrs.get('title', study)}", "",
             pair +
             f"config sha256 `{s['config_sha256'][:12]}`, creatio "
             f"{ds.attrs.get('creatio_version')}, commit {ds.attrs.get('git_commit', '')[:10]}.",
             "", "## Summary figures", ""]
    lines += _table(["figure", "computed", "published" if pub else ""], rows)
    if pub:
        lines += ["", "Published timestep difference and energy residual are upper bounds "
                  "(the notebook's code used approximate derivatives); these runs use exact "
                  "derivatives."]
    lines += ["", "Extrema are taken over every integration step. Energy residual per dt: "
              + ", ".join(f"{k} s: {_fmt(v)} J" for k, v in s["energy_residual_by_dt_J"].items())
              + f". {method.upper()} stability limit of the friction: "
              f"{_fmt(s['stability_limit_dt_s'])} s; "
              f"max b kappa on the path: {_fmt(s['max_b_kappa'])}.", ""]
    if s["warnings"]:
        lines += ["## Warnings", "", *[f"* {w}" for w in s["warnings"]], ""]
    lines += [f"![time histories]({paths['png'].name})", "",
              f"![trajectory]({paths['trajectory'].name})", "",
              f"![convergence]({paths['convergence'].name})", ""]
    paths["md"].write_text("\n".join(lines))
    return paths


def write_comparison(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """EN-02 vs EN-02R: both centre paths on shared time over the surface, and a table."""
    from creatio.io import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    outdir = Path(outdir)
    summaries = [json.loads((outdir / f"{ds.attrs['study']}.json").read_text())
                 for ds, _ in loaded]
    names = [s["study"] for s in summaries]
    paths = {"md": outdir / "compare_en02_en02r.md", "png": outdir / "compare_en02_en02r.png"}
    _trajectory_figure([(n, ds) for n, (ds, _) in zip(names, loaded, strict=True)],
                       loaded[0][1], paths["png"])
    rows = [(label, *[s[key] for s in summaries]) for label, key in SUMMARY_ROWS]
    lines = ["# EN-02 / EN-02R comparison", "",
             "Both centre paths in top view on shared time (colour), over the surface height "
             "at t = 0.", "", f"![paths]({paths['png'].name})", ""]
    lines += _table(["figure", *names], rows)
    paths["md"].write_text("\n".join(lines) + "\n")
    return paths


# ------------------------------------------------------------------------------- sweeps
SWEEP_FIGURES = {
    "dynamic": ["cumulative_spin_deg", "max_slip_speed_m_s", "min_normal_reaction_N",
                "angular_displacement_deg", "final_radius_m", "energy_residual_J"],
}


def _sweep_figures(ds: xr.Dataset) -> list[str]:
    numeric = [n for n, v in ds.data_vars.items() if v.dtype.kind == "f"
               and n not in ("stability_limit_dt_s", "dt_s")]
    wanted = [n for n in SWEEP_FIGURES["dynamic"] if n in numeric]
    return wanted or numeric[:6]


def _stability_edge(ds: xr.Dataset, dim: str) -> float | None:
    """Where dt / (RK4 limit) crosses 1 along a numeric axis (linear interpolation: exact
    for mu, whose limit scales as 1 / mu); None if no point is beyond the limit."""
    x = ds[dim].values
    if x.dtype.kind != "f":
        return None
    ratio = ds.dt_s.values / ds.stability_limit_dt_s.values
    beyond = np.flatnonzero(ratio > 1.0)
    if beyond.size == 0:
        return None
    i = beyond[0]
    if i == 0:
        return float(x[0])
    j = i - 1
    return float(x[j] + (1.0 - ratio[j]) * (x[i] - x[j]) / (ratio[i] - ratio[j]))


def write_sweep_report(ds: xr.Dataset, outdir: str | Path) -> dict[str, Path]:
    """sweep.md (one row per point) and sweep.png (a line or heat map per figure)."""
    outdir = Path(outdir)
    dims = list(ds.status.dims)
    names = _sweep_figures(ds)
    flat = ds.stack(point=dims) if len(dims) > 1 else ds.rename({dims[0]: "point"})
    header = [ds[d].attrs.get("long_name", d) for d in dims] + ["status", *names]
    if "stability_limit_dt_s" in ds:
        header.append("RK4 limit dt (s)")
    rows = []
    for i in range(flat.sizes["point"]):
        p = flat.isel(point=i)
        coords = [p[d].item() for d in dims] if len(dims) > 1 else [p["point"].item()]
        row = [*coords, str(p.status.item()) + (f" ({p.message.item()})" if
                                                 p.message.item() else ""),
               *[float(p[n]) for n in names]]
        if "stability_limit_dt_s" in ds:
            row.append(float(p.stability_limit_dt_s))
        rows.append(row)
    lines = [f"# {ds.attrs.get('title', 'sweep')}", "",
             f"{ds.attrs.get('points_run')} of {ds.attrs.get('points')} points ran; base "
             f"overrides {ds.attrs.get('base_overrides')}. Refused points (invalid) were not "
             "run; stopped runs keep their status.", "", "![sweep](sweep.png)", ""]
    lines += _table(header, rows)
    md = outdir / "sweep.md"
    md.write_text("\n".join(lines) + "\n")
    png = outdir / "sweep.png"
    ncol = min(3, len(names)) or 1
    nrow = max(1, math.ceil(len(names) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.6 * nrow), squeeze=False)
    for ax, name in zip(axes.flat, names, strict=False):
        if len(dims) == 1:
            x = ds[dims[0]].values
            ok = ds.status.values == "ok"
            ax.plot(x, ds[name].values, "o-", label="ran")
            if (~ok).any():
                bad = x[~ok]
                ax.plot(bad, np.where(np.isnan(ds[name].values[~ok]),
                                      np.nanmin(ds[name].values) if ok.any() else 0.0,
                                      ds[name].values[~ok]),
                        "rx", ms=9, label="refused or stopped")
            edge = _stability_edge(ds, dims[0]) if "stability_limit_dt_s" in ds else None
            if edge is not None:
                ax.axvspan(edge, x.max(), color="red", alpha=0.08,
                           label=f"dt beyond the RK4 friction limit (from {edge:.4g})")
                ax.axvline(edge, color="red", lw=0.8)
            ax.set_xlabel(ds[dims[0]].attrs.get("long_name", dims[0]))
        else:
            img = ds[name].transpose(dims[0], dims[1]).values
            im = ax.imshow(img, origin="lower", aspect="auto", cmap="viridis")
            ax.set_yticks(range(len(ds[dims[0]])), [f"{v:g}" if isinstance(v, float) else v
                                                     for v in ds[dims[0]].values])
            ax.set_xticks(range(len(ds[dims[1]])), [f"{v:g}" if isinstance(v, float) else v
                                                     for v in ds[dims[1]].values])
            ax.set_ylabel(ds[dims[0]].attrs.get("long_name", dims[0]))
            ax.set_xlabel(ds[dims[1]].attrs.get("long_name", dims[1]))
            fig.colorbar(im, ax=ax)
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    if len(dims) == 1:
        axes.flat[0].legend(fontsize=7)
    fig.suptitle(ds.attrs.get("title", ""))
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)
    return {"md": md, "png": png}
