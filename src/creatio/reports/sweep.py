"""Reports of parameter sweeps: a markdown table and one figure per summary figure."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import plt, readable_y, save_figure, table, write_text

__all__ = ["axis_label", "figure_label", "log_scale", "report_paths", "status_cells",
           "write_sweep_report"]

#: A positive figure spanning more than this ratio is drawn on a log axis (the slip speed
#: falls from 0.1 m/s at mu = 0 to 1e-5 m/s: on a linear axis all but one point sit at 0).
LOG_SPAN = 100.0
#: What a table shows where a point has no value (refused, or the figure not computed).
NO_VALUE = "—"


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
    "solver.h0": "first step h0 (s)",
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


def log_scale(values: np.ndarray) -> bool:
    """Whether a figure reads better on a log axis: all finite values positive, spanning
    more than LOG_SPAN."""
    y = np.asarray(values, float)
    y = y[np.isfinite(y)]
    return bool(y.size > 1 and (y > 0).all() and y.max() / y.min() > LOG_SPAN)


def status_cells(statuses: list[str], messages: list[str]) -> tuple[list[str], list[str]]:
    """The status column of a sweep table and its footnotes: a short status per point
    (``invalid [1]``), each distinct reason once below the table (``[1] invalid config:
    solver.dt=0.002: beyond ...``), instead of the whole message in every cell."""
    notes: dict[str, int] = {}
    cells = []
    for status, message in zip(statuses, messages, strict=True):
        if message:
            k = notes.setdefault(message, len(notes) + 1)
            cells.append(f"{status} [{k}]")
        else:
            cells.append(status)
    return cells, [f"[{k}] {m}" for m, k in notes.items()]


def _value(x: float) -> float | str:
    """A table cell of a figure: the number, NO_VALUE where the point has none, "none"
    for an infinite limit (no friction, no stability limit)."""
    if np.isinf(x):
        return "none"
    return float(x) if np.isfinite(x) else NO_VALUE


def report_paths(outdir: str | Path) -> dict[str, Path]:
    """The files :func:`write_sweep_report` writes into outdir."""
    return {"md": Path(outdir) / "sweep.md", "png": Path(outdir) / "sweep.png"}


def _answer(flat: xr.Dataset, dims: list[str], names: list[str],
            statuses: list[str]) -> list[str]:
    """A sweep's plain-word answer: the axes, the range of its first figures over the points
    that ran ok (and where), how many points ended how."""
    def at(i: int) -> str:
        p = flat.isel(point=i)
        values = [p[d].item() for d in dims] if len(dims) > 1 else [p["point"].item()]
        return ", ".join(f"{d.replace('__', '.')} = {v:g}" if isinstance(v, float)
                         else f"{d.replace('__', '.')} = {v}"
                         for d, v in zip(dims, values, strict=True))

    def span(d: str) -> str:
        values = list(dict.fromkeys((flat[d] if len(dims) > 1 else flat["point"]).values
                                    .tolist()))
        shown = [f"{v:g}" if isinstance(v, float) else str(v) for v in values]
        return (f"{d.replace('__', '.')} = {shown[0]} to {shown[-1]} ({len(shown)} values)"
                if len(shown) > 1 else f"{d.replace('__', '.')} = {shown[0]}")

    axes = "; ".join(span(d) for d in dims)
    ok = np.array([s == "ok" for s in statuses])
    counts: dict[str, int] = {}
    for st in statuses:
        counts[st] = counts.get(st, 0) + 1
    ranges = []
    for name in names[:3]:
        y = np.where(ok, flat[name].values.astype(float), np.nan)
        if not np.isfinite(y).any():
            continue
        lo, hi = int(np.nanargmin(y)), int(np.nanargmax(y))
        ranges.append(f"{figure_label(name)} from {num(float(y[lo]))} ({at(lo)}) to "
                      f"{num(float(y[hi]))} ({at(hi)})")
    answer = (("over the points that ran ok: " + "; ".join(ranges) + ".") if ranges
              else "no point ran ok: there is no figure to compare.")
    return answer_lines(
        f"{len(statuses)} points of the base config over {axes}; each point one full run.",
        answer,
        "points by status: " + ", ".join(f"{k} {v}" for k, v in counts.items())
        + f"; base overrides {flat.attrs.get('base_overrides')}.")


def write_sweep_report(ds: xr.Dataset, outdir: str | Path) -> dict[str, Path]:
    """sweep.md (one row per point) and sweep.png (a line or heat map per figure)."""
    outdir = Path(outdir)
    dims = list(ds.status.dims)
    names = _sweep_figures(ds)
    flat = ds.stack(point=dims) if len(dims) > 1 else ds.rename({dims[0]: "point"})
    header = [axis_label(ds, d) for d in dims] + ["status", *[figure_label(n) for n in names]]
    if "stability_limit_dt_s" in ds:
        header.append("RK4 limit dt (s)")
    statuses = [str(s) for s in flat.status.values]
    cells, notes = status_cells(statuses, [str(m) for m in flat.message.values])
    rows = []
    for i in range(flat.sizes["point"]):
        p = flat.isel(point=i)
        coords = [p[d].item() for d in dims] if len(dims) > 1 else [p["point"].item()]
        row = [*coords, cells[i], *[_value(float(p[n])) for n in names]]
        if "stability_limit_dt_s" in ds:
            row.append(_value(float(p.stability_limit_dt_s)))
        rows.append(row)
    lines = [f"# {ds.attrs.get('title', 'sweep')}", "",
             *_answer(flat, dims, names, statuses),
             f"{ds.attrs.get('points_run')} of {ds.attrs.get('points')} points ran; base "
             f"overrides {ds.attrs.get('base_overrides')}. Refused points (invalid) were not "
             f"run and have no figures ({NO_VALUE}); stopped runs keep their status. The "
             "reasons are numbered below the table.", "", "![sweep](sweep.png)", ""]
    lines += table(header, rows)
    if notes:
        lines += ["", *[f"{n}  " for n in notes]]
    md, png = report_paths(outdir).values()
    write_text(md, "\n".join(lines) + "\n")
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
            if log_scale(y[ok | stopped]):
                ax.set_yscale("log")
                ax.set_title(f"{figure_label(name)} (log scale)", fontsize=9)
            else:
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
        if not ax.get_title():
            ax.set_title(figure_label(name), fontsize=9)
        ax.grid(alpha=0.3, which="both")
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    fig.suptitle(ds.attrs.get("title", ""))
    fig.tight_layout()
    if len(dims) == 1:  # one legend for every panel, above them: it hides no point
        handles, labels = axes.flat[0].get_legend_handles_labels()
        fig.subplots_adjust(top=1 - 0.9 / fig.get_figheight())
        fig.legend(handles, labels, loc="upper center", ncol=len(labels), fontsize=8,
                   bbox_to_anchor=(0.5, 1 - 0.35 / fig.get_figheight()), frameon=False)
    save_figure(fig, png, dpi=100)
    plt.close(fig)
    return {"md": md, "png": png}
