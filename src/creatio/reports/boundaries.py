"""Report of the physics boundaries of EN-02 (creatio.studies.boundaries): one JSON summary
per axis, a markdown table with each axis's transitions, checks and anomalies, and one
figure with a row of six diagnostics per axis. Derived from the datasets only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines
from creatio.reports.common import fmt, plt, save_figure, strict_json, table, write_text

__all__ = ["figure", "summary", "write_report"]

#: Marker colour of each status (a point's recorded run, or its outcome at the nominal dt).
COLOURS = {
    "ok": "tab:green",
    "contact_lost": "tab:red",
    "left_annulus": "tab:purple",
    "edge_crossed": "tab:orange",
    "offset_singular": "tab:blue",
    "non_finite": "black",
    "step_failed": "tab:pink",
    "refused": "tab:gray",
    "refused_unstable": "tab:brown",
}
#: The six diagnostics of each axis's row: variable (or the completed fraction), reference line.
PANELS = (
    ("min_N", 0.0),
    ("max_b_kappa", 1.0),
    ("min_edge_clearance", 0.0),
    ("stop_time / duration", 1.0),
    ("max_slip_speed", None),
    ("max_cavity_tracking_error", None),
)


def _num(x: float) -> str:
    """A number by :func:`fmt`, or "-" when it was not computed."""
    return fmt(float(x)) if math.isfinite(x) else "-"


def _units(ds: xr.Dataset) -> str:
    """" <units>" of the axis, empty for a dimensionless one."""
    u = ds["value"].attrs["units"]
    return "" if u == "1" else f" {u}"


def _axis_summary(ds: xr.Dataset) -> dict[str, Any]:
    """The JSON entry of one axis: boundary, status, bracket, analytic value and basis."""
    a = ds.attrs
    extras = {k.removeprefix("analytic_"): float(v) for k, v in a.items()
              if k.startswith("analytic_")}
    status = ds["status"].values.astype(str)
    return {
        "config_key": a["config_key"],
        "units": ds["value"].attrs["units"],
        "boundary": float(ds["boundary"]),
        "status": ds["boundary_status"].item(),
        "bracket": [float(ds["boundary_ok"]), float(ds["boundary_fail"])],
        "what_failed": a["what_failed"],
        "physics_boundary": float(ds["physics_boundary"]),
        "physics_status": ds["physics_boundary_status"].item(),
        "physics_bracket": [float(ds["physics_boundary_ok"]), float(ds["physics_boundary_fail"])],
        "analytic": {"value": float(ds["analytic_boundary"]), "basis": a["analytic"], **extras},
        "points": int(ds.sizes["value"]),
        "statuses": {s: int((status == s).sum()) for s in dict.fromkeys(status)},
        "transitions": a["transitions"],
        "dt_check": a.get("boundary_dt_check", ""),
        "anomalies": [s for s in a["anomalies"].split("; ") if s],
    }


def summary(datasets: Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report: provenance, then one entry per axis in dataset order."""
    first = datasets[0].attrs
    return {
        "study": first.get("study", "boundaries"),
        "config_sha256": first.get("config_sha256", ""),
        "axes": {ds.attrs["axis"]: _axis_summary(ds) for ds in datasets},
    }


def _answer(datasets: Sequence[xr.Dataset]) -> list[str]:
    """The boundaries' plain-word answer: per axis where EN-02 stops working and why, beside
    the analytic expectation."""
    found = []
    for ds in datasets:
        u = _units(ds)
        found.append(f"{ds.attrs['axis']} at {_num(float(ds['boundary']))}{u} "
                     f"({ds['boundary_status'].item()}; analytic "
                     f"{_num(float(ds['analytic_boundary']))}{u})")
    anomalies = sum(1 for ds in datasets for a in str(ds.attrs["anomalies"]).split("; ") if a)
    return answer_lines(
        "how far each of " + ", ".join(f"`{ds.attrs['config_key']}`" for ds in datasets)
        + " can move from EN-02's default before the cycle fails.",
        "the boundaries: " + "; ".join(found) + ".",
        "a bisected bracket [last ok, first failure] per axis (its midpoint is the boundary), "
        f"each run a full EN-02 cycle; {anomalies} anomalies flagged (listed per axis below).")


def _markdown(datasets: Sequence[xr.Dataset], title: str, figure_name: str) -> str:
    """One table of the located boundaries, then per-axis transitions, checks, anomalies."""
    first = datasets[0].attrs
    lines = [
        f"# {title}",
        "",
        *_answer(datasets),
        "Each axis moves one EN-02 parameter outward from its default; the boundary is the "
        "midpoint of the bisected bracket [last ok, first failure]. "
        f"Config sha256 `{first.get('config_sha256', '')[:12]}`, creatio "
        f"{first.get('creatio_version', '')}, commit {first.get('git_commit', '')[:10]}.",
        "",
    ]
    rows = []
    for ds in datasets:
        u = _units(ds)
        rows.append((
            ds.attrs["axis"], f"`{ds.attrs['config_key']}`", f"{_num(float(ds['boundary']))}{u}",
            f"{_num(float(ds['boundary_ok']))} -> {_num(float(ds['boundary_fail']))}",
            ds["boundary_status"].item(), f"{_num(float(ds['analytic_boundary']))}{u}",
            ds.attrs["what_failed"],
        ))
    lines += table(["axis", "key", "boundary", "bracket (ok -> fail)", "failure status",
                    "analytic expectation", "what failed"], rows)
    for ds in datasets:
        lines += ["", f"## {ds.attrs['axis']} (`{ds.attrs['config_key']}`)", "",
                  ds.attrs["description"] + ".", "",
                  f"* analytic: {ds.attrs['analytic']}",
                  f"* status changes: {ds.attrs['transitions'] or 'none'}"]
        if ds["physics_boundary_status"].item() != ds["boundary_status"].item():
            lines.append(f"* physics at a stable dt: {ds.attrs['physics_what_failed']}")
        if ds.attrs.get("boundary_dt_check"):
            lines.append(f"* dt / 2 check of the bracket: {ds.attrs['boundary_dt_check']}")
        escaped = ds["value"].values[(ds["left_cavity"].values == 1)
                                     & (ds["run_status"].values.astype(str) == "ok")]
        if escaped.size:
            lines.append("* ok runs whose sphere left its cavity (|R - R_c| past the crest "
                         "line) yet finished the cycle: " + ", ".join(map(_num, escaped)))
        warned = ds["value"].values[ds["n_warnings"].values > 0]
        if warned.size:
            lines.append("* run warnings (max N beyond the stability limit) at: "
                         + ", ".join(map(_num, warned)))
        lines.append(f"* anomalies: {ds.attrs['anomalies'] or 'none'}")
    lines += ["", f"![boundaries]({figure_name})", ""]
    return "\n".join(lines)


def _row(fig_row: Any, ds: xr.Dataset) -> None:
    """Six diagnostics of one axis against its value (dots: the recorded run, coloured by
    its status; bottom ticks: the status at the nominal dt), boundary and analytic lines."""
    axes = fig_row.subplots(1, len(PANELS), sharex=True)
    x = ds["value"].values
    status = ds["status"].values.astype(str)
    run_status = ds["run_status"].values.astype(str)
    with np.errstate(invalid="ignore", divide="ignore"):
        completed = ds["stop_time"].values / ds["duration"].values
    for axp, (name, ref) in zip(axes, PANELS, strict=True):
        y = ds[name].values if name in ds else completed
        for st in dict.fromkeys(run_status):
            sel = (run_status == st) & np.isfinite(y)
            if sel.any():
                axp.scatter(x[sel], y[sel], s=22, color=COLOURS.get(st, "k"), label=st,
                            zorder=3)
        for st in dict.fromkeys(status):
            sel = status == st
            axp.scatter(x[sel], np.full(sel.sum(), 0.0), marker="|", s=150,
                        color=COLOURS.get(st, "k"), transform=axp.get_xaxis_transform(),
                        clip_on=False, label=st)
        if ref is not None:
            axp.axhline(ref, color="0.5", lw=0.8, ls=":")
        for var, style in (("boundary", "-"), ("physics_boundary", "--")):
            if np.isfinite(ds[var].values):
                axp.axvline(float(ds[var]), color="k", lw=1.0, ls=style)
        if np.isfinite(ds["analytic_boundary"].values):
            axp.axvline(float(ds["analytic_boundary"]), color="tab:red", lw=0.8, ls="-.")
        if name in ds:
            a = ds[name].attrs
            axp.set_ylabel(f"{name} [{a.get('units', '')}]")
            axp.set_title(a.get("long_name", name), fontsize=8.5)
        else:
            axp.set_ylabel(name)
            axp.set_title("fraction of the run completed", fontsize=8.5)
        positive = y[np.isfinite(y)]
        if name == "max_slip_speed" and positive.size and (positive > 0).all():
            axp.set_yscale("log")
        if ds.attrs.get("log_scale"):
            axp.set_xscale("log")
        axp.set_xlabel(f"{ds['value'].attrs['long_name']} [{ds['value'].attrs['units']}]",
                       fontsize=8.5)
    _span(axes[0], x, bool(ds.attrs.get("log_scale")))
    u = _units(ds)
    fig_row.suptitle(f"{ds.attrs.get('title', '')}: boundary {_num(float(ds['boundary']))}{u} "
                     f"({ds['boundary_status'].item()}), analytic "
                     f"{_num(float(ds['analytic_boundary']))}{u}", fontsize=11)


def _span(axp: Any, x: np.ndarray, log: bool) -> None:
    """x limits covering every value (refused points have ticks only, no data limits)."""
    lo, hi = float(np.min(x)), float(np.max(x))
    if log and lo > 0.0:
        pad = (hi / lo) ** 0.04
        axp.set_xlim(lo / pad, hi * pad)
    elif hi > lo:
        pad = 0.04 * (hi - lo)
        axp.set_xlim(lo - pad, hi + pad)


def figure(datasets: Sequence[xr.Dataset], path: str | Path) -> Path:
    """One figure, a row of six diagnostics per axis, one legend of statuses and lines."""
    path = Path(path)
    n = len(datasets)
    fig = plt.figure(figsize=(22, 3.9 * n + 1.0), layout="constrained")
    rows = fig.subfigures(n + 1, 1, height_ratios=[*([3.9] * n), 1.0])
    for fig_row, ds in zip(rows[:n], datasets, strict=True):
        _row(fig_row, ds)
    handles: dict[str, Any] = {}
    for axp in fig.get_axes():
        for h, lab in zip(*axp.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    handles["located boundary"] = plt.Line2D([], [], color="k")
    if any(not np.array_equal(ds["physics_boundary"].values, ds["boundary"].values,
                              equal_nan=True) for ds in datasets):
        handles["physics boundary (stable dt)"] = plt.Line2D([], [], color="k", ls="--")
    handles["analytic expectation"] = plt.Line2D([], [], color="tab:red", ls="-.")
    rows[n].legend(handles.values(), handles.keys(), loc="center", ncol=7, fontsize=9,
                   title="dots: status of the recorded run; bottom ticks: status at the "
                         "nominal dt", title_fontsize=9)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=80)
    plt.close(fig)
    return path


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write boundaries.json, boundaries.md and boundaries.png from the axis datasets."""
    from creatio.store.netcdf import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    if not loaded:
        raise ValueError("the boundaries report needs at least one axis dataset")
    runs = [ds for ds, _ in loaded]
    title = loaded[0][1].get("study", {}).get("title") or "EN-02 physics boundaries"
    study = str(runs[0].attrs.get("study", "boundaries"))
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = {"json": outdir / f"{study}.json", "md": outdir / f"{study}.md",
             "png": outdir / f"{study}.png"}
    write_text(paths["json"], strict_json(summary(runs)))
    figure(runs, paths["png"])
    write_text(paths["md"], _markdown(runs, title, paths["png"].name))
    return paths
