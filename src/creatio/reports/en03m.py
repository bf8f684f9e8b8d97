"""EN-03M's report (docs/studies.md): the smallest confining force that carries the sphere
through the cycle in microgravity, per confinement and structure inertia. From the study's
datasets it writes ``en03m.json``, ``.md``, ``.png``, ``_history.csv`` (the search's runs),
``_trajectory.png`` and ``_convergence.png``. :func:`en03m_summary` gives the JSON summary.
Nothing here recomputes the study."""

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
    study_status,
    table,
    value_key,
    write_csv,
    write_markdown,
)

__all__ = ["en03m_summary", "write_en03m"]


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
    runs = as_list(datasets)
    ds = runs[0]
    other = runs[1] if len(runs) > 1 else None
    out: dict[str, Any] = {"study": ds.attrs.get("study", "en03m")}
    cells = []
    for i, kind in enumerate(ds.confinement.values):
        by = {}
        for j, v in enumerate(ds.structure_inertia.values):
            cell = _en03m_cell(ds, other, i, j)
            cell["structure_inertia_kg_m2"] = float(v)
            by[value_key(float(v))] = cell
            cells.append(cell)
        first = dict(next(iter(by.values())))
        first["by_structure_inertia"] = by
        out[str(kind)] = first
    statuses = [c["status"] for c in cells] + [str(x) for x in ds.probe_status.values.ravel()
                                               if str(x)]
    out.update({
        "status": study_status(statuses),
        "timestep_difference_m": finite_max([c["timestep_difference_m"] for c in cells]),
        "energy_residual_J": finite_max([c["energy_residual_J"] for c in cells]),
        "angular_momentum_drift": finite_max([c["angular_momentum_drift"] for c in cells]),
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
            line, = ax.semilogx(x, y, "-", lw=0.8, label=f"{kind}, I_s = {value_key(float(v))}")
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
                        label=f"{kind}, I_s = {value_key(float(v))}, P = "
                              f"{fmt(float(ds.figure_force.values[i, j]))} N")
        ax.set_xlabel("time (s)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0, 1].legend(fontsize=6)
    fig.suptitle("EN-03M: the search for the smallest carrying force, and the figure runs",
                 fontsize=10)
    finish_figure(fig, path)


def _en03m_convergence(runs: Sequence[xr.Dataset], path: Path) -> None:
    ds = runs[0]
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(15, 4))
    t = ds.time.values
    for i, kind in enumerate(ds.confinement.values):
        for j, v in enumerate(ds.structure_inertia.values):
            label = f"{kind}, I_s = {value_key(float(v))}"
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
    finish_figure(fig, path)


def _or(value: Any, text: str) -> Any:
    """value formatted, or text where it is absent (None or NaN: nothing carried, or no
    structure to conserve H_z for)."""
    return text if value is None or (isinstance(value, float) and math.isnan(value)) \
        else fmt(value)


def _answer(s: dict, kinds: Sequence[str], method: str) -> list[str]:
    """EN-03M's plain-word answer, from its summary: the smallest confining force that
    carries the sphere, per confinement and structure inertia."""
    parts = []
    for kind in kinds:
        cells = s[kind]["by_structure_inertia"]
        found = ", ".join(
            f"I_s = {key} kg m^2: "
            + (f"none up to {num(s['max_force_N'], 'N')}"
               if c["min_confining_force_N"] is None or not math.isfinite(
                   c["min_confining_force_N"]) else num(c["min_confining_force_N"], "N"))
            for key, c in cells.items())
        parts.append(f"{kind} confinement: {found}")
    what = ("the smallest confining force P that keeps the sphere carried through the cycle, "
            f"for each confinement ({', '.join(kinds)}) and structure inertia I_s, by a "
            f"search from {num(s['reference_force_N'], 'N')} x 10^k up to "
            f"{num(s['max_force_N'], 'N')}.")
    answer = "smallest carrying P: " + "; ".join(parts) + "."
    dts = ", ".join(f"{d:g}" for d in s["dt_s"])
    basis = (f"{method.upper()} at dt = {dts} s (figure runs' centres "
             f"differ by at most {num(s['timestep_difference_m'], 'm', 3)}); energy residual "
             f"at most {num(s['energy_residual_J'], 'J', 3)}; g = "
             f"{num(s['gravity_m_s2'], 'm/s^2')}.")
    return answer_lines(what, answer, basis)


def write_en03m(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en03m.json/.md/.png, _history.csv (every run of the search), _trajectory.png,
    _convergence.png."""
    runs, s, paths = start_report(datasets, outdir, en03m_summary)
    ds = runs[0]
    _en03m_figure(ds, s, paths["png"])
    named = []
    for i, kind in enumerate(ds.confinement.values):
        for j, v in enumerate(ds.structure_inertia.values):
            cell = ds.isel(confinement=i, structure_inertia=j)
            named.append((f"{kind}, I_s = {value_key(float(v))}", cell))
    paths_figure(named, paths["trajectory"], "EN-03M figure runs")
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
    write_csv(paths["csv"], ["confinement", "structure_inertia_kg_m2", "run", "force_N",
                              "dt_s", "status", "carried", "left_cavity_time_s", "angle_deg",
                              "lag_deg"], rows)
    lines = run_header(ds, runs, s["study"])
    lines[2:2] = _answer(s, [str(k) for k in ds.confinement.values],
                         str(ds.attrs.get("method", "rk4")))
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
