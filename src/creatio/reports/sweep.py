"""Reports of parameter sweeps: a markdown table and one figure per summary figure."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from creatio.reports.common import plt, readable_y, save_figure, table, write_text

__all__ = ["axis_label", "figure_label", "write_sweep_report"]


def figure_label(name: str) -> str:
    """How a summary figure reads on an axis: the reports' own label (``cumulative spin
    (deg)``), else the key with its unit suffix spelled out."""
    from creatio.reports.sphere import SUMMARY_ROWS

    labels = {key: label for label, key in SUMMARY_ROWS}
    if name in labels:
        return labels[name]
    for suffix, unit in (("_deg", "deg"), ("_m_s", "m/s"), ("_N", "N"), ("_J", "J"),
                         ("_m", "m"), ("_s", "s")):
        if name.endswith(suffix):
            return f"{name[: -len(suffix)].replace('_', ' ')} ({unit})"
    return name.replace("_", " ")


#: What the commonly swept keys mean, for axis labels (the key itself is kept beside it).
KEY_LABELS = {
    "sphere.mu": "friction coefficient mu",
    "sphere.eps": "friction regularisation eps (m/s)",
    "sphere.b": "sphere radius b (m)",
    "sphere.m": "sphere mass m (kg)",
    "phases.T": "cycle duration T (s)",
    "solver.dt": "timestep dt (s)",
    "geometry.A": "corrugation amplitude A (m)",
    "study.initial.R": "initial contact radius R (m)",
}


def axis_label(ds: xr.Dataset, dim: str) -> str:
    """A swept key as an axis label: what it means, if known, and its config key
    (``friction coefficient mu (sphere.mu)``)."""
    key = str(ds[dim].attrs.get("long_name", dim.replace("__", ".")))
    units = ds[dim].attrs.get("units")
    if key in KEY_LABELS:
        return f"{KEY_LABELS[key]} ({key})"
    return f"{key} ({units})" if units else key


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
    header = [axis_label(ds, d) for d in dims] + ["status", *[figure_label(n) for n in names]]
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
    lines += table(header, rows)
    md = outdir / "sweep.md"
    write_text(md, "\n".join(lines) + "\n")
    png = outdir / "sweep.png"
    ncol = min(3, len(names)) or 1
    nrow = max(1, math.ceil(len(names) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.6 * nrow), squeeze=False)
    for ax, name in zip(axes.flat, names, strict=False):
        if len(dims) == 1:
            x = ds[dims[0]].values
            y = ds[name].values.astype(float)
            status = ds.status.values.astype(str)
            ok = status == "ok"
            refused = status == "invalid"
            stopped = ~ok & ~refused & np.isfinite(y)
            ax.plot(x[ok], y[ok], "o-", label="ran (status ok)")
            if stopped.any():  # a run that stopped early: its own value, marked
                ax.plot(x[stopped], y[stopped], "rx", ms=9, mew=2, label="stopped early")
            if refused.any():  # never run: no value, only where along the axis
                ax.plot(x[refused], np.zeros(refused.sum()), "v", color="0.4", ms=8,
                        transform=ax.get_xaxis_transform(), clip_on=False,
                        label="refused (not run)")
            readable_y(ax, y[ok | stopped])
            edge = _stability_edge(ds, dims[0]) if "stability_limit_dt_s" in ds else None
            if edge is not None:
                ax.axvspan(edge, x.max(), color="red", alpha=0.08,
                           label=f"dt beyond the RK4 friction limit (from {edge:.4g})")
                ax.axvline(edge, color="red", lw=0.8)
            ax.set_xlabel(axis_label(ds, dims[0]))
            ax.set_ylabel(figure_label(name), fontsize=8)
        else:
            img = ds[name].transpose(dims[0], dims[1]).values
            im = ax.imshow(img, origin="lower", aspect="auto", cmap="viridis")
            ax.set_yticks(range(len(ds[dims[0]])), [f"{v:g}" if isinstance(v, float) else v
                                                     for v in ds[dims[0]].values])
            ax.set_xticks(range(len(ds[dims[1]])), [f"{v:g}" if isinstance(v, float) else v
                                                     for v in ds[dims[1]].values])
            ax.set_ylabel(axis_label(ds, dims[0]))
            ax.set_xlabel(axis_label(ds, dims[1]))
            fig.colorbar(im, ax=ax, label=figure_label(name))
        ax.set_title(figure_label(name), fontsize=9)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    if len(dims) == 1:
        axes.flat[0].legend(fontsize=7)
    fig.suptitle(ds.attrs.get("title", ""))
    fig.tight_layout()
    save_figure(fig, png, dpi=100)
    plt.close(fig)
    return {"md": md, "png": png}
