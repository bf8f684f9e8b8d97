"""EN-07's report (docs/aerospace.md): a demonstrator in microgravity. From the study's three
datasets (told apart by their ``part`` attribute) it writes ``en07.json`` (the contract:
similarity, platforms, interfaces), ``.md`` and ``.html``, ``.png`` (the requirements table:
platforms and laws against the constraints, pass or fail), ``_feasible.png`` (every run of
each platform's search in the (scale, preload) plane, the preload ceiling and the window's
boundary) and ``_yaw.png`` (host yaw against host inertia beside the point-mass closed
form). Nothing here recomputes the study; when the similarity check fails, no platform is
reported as passing (the requirements rest on it)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.colors import ListedColormap

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import fmt, plt, save_figure, start_report, table, write_markdown

__all__ = ["en07_summary", "write_report"]

#: The per-law figures of the contract: (JSON key, dataset variable).
LAW_FIGURES = (("scale", "scale"), ("preload_N", "preload_N"), ("transport_s", "transport_s"),
               ("residual_drift_m", "residual_drift_m"),
               ("P_actuator_peak_W", "P_actuator_peak"), ("E_actuator_J", "E_actuator"),
               ("stroke_m", "stroke"), ("bandwidth_hz", "bandwidth"),
               ("mount_force_peak_N", "mount_force_peak_N"))

#: The interface figures of the contract, in order.
INTERFACE_FIGURES = ("mount_force_peak_N", "mount_force_rms_N", "torque_peak_N_m",
                     "yaw_excursion_deg", "yaw_rate_peak_deg_s", "stored_momentum_N_m_s",
                     "H_z_drift", "point_mass_yaw_deg")


def _by_part(runs: Sequence[xr.Dataset]) -> dict[str, xr.Dataset]:
    return {str(ds.attrs.get("part", "")): ds for ds in runs}


def _f(x: Any) -> float | None:
    """A finite float, or None (a null in the JSON)."""
    v = float(x)
    return v if math.isfinite(v) else None


def _similarity(ds: xr.Dataset) -> dict[str, Any]:
    cases = [{"s": float(ds.scale.values[i]), "a_g": float(ds.pull_g.values[i]),
              "max_position_error_scaled": _f(ds.max_position_error_scaled.values[i]),
              "time_factor": float(ds.time_factor.values[i]),
              "max_velocity_error_scaled": _f(ds.max_velocity_error_scaled.values[i])}
             for i in range(ds.sizes["case"])]
    return {"cases": cases, "holds": bool(int(ds.attrs["holds"])),
            "tolerance_bound_m": float(ds.attrs["tolerance_bound"]),
            "base_partner_difference_m": float(ds.attrs["base_partner_difference"]),
            "method": str(ds.attrs["method"]), "rtol": float(ds.attrs["rtol"])}


def _platforms(ds: xr.Dataset, holds: bool) -> dict[str, Any]:
    out: dict[str, Any] = {}
    strain = float(ds.attrs["max_strain"])
    for i, name in enumerate(str(p) for p in ds.platform.values):
        laws = {}
        for j, law in enumerate(str(x) for x in ds.law.values):
            ok = bool(int(ds.passed.values[i, j])) and holds
            row: dict[str, Any] = {
                "pass": ok,
                "binding": (str(ds.binding.values[i, j]) if holds
                            else "similarity_check_failed"),
                "preload_set_by": str(ds.preload_set_by.values[i, j]),
            }
            row.update({key: _f(ds[var].values[i, j]) for key, var in LAW_FIGURES})
            row["max_strain"] = strain
            row["constraints"] = {str(c): bool(int(ds.constraint_passed.values[i, j, k]))
                                  for k, c in enumerate(ds.constraint.values)}
            laws[law] = row
        out[name] = {"window_s": _f(ds.window_s.values[i]),
                     "residual_g": float(ds.residual_g.values[i]),
                     "preload_max_g": float(ds.preload_max_g.values[i]),
                     "budget_s": float(ds.budget_s.values[i]),
                     "label": str(ds.label.values[i]), "laws": laws}
    return out


def _interfaces(ds: xr.Dataset) -> dict[str, Any]:
    cases = []
    for i, I_s in enumerate(ds.host_inertia.values):
        row: dict[str, Any] = {"I_host_kg_m2": float(I_s)}
        row.update({k: _f(ds[k].values[i]) for k in INTERFACE_FIGURES})
        cases.append(row)
    return {"cases": cases, "scale": float(ds.attrs["scale"]),
            "pull_g": float(ds.attrs["pull_g"])}


def en07_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-07: similarity, platforms, interfaces, the computation's cost."""
    runs = [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)
    parts = _by_part(runs)
    first = runs[0]
    out: dict[str, Any] = {"study": first.attrs.get("study", "en07")}
    holds = False
    if "similarity" in parts:
        out["similarity"] = _similarity(parts["similarity"])
        holds = out["similarity"]["holds"]
    if "requirements" in parts:
        rq = parts["requirements"]
        out["platforms"] = _platforms(rq, holds)
        out["requirements"] = {k: float(rq.attrs[k]) for k in (
            "margin", "scale_min", "scale_max", "preload_min_g", "rel_tol", "drift_max_radii",
            "max_strain", "strain_limit")}
    if "interfaces" in parts:
        out["interfaces"] = _interfaces(parts["interfaces"])
    out["cost"] = {"cpu_s": sum(float(ds.attrs.get("cpu_s", math.nan)) for ds in runs),
                   "wall_s": sum(float(ds.attrs.get("wall_s", math.nan)) for ds in runs),
                   "parts": {p: {"cpu_s": float(ds.attrs.get("cpu_s", math.nan)),
                                 "wall_s": float(ds.attrs.get("wall_s", math.nan))}
                             for p, ds in parts.items()}}
    out["config_sha256"] = first.attrs.get("config_sha256", "")
    return out


# ------------------------------------------------------------------------------ the answer
def _answer(s: dict[str, Any]) -> list[str]:
    """The opening lines: what was computed, the answer, what it rests on."""
    what = ("the similarity check of the scaled model, the largest demonstrator and smallest "
            "preload that carry one 360-degree transport on each platform (quintic cycle and "
            "closed loop), and the loads and yaw the host feels.")
    lines = []
    sim = s.get("similarity")
    if sim:
        worst = max((c["max_position_error_scaled"] or math.inf) for c in sim["cases"])
        lines.append(f"similarity {'holds' if sim['holds'] else 'does NOT hold'}: largest "
                     f"scaled position difference {num(worst, 'm', 2)} against the bound "
                     f"{num(sim['tolerance_bound_m'], 'm', 2)}")
    plats = s.get("platforms", {})
    if plats:
        parts = []
        for name, p in plats.items():
            verdict = ", ".join(f"{law} {'passes' if v['pass'] else 'fails'} ({v['binding']})"
                                for law, v in p["laws"].items())
            parts.append(f"{name}: {verdict}")
        lines.append("; ".join(parts))
    its = s.get("interfaces", {}).get("cases", [])
    if its:
        lines.append("host yaw " + ", ".join(
            f"{num(c['yaw_excursion_deg'], 'deg', 3)} at I = {fmt(c['I_host_kg_m2'])} kg m^2"
            for c in its))
    return answer_lines(what, lines or ["nothing computed"],
                        "the similarity of the pull (checked here), illustrative platforms, "
                        "EN-04's controller and actuation figures, EN-06's strain, EN-03's "
                        "free structure.")


# ---------------------------------------------------------------------------- the figures
def _table_figure(ds: xr.Dataset, path: Path, holds: bool) -> None:
    """Platforms x laws against the constraints: green pass, red fail, the binding one framed."""
    rows = [(str(p), str(law)) for p in ds.platform.values for law in ds.law.values]
    cons = [str(c) for c in ds.constraint.values]
    grid = ds.constraint_passed.values.reshape(len(rows), len(cons)).astype(float)
    passed = ds.passed.values.reshape(len(rows)).astype(bool) & holds
    fig, ax = plt.subplots(figsize=(1.6 * len(cons) + 4.0, 0.45 * len(rows) + 1.6))
    ax.imshow(grid, cmap=ListedColormap(["#e07070", "#7cc47c"]), vmin=0, vmax=1,
              aspect="auto")
    binding = ds.binding.values.reshape(len(rows))
    for r in range(len(rows)):
        for c, name in enumerate(cons):
            bound = name in str(binding[r]).split("+")
            ax.text(c, r, ("binds" if bound else "") + (" ok" if grid[r, c] else " fail"),
                    ha="center", va="center", fontsize=8,
                    fontweight="bold" if bound else "normal")
    ax.set_xticks(range(len(cons)), cons, rotation=20)
    ax.set_yticks(range(len(rows)),
                  [f"{p} / {law}: {'PASS' if ok else 'FAIL'}"
                   for (p, law), ok in zip(rows, passed, strict=True)])
    ax.set_title("EN-07 requirements: platform / law against each constraint")
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _feasible_figure(ds: xr.Dataset, path: Path) -> None:
    """Each platform's search in the (scale, preload) plane: every run (filled: carried
    within the budget and the drift limit), the design point, the preload ceiling, the scale
    range and the window's boundary through the bracket (P proportional to s)."""
    names = [str(p) for p in ds.platform.values]
    laws = [str(x) for x in ds.law.values]
    m, g = float(ds.attrs["sphere_mass"]), float(ds.attrs["g"])
    fig, axes = plt.subplots(1, len(names), figsize=(4.0 * len(names), 3.8), squeeze=False)
    colors = {"quintic": "tab:blue", "closed_loop": "tab:orange"}
    for i, (ax, name) in enumerate(zip(axes[0], names, strict=True)):
        for j, law in enumerate(laws):
            s = ds.trial_scale.values[i, j]
            P = ds.trial_pull_g.values[i, j] * m * g
            ok = ds.trial_feasible.values[i, j] == 1.0
            keep = np.isfinite(s)
            c = colors.get(law, "k")
            ax.scatter(s[keep & ok], P[keep & ok], color=c, s=14, label=f"{law} carries")
            ax.scatter(s[keep & ~ok], P[keep & ~ok], facecolors="none", edgecolors=c, s=14,
                       label=f"{law} does not")
            s_in, a_in = ds.inside_scale.values[i, j], ds.inside_pull_g.values[i, j]
            if np.isfinite(s_in) and np.isfinite(a_in):
                xs = np.geomspace(float(ds.attrs["scale_min"]), float(ds.attrs["scale_max"]),
                                  20)
                ax.plot(xs, a_in * m * g * xs / s_in, color=c, lw=0.8, ls=":")
        ax.axhline(float(ds.preload_max_g.values[i]) * m * g, color="k", lw=1,
                   label="preload ceiling")
        for x in (float(ds.attrs["scale_min"]), float(ds.attrs["scale_max"])):
            ax.axvline(x, color="grey", lw=0.8, ls="--")
        w = float(ds.window_s.values[i])
        ax.set_title(f"{name}\nwindow {fmt(w) + ' s' if math.isfinite(w) else 'none'}, "
                     f"budget {fmt(float(ds.budget_s.values[i]))} s", fontsize=9)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("scale s")
    axes[0][0].set_ylabel("preload P = m a (N)")
    axes[0][-1].legend(fontsize=6, loc="lower right")
    fig.suptitle("EN-07 feasible region: runs of each search (filled: carried within the "
                 "budget and the drift limit); dotted: the boundary through the bracket "
                 "(P proportional to s by the similarity); solid: the preload ceiling",
                 fontsize=9)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _yaw_figure(ds: xr.Dataset, path: Path) -> None:
    """Host yaw against host inertia beside the point-mass closed form (and its 1 / I_s tail)."""
    inertia = ds.host_inertia.values
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    ax.loglog(inertia, np.abs(ds.yaw_excursion_deg.values), "o-", label="yaw excursion (run)")
    ax.loglog(inertia, np.abs(ds.point_mass_yaw_deg.values), "x--",
              label="point mass: m rho^2 / (I_s + m rho^2) x 360 deg")
    tail = abs(float(ds.point_mass_yaw_deg.values[-1])) * inertia[-1] / inertia
    ax.loglog(inertia, tail, ":", color="grey", label="1 / I_s")
    ax.set_xlabel("host inertia I_s (kg m^2)")
    ax.set_ylabel("|yaw| (deg)")
    ax.set_title("EN-07 interfaces: host yaw over one transport")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


# ---------------------------------------------------------------------------- the sections
def _similarity_section(s: dict[str, Any]) -> list[str]:
    sim = s["similarity"]
    rows = [[fmt(c["s"]), fmt(c["a_g"]), fmt(c["time_factor"]),
             num(c["max_position_error_scaled"], digits=3),
             num(c["max_velocity_error_scaled"], digits=3)] for c in sim["cases"]]
    verdict = ("holds: the requirements below build on it" if sim["holds"] else
               "does NOT hold: the requirements below do not rest on a checked similarity, "
               "and no platform is reported as passing")
    return ["## Similarity", "",
            f"Base and scaled runs at {sim['method']}, rtol = {fmt(sim['rtol'])}; bound = rtol "
            f"x max |X| = {num(sim['tolerance_bound_m'], 'm', 3)}; the base against its "
            f"convergence partner differs by {num(sim['base_partner_difference_m'], 'm', 3)}. "
            f"The similarity {verdict}.", "",
            *table(["s", "a / g", "time factor", "max |X'/s - X| (m)",
                    "max |V'/v - V| (m/s)"], rows), ""]


def _requirements_section(s: dict[str, Any], paths: dict[str, Path]) -> list[str]:
    rq = s["requirements"]
    rows = []
    for name, p in s["platforms"].items():
        for law, v in p["laws"].items():
            rows.append([name, law, "PASS" if v["pass"] else "FAIL", v["binding"],
                         v["preload_set_by"],
                         num(v["scale"], digits=4), num(v["preload_N"], "N", 4),
                         num(v["transport_s"], "s", 4), num(v["residual_drift_m"], "m", 3),
                         num(v["P_actuator_peak_W"], "W", 3), num(v["E_actuator_J"], "J", 3),
                         num(v["stroke_m"], "m", 3), num(v["bandwidth_hz"], "Hz", 3),
                         num(v["mount_force_peak_N"], "N", 3)])
    return ["## Requirements", "",
            f"One 360-degree transport within window / {fmt(rq['margin'])} (the budget); the "
            f"largest scale in [{fmt(rq['scale_min'])}, {fmt(rq['scale_max'])}] at the preload "
            f"ceiling, then at the largest scale the smallest pull down to "
            f"{fmt(rq['preload_min_g'])} g, by bisection of direct runs to "
            f"{fmt(100 * rq['rel_tol'])} %; the residual may move the sphere off its path by "
            f"{fmt(rq['drift_max_radii'])} radii. Peak membrane strain (scale-free) "
            f"{num(rq['max_strain'], digits=4)} against eps_u = {fmt(rq['strain_limit'])}.", "",
            *table(["platform", "law", "verdict", "binds", "preload set by", "scale",
                    "preload", "transport",
                    "drift", "P_act peak", "E_act", "stroke", "bandwidth", "mount force"],
                   rows), "",
            f"![requirements]({paths['png'].name})", "",
            f"![feasible region]({paths['feasible'].name})", ""]


def _interfaces_section(s: dict[str, Any], paths: dict[str, Path]) -> list[str]:
    it = s["interfaces"]
    rows = [[fmt(c["I_host_kg_m2"]), *(num(c[k], digits=4) for k in INTERFACE_FIGURES)]
            for c in it["cases"]]
    return ["## Interfaces", "",
            f"The base at scale {fmt(it['scale'])} under the base pull {fmt(it['pull_g'])} g "
            "(g = 0 besides) on a host free to yaw.", "",
            *table(["I_s (kg m^2)", "F peak (N)", "F rms (N)", "torque (N m)", "yaw (deg)",
                    "yaw rate (deg/s)", "H stored (N m s)", "H_z drift", "point mass (deg)"],
                   rows), "",
            f"![host yaw]({paths['yaw'].name})", ""]


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en07.json/.md/.html, en07.png, en07_feasible.png and en07_yaw.png."""
    runs, s, paths = start_report(datasets, outdir, en07_summary)
    out = Path(outdir)
    study = s["study"]
    paths = {"json": paths["json"], "md": paths["md"], "html": paths["html"],
             "png": paths["png"], "feasible": out / f"{study}_feasible.png",
             "yaw": out / f"{study}_yaw.png"}
    parts = _by_part(runs)
    first = runs[0]
    lines = [f"# {first.attrs.get('title', study)}", "", *_answer(s),
             f"Config sha256 `{str(s['config_sha256'])[:12]}`, creatio "
             f"{first.attrs.get('creatio_version')}, commit "
             f"{str(first.attrs.get('git_commit', ''))[:10]}.", ""]
    holds = bool(s.get("similarity", {}).get("holds", False))
    if "similarity" in s:
        lines += _similarity_section(s)
    if "requirements" in parts:
        _table_figure(parts["requirements"], paths["png"], holds)
        _feasible_figure(parts["requirements"], paths["feasible"])
        lines += _requirements_section(s, paths)
    if "interfaces" in parts:
        _yaw_figure(parts["interfaces"], paths["yaw"])
        lines += _interfaces_section(s, paths)
    cost = s["cost"]
    lines += ["## Cost", "", f"CPU {num(cost['cpu_s'], 's', 3)}, wall "
              f"{num(cost['wall_s'], 's', 3)} over the three parts (compilation included "
              "where a loop was not yet cached).", "",
              "## Assumptions", "",
              "Illustrative platforms; the residual is quasi-steady and adds to the pull as "
              "one gravity vector (a tilt); the interfaces carry the pull alone (the free "
              "structure takes no tilt); the membrane's areal density is kept at every scale.",
              ""]
    write_markdown(paths["md"], "\n".join(lines))
    return paths
