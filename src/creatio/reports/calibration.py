"""The report of one `creatio calibrate` run, from its calibration dataset.

``calibration.json`` (the record `creatio ls` and the index list: kind, study, track,
parameters, estimate, interval, identifiable, status, created, with units and ranges),
``calibration.md`` (every table with its units; a key held at the bound of its physical
range shows the bound, never the value beyond it; what would pin a key that is not
identifiable) and ``calibration.png`` (residuals against time, their histogram, the path).
Nothing here recomputes.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.common import fmt, plt, save_figure, strict_json, table, write_text
from creatio.reports.en05 import residual_axes

__all__ = ["calibration_summary", "write_calibration_report"]


def _mapping(keys: list[str], values: Any) -> dict[str, float]:
    return {k: float(v) for k, v in zip(keys, values, strict=True)}


def calibration_summary(ds: xr.Dataset) -> dict[str, Any]:
    """The JSON record of one `creatio calibrate` run (what the index lists, and the fit)."""
    keys = [str(p) for p in ds.parameter.values]
    flags = dict(line.split(": ", 1) for line in str(ds.attrs.get("flags", "")).splitlines()
                 if ": " in line)
    units = ([str(u) for u in ds.unit.values] if "unit" in ds.coords
             else ["config units"] * len(keys))
    at_bound = (ds.at_bound.values.astype(bool) if "at_bound" in ds
                else np.zeros(len(keys), bool))
    ranges = (ds.physical_range.values if "physical_range" in ds
              else np.full((len(keys), 2), math.nan))
    interval = {k: [float(v) for v in ds.interval_95.values[i]] for i, k in enumerate(keys)}
    identifiable = {k: k not in flags for k in keys}
    run = str(ds.attrs["status"])
    lost = [k for k in keys if not identifiable[k]]
    status = "; ".join([*([run] if run != "ok" or not lost else []),
                        *([f"not identifiable: {', '.join(lost)}"] if lost else [])]) or "ok"
    return {
        "kind": "calibration",
        "study": str(ds.attrs["study"]),
        "track": str(ds.attrs["track_file"]),
        "parameters": keys,
        "units": dict(zip(keys, units, strict=True)),
        "physical_range": {k: [float(v) for v in ranges[i]] for i, k in enumerate(keys)},
        "estimate": _mapping(keys, ds.estimate.values),
        "at_bound": {k: bool(b) for k, b in zip(keys, at_bound, strict=True)},
        "unconstrained": ({k: [float(ds.unconstrained.values[i]),
                               float(ds.unconstrained_stderr.values[i])]
                           for i, k in enumerate(keys) if at_bound[i]}
                          if "unconstrained" in ds else {}),
        "stderr": _mapping(keys, ds.stderr.values),
        "interval": interval,
        "interval_95": interval,
        "confidence": 0.95,
        "correlation": [[float(v) for v in row] for row in ds.correlation.values],
        "residual_rms_m": float(ds.attrs["residual_rms_m"]),
        "noise_m": float(ds.attrs["noise_m"]),
        "frames": int(ds.sizes["frame"]),
        "condition": float(ds.attrs["condition"]),
        "identifiable": identifiable,
        "flags": flags,
        "next_step": str(ds.attrs.get("next_step", "")),
        "status": status,
        "run_status": run,
        "evaluations": int(ds.attrs["evaluations"]),
        "numerical_error": _accuracy(ds),
        "config_sha256": str(ds.attrs.get("config_sha256", "")),
        "created": str(ds.attrs.get("date_created", "")),
    }


def _accuracy(ds: xr.Dataset) -> dict[str, Any]:
    """The fit's checked model error (creatio.studies.budget.Verification): its line, the
    observed error and budget (m), the points, the setting; {} for a dataset without one."""
    from creatio.studies.budget import Verification

    try:
        v = Verification.from_attrs(ds.attrs)
    except KeyError:
        return {}
    name = v.worst() or next(iter(v.budget))
    return {"line": v.line(), "observed_m": v.observed[name], "budget_m": v.budget[name],
            "points": v.points, "ok": v.ok, "tightened": v.tightened, "rung": v.rung.label(),
            "reference": v.reference.label()}


def _markdown(s: dict[str, Any]) -> list[str]:
    """calibration.md: the fit's tables with units, the flags, what would pin a key."""
    keys = s["parameters"]
    lines = [f"# Calibration of {s['study']} to {Path(s['track']).name}", "",
             f"{s['frames']} frames; residual rms {fmt(s['residual_rms_m'])} m against the "
             f"stated noise {fmt(s['noise_m'])} m; run at the estimate: {s['run_status']}; "
             f"{s['evaluations']} model runs; condition of J^T J (scaled, dimensionless) "
             f"{fmt(s['condition'])}.", ""]
    acc = s["numerical_error"]
    if acc:
        lines += [f"Model: {acc['line']}, searched at {acc['rung']}, checked against "
                  f"{acc['reference']}" + (f"; tightened {acc['tightened']} time(s)"
                                          if acc["tightened"] else "")
                  + ("" if acc["ok"] else "; BUDGET BROKEN") + ".", ""]

    def cell(k: str, x: float) -> str:
        return "-" if not math.isfinite(x) else fmt(x)

    rows = []
    for k in keys:
        lo, hi = s["interval"][k]
        rlo, rhi = s["physical_range"][k]
        est = fmt(s["estimate"][k]) + (" (held at the bound)" if s["at_bound"][k] else "")
        rows.append([k, s["units"][k], est, cell(k, s["stderr"][k]),
                     f"[{fmt(lo)}, {fmt(hi)}]" if math.isfinite(lo) else "-",
                     f"[{fmt(rlo)}, {fmt(rhi)}]" if math.isfinite(rlo) else "none declared",
                     "yes" if s["identifiable"][k] else "no"])
    lines += table(["key", "unit", "estimate", "stderr", "95 % interval", "physical range",
                    "identifiable"], rows) + [""]
    lines += ["Correlation (dimensionless):", ""]
    lines += table(["", *keys], [[k, *(cell(k, v) for v in row)]
                                 for k, row in zip(keys, s["correlation"], strict=True)])
    lines.append("")
    for k, why in s["flags"].items():
        lines.append(f"* {k}: {why}")
    for k, (x, se) in s["unconstrained"].items():
        if k not in s["flags"]:
            lines.append(f"* {k}: held at the bound {fmt(s['estimate'][k])} of its physical "
                         f"range; the unconstrained fit ({fmt(x)} +- {fmt(se)}) lies beyond "
                         "it, its 95 % interval reaching into the range (the interval "
                         "shown is that part; the other keys are fitted with it held)")
    if s["next_step"]:
        lines += ["", f"* {s['next_step']}"]
    return lines


def write_calibration_report(ds: xr.Dataset, outdir: Path) -> dict[str, Path]:
    """calibration.json, .md and .png (residuals against time, their histogram, the path)."""
    s = calibration_summary(ds)
    outdir = Path(outdir)
    paths = {"json": write_text(outdir / "calibration.json", strict_json(s)),
             "md": write_text(outdir / "calibration.md", "\n".join(_markdown(s)) + "\n")}
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5))
    residual_axes(axes[:2], ds, s["noise_m"])
    coords = [str(c) for c in ds.coordinate.values]
    if "x" in coords and "y" in coords:
        ix, iy = coords.index("x"), coords.index("y")
        axes[2].plot(ds.track.values[:, ix], ds.track.values[:, iy], ".", ms=2, label="track")
        axes[2].plot(ds.model.values[:, ix], ds.model.values[:, iy], "-", lw=1,
                     label="model at the estimate")
        axes[2].set_aspect("equal", adjustable="datalim")
        axes[2].set_xlabel("x (m)")
        axes[2].set_ylabel("y (m)")
        axes[2].legend(fontsize=8)

    def shown(k: str) -> str:
        u = "" if s["units"][k] == "1" else f" {s['units'][k]}"
        if s["at_bound"][k]:
            why = "" if s["identifiable"][k] else " (not identifiable)"
            return f"{k} held at the bound {fmt(s['estimate'][k])}{u}{why}"
        return f"{k} = {fmt(s['estimate'][k])} +- {fmt(s['stderr'][k])}{u}"

    fig.suptitle(f"{s['study']} fitted to {Path(s['track']).name}: "
                 + ", ".join(shown(k) for k in s["parameters"]), fontsize=10)
    fig.tight_layout()
    save_figure(fig, outdir / "calibration.png", dpi=110)
    plt.close(fig)
    paths["png"] = outdir / "calibration.png"
    return paths
