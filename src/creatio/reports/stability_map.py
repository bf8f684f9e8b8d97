"""Report of the stability map (creatio.studies.stability_map): JSON figures, markdown tables
and the figure (largest good dt against the axis, error against dt / estimate).

Derived from the datasets alone: one per axis (attrs ``axis`` = mu, eps) and the optional
duration check (``axis`` = duration).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.model.sphere import STABILITY_MARGIN
from creatio.reports.answer import answer_lines, num
from creatio.reports.common import fmt, plt, save_figure, strict_json, table, write_text

__all__ = ["figure", "method_colors", "summary", "write_report"]

STUDY = "stability_map"
DURATION_AXIS = "duration"


def _cell(x: Any) -> Any:
    """A table cell: "-" for a figure not found (NaN: no break, no good dt), else the number."""
    x = float(x)
    return x if math.isfinite(x) else "-"


def _split(sets: Sequence[xr.Dataset]) -> tuple[list[xr.Dataset], xr.Dataset | None]:
    maps = [d for d in sets if d.attrs["axis"] != DURATION_AXIS]
    checks = [d for d in sets if d.attrs["axis"] == DURATION_AXIS]
    return maps, (checks[0] if checks else None)


def _axis_summary(d: xr.Dataset) -> dict[str, Any]:
    """Per method and value: estimate, linear limit, largest good and first broken dt, the
    ratios and the break kind; per value: the validation check."""
    values = [float(v) for v in d.value.values]
    methods: dict[str, Any] = {}
    for m in d.method.values:
        s = d.sel({"method": m})
        methods[str(m)] = {
            "real_stability_bound": float(s.real_stability_bound),
            "points": [
                {
                    "value": v,
                    "estimate_dt_s": float(s.estimate_dt[j]),
                    "linear_limit_dt_s": float(s.linear_limit_dt[j]),
                    "largest_good_dt_s": float(s.largest_stable_dt[j]),
                    "first_broken_dt_s": float(s.first_broken_dt[j]),
                    "ratio": float(s.ratio[j]),
                    "broken_ratio": float(s.broken_ratio[j]),
                    "limited_by": str(s.limited_by.values[j]),
                    "runs": int(np.isfinite(s.dt.values[j]).sum()),
                }
                for j, v in enumerate(values)
            ],
        }
    out: dict[str, Any] = {
        "values": values,
        "units": d.value.attrs.get("units", ""),
        "reference_agreement_m": float(np.nanmax(d.reference_agreement_m)),
        "methods": methods,
        "validation": None,
    }
    if "validation_limit_dt" in d:
        out["validation"] = {
            "method": str(d.attrs.get("validation_method", "rk4")),
            "agrees": bool(d.validation_agrees.all()),
            "accepted_broken": int(d.accepted_broken.sum()),
            "accepted_unstable": int(d.accepted_unstable.sum()),
            "points": [
                {
                    "value": v,
                    "step_limit_dt_s": float(d.validation_limit_dt[j]),
                    "refuses_exactly_above_limit": bool(d.validation_agrees[j]),
                    "good_ratio": float(d.validation_good_ratio[j]),
                    "break_ratio": float(d.validation_break_ratio[j]),
                    "accepted_broken": int(d.accepted_broken[j]),
                    "accepted_unstable": int(d.accepted_unstable[j]),
                }
                for j, v in enumerate(values)
            ],
        }
    return out


def _check_summary(d: xr.Dataset) -> dict[str, Any]:
    """Per mu and method: (largest good, first broken) dt per duration, and whether equal."""
    durations = [float(t) for t in d.duration.values]
    out: dict[str, Any] = {"durations_s": durations, "mu": {}}
    for mu in d.mu.values:
        by_method = {}
        for m in d.method.values:
            s = d.sel({"mu": mu, "method": m})
            pairs = [(float(g), float(b)) for g, b in zip(s.largest_stable_dt.values,
                                                          s.first_broken_dt.values, strict=True)]
            by_method[str(m)] = {
                "largest_good_dt_s": [p[0] for p in pairs],
                "first_broken_dt_s": [p[1] for p in pairs],
                "same": len({(_key(g), _key(b)) for g, b in pairs}) == 1,
            }
        out["mu"][repr(float(mu))] = by_method
    return out


def _key(x: float) -> float | None:
    return x if math.isfinite(x) else None


def summary(sets: Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report: settings, per axis the map and the validation check, the duration
    check and the computing time."""
    maps, check = _split(sets)
    a = sets[0].attrs
    return {
        "study": str(a.get("study", STUDY)),
        "config_sha256": str(a.get("config_sha256", "")),
        "base": str(a.get("base", "en02")),
        "tolerance_m": float(a["tolerance_m"]),
        "duration_s": float(a["duration_s"]),
        "output_interval_s": float(a["output_interval_s"]),
        "reference": str(a["reference"]),
        "cross_check": str(a["cross_check"]),
        "chatter_factor": float(a["chatter_factor"]),
        "axes": {str(d.attrs["axis"]): _axis_summary(d) for d in maps},
        "validation_agrees": all(bool(d.validation_agrees.all()) for d in maps
                                 if "validation_agrees" in d),
        "duration_check": _check_summary(check) if check is not None else None,
        "compute_seconds": float(sum(float(d.attrs.get("compute_seconds", 0.0)) for d in sets)),
    }


def method_colors(methods: Sequence[str]) -> dict[str, Any]:
    """One colour per method, for any number of methods (tab10, or viridis beyond 10)."""
    n = len(methods)
    if n <= 10:
        cmap = plt.get_cmap("tab10")
        return {m: cmap(i) for i, m in enumerate(methods)}
    cmap = plt.get_cmap("viridis")
    return {m: cmap(i / (n - 1)) for i, m in enumerate(methods)}


def figure(sets: xr.Dataset | Sequence[xr.Dataset], path: str | Path) -> Path:
    """Largest good dt against the axis value (log-log) with the estimate, one column per
    axis, and the error against dt / estimate underneath."""
    from matplotlib.ticker import NullFormatter

    maps, _ = _split([sets] if isinstance(sets, xr.Dataset) else list(sets))
    fig, axes = plt.subplots(2, len(maps), figsize=(6.0 * len(maps), 9.0), squeeze=False)
    every = list(dict.fromkeys(str(m) for d in maps for m in d.method.values))
    colors = method_colors(every)
    for c, d in enumerate(maps):
        top, bottom = axes[0, c], axes[1, c]
        axis = d.attrs["axis"]
        x = d.value.values
        for m in d.method.values:
            m = str(m)
            color = colors[m]
            sel = d.sel({"method": m})
            top.loglog(x, sel.estimate_dt, "--", color=color, label=f"{m} estimate")
            top.loglog(x, sel.largest_stable_dt, "o-", color=color, label=f"{m} largest good")
            top.loglog(x, sel.first_broken_dt, "x", color=color, ms=7)
            for j in range(x.size):
                ok = np.isfinite(sel.dt.values[j])
                ratio = sel.dt.values[j][ok] / float(sel.estimate_dt[j])
                err = np.clip(sel.error_m.values[j][ok], 1e-16, 1.0)
                bottom.loglog(ratio, err, ".-", color=color, alpha=0.5,
                              label=m if j == 0 else None)
        top.set_xlabel(f"{axis} ({d.value.attrs['units']})")
        top.set_ylabel("dt (s)")
        top.set_title(f"fixed-step break vs {axis} (x: first broken dt)")
        top.legend(fontsize=7)
        for ax in (top, bottom):
            ax.xaxis.set_minor_formatter(NullFormatter())
        top.grid(True, which="both", alpha=0.3)
        bottom.axhline(float(d.attrs["tolerance_m"]), color="k", lw=0.8)
        bottom.axvline(1.0, color="k", ls=":", lw=0.8)
        bottom.set_xlabel("dt / estimate")
        bottom.set_ylabel("max |X - X_ref| (m), clipped to [1e-16, 1]")
        bottom.set_title(f"error vs dt, every {axis} (line: tolerance)")
        bottom.legend(fontsize=7)
        bottom.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path


def _answer(s: dict[str, Any]) -> list[str]:
    """The stability map's plain-word answer, from its summary: per scheme how the largest
    good step compares with the estimate, and whether the validation refuses exactly the
    steps beyond it."""
    ratios: dict[str, list[float]] = {}
    for ax in s["axes"].values():
        for m, per in ax["methods"].items():
            ratios.setdefault(m, []).extend(p["ratio"] for p in per["points"]
                                            if math.isfinite(p["ratio"]))
    axes = ", ".join(f"{name} = {', '.join(f'{v:g}' for v in ax['values'])}"
                     for name, ax in s["axes"].items())
    def span(r: list[float]) -> str:
        lo, hi = num(min(r), digits=3), num(max(r), digits=3)
        return f"{lo} times the estimate" if lo == hi else f"{lo} to {hi} times the estimate"

    per_method = "; ".join(f"{m}: {span(r)}" if r else f"{m}: no good step found"
                           for m, r in ratios.items())
    answer = [f"the largest step that stays good is, per scheme, {per_method}."]
    checked = [ax["validation"] for ax in s["axes"].values() if ax["validation"]]
    if checked:
        broken = sum(v["accepted_broken"] for v in checked)
        answer.append(f"the config validation ({checked[0]['method'].upper()}) "
                      + ("refuses exactly the steps above its limit" if s["validation_agrees"]
                         else "does NOT refuse exactly the steps above its limit")
                      + f"; it accepts {broken} step(s) that break.")
    agree = max((ax["reference_agreement_m"] for ax in s["axes"].values()), default=math.nan)
    return answer_lines(
        f"the largest fixed step dt at which each explicit scheme follows the reference "
        f"within {num(s['tolerance_m'], 'm')} over {num(s['duration_s'], 's')} of "
        f"{s['base'].upper()}, along {axes}.", answer,
        f"the reference {s['reference']} (its cross-check {s['cross_check']} agrees to "
        f"{num(agree, 'm', 3)}); a run is good when its status is ok and its centre stays "
        "within the tolerance at every output.")


def markdown(sets: Sequence[xr.Dataset], title: str = "") -> str:
    """The markdown report: the method, per axis the map and the validation check, the
    duration check."""
    maps, check = _split(sets)
    a = sets[0].attrs
    interval = fmt(float(a["output_interval_s"]))
    reference_method = str(a["reference"]).split()[0]
    lines = [
        f"# {title or 'Stability map of the fixed-step explicit schemes (EN-02)'}",
        "",
        *_answer(summary(sets)),
        f"dt = {interval} s / n; a run is good when its status is ok and its centre stays "
        f"within {fmt(float(a['tolerance_m']))} m of the reference ({a['reference']}) on "
        f"every {interval} s output, over {fmt(float(a['duration_s']))} s. Estimate: "
        "creatio.dynamics.stability_limit (bound / (3.5 mu N_est / (m eps)), N_est = "
        f"{fmt(STABILITY_MARGIN)} max(N0, m g)). Ratio: largest good dt / estimate; the break "
        "lies between the largest good and the first broken dt. Linear limit: the same bound "
        f"at the reference's largest N, without the {fmt(STABILITY_MARGIN)} margin (the exact "
        "slip-mode limit).",
        "",
        f"Config sha256 `{str(a.get('config_sha256', ''))[:12]}`, creatio "
        f"{a.get('creatio_version', '')}, commit {str(a.get('git_commit', ''))[:10]}.",
        "",
    ]
    for d in maps:
        axis = d.attrs["axis"]
        agree = float(np.nanmax(d.reference_agreement_m))
        lines += [
            f"## Along {axis}",
            "",
            f"Reference agreement ({d.attrs['cross_check']} vs {reference_method}): max "
            f"{fmt(agree)} m over the values.",
            "",
        ]
        rows = []
        for m in d.method.values:
            for j, v in enumerate(d.value.values):
                s = d.sel({"method": m}).isel(value=j)
                rows.append([str(m), float(v), *(_cell(s[k]) for k in (
                    "estimate_dt", "linear_limit_dt", "largest_stable_dt", "first_broken_dt",
                    "ratio", "broken_ratio")), s.limited_by.item()])
        lines += table(["method", axis, "estimate (s)", "linear limit (s)",
                        "largest good dt (s)", "first broken dt (s)", "ratio",
                        "broken / estimate", "limited by"], rows)
        if "validation_limit_dt" in d:
            name = str(d.attrs.get("validation_method", "rk4")).upper()
            lines += [
                "",
                f"{name} config validation along {axis} (solver.dt set to each {name} dt "
                "tried, allow_unstable off):",
                "",
            ]
            lines += table(
                [axis, "step_limit (s)", "refuses exactly dt > limit", "largest good / limit",
                 "first broken / limit", "accepted but broken"],
                [[float(v), float(d.validation_limit_dt[j]), bool(d.validation_agrees[j]),
                  _cell(d.validation_good_ratio[j]), _cell(d.validation_break_ratio[j]),
                  int(d.accepted_broken[j])] for j, v in enumerate(d.value.values)])
        lines.append("")
    if check is not None:
        lines += [
            "## Shortened duration",
            "",
            "(largest good dt, first broken dt) in s, per simulated duration:",
            "",
        ]
        durations = [float(t) for t in check.duration.values]
        for mu in check.mu.values:
            rows = []
            for m in check.method.values:
                s = check.sel({"mu": mu, "method": m})
                pairs = list(zip(s.largest_stable_dt.values, s.first_broken_dt.values,
                                 strict=True))
                cells = [f"{fmt(_cell(g))}, {fmt(_cell(b))}" for g, b in pairs]
                same = len({(_key(float(g)), _key(float(b))) for g, b in pairs}) == 1
                rows.append([str(m), *cells, same])
            lines += table([f"mu = {fmt(float(mu))}", *(f"{fmt(t)} s" for t in durations),
                            "same"], rows)
            lines.append("")
    seconds = sum(float(d.attrs.get("compute_seconds", 0.0)) for d in sets)
    lines.append(f"Computed in {seconds:.1f} s.")
    return "\n".join(lines) + "\n"


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write stability_map.json, stability_map.md and stability_map.png to outdir."""
    from creatio.store.netcdf import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    sets = [ds for ds, _ in loaded]
    config = loaded[0][1]
    title = str(config.get("study", {}).get("title", "")) if config else ""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = {k: outdir / f"{STUDY}.{k}" for k in ("json", "md", "png")}
    write_text(paths["json"], strict_json(summary(sets)))
    write_text(paths["md"], markdown(sets, title))
    figure(sets, paths["png"])
    return paths
