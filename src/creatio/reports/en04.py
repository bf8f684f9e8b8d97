"""Report of EN-04: what the actuators must deliver, and the still-cavity check (docs/studies.md,
docs/model.md s.12).

From the study's datasets (``en04_actuation``, ``en04_oscillation``, ``en04_control``) the
sphere kind's files: ``en04.json`` (the contract: ``actuation.<study>``, ``oscillation.alpha``
/ ``oscillation.R`` and ``control``; the checks beside them), ``en04.md``, ``en04.png`` (the
powers over the cycle), ``en04_history.csv`` (the actuation histories),
``en04_trajectory.png`` (the still-cavity oscillations), ``en04_convergence.png`` (the
quadrature's convergence, its closed-form check and the load energy against the run's own
bookkeeping), and for the closed loop ``en04_control.png`` (arrival over the controller
grid), ``en04_control_paths.png`` (the fastest closed loop beside the open-loop laws) and
``en04_control_powers.png`` (what the actuators deliver along those runs). Nothing here
recomputes a study.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import (
    finish_figure,
    plt,
    save_figure,
    start_report,
    table,
    write_markdown,
    write_text,
)
from creatio.studies.en04 import oscillation_tolerance

__all__ = ["ACTUATION_KEYS", "CONTROL_CASE_KEYS", "CONTROL_DEMAND_KEYS", "en04_summary",
           "write_report"]

#: The contract keys of ``actuation.<study>`` and the dataset variable each comes from.
ACTUATION_KEYS = (
    ("sigma_kg_m2", "sigma"),
    ("K_m_max_J", "K_m_max"),
    ("K_m_max_closed_form_J", "K_m_max_closed_form"),
    ("P_surface_peak_W", "P_surface_peak"),
    ("W_surface_J", "W_surface"),
    ("P_inertia_peak_W", "P_inertia_peak"),
    ("P_actuator_peak_W", "P_actuator_peak"),
    ("E_actuator_J", "P_actuator_energy"),
    ("stroke_m", "stroke"),
    ("max_W_t_m_s", "max_W_t"),
    ("max_W_tt_m_s2", "max_W_tt"),
    ("bandwidth_hz", "bandwidth"),
    ("bandwidth99_hz", "bandwidth99"),
    ("quadrature_rel_change", "quadrature_rel_change"),
)

#: The checks beside the contract: key and dataset variable.
_CHECK_KEYS = (
    ("K_m_closed_form_rel_error", "K_m_closed_form_rel_error"),
    ("P_inertia_closed_form_rel_error", "P_inertia_closed_form_rel_error"),
    ("K_m_max_time_s", "K_m_max_time"),
    ("W_surface_run_J", "W_surface_run"),
    ("W_surface_fine_J", "W_surface_fine"),
    ("W_surface_run_fine_J", "W_surface_run_fine"),
    ("fine_dt_s", "fine_dt"),
    ("stroke_angular_law_m", "stroke_angular_law"),
    ("max_W_t_closed_form_m_s", "max_W_t_closed_form"),
    ("max_W_t_angular_law_m_s", "max_W_t_angular_law"),
    ("max_W_tt_closed_form_m_s2", "max_W_tt_closed_form"),
    ("max_W_tt_angular_law_m_s2", "max_W_tt_angular_law"),
    ("worst_alpha_deg", "worst_alpha"),
    ("worst_R_m", "worst_R"),
    ("quadrature_n_alpha", "quadrature_n_alpha"),
    ("quadrature_n_R", "quadrature_n_R"),
    ("P_surface_mean_W", "P_surface_mean"),
    ("P_inertia_mean_W", "P_inertia_mean"),
    ("P_gravity_peak_W", "P_gravity_peak"),
    ("P_gravity_mean_W", "P_gravity_mean"),
    ("P_damping_peak_W", "P_damping_peak"),
    ("P_actuator_mean_W", "P_actuator_mean"),
)


def _split(runs: Sequence[xr.Dataset]) -> dict[str, xr.Dataset]:
    return {str(ds.attrs.get("part")): ds for ds in runs}


def _actuation(ds: xr.Dataset) -> tuple[dict, dict, dict]:
    """(contract, damped case, checks) per case of the actuation dataset."""
    contract, damped, checks = {}, {}, {}
    for i, case in enumerate(ds.case.values):
        row = ds.isel(case=i)
        contract[str(case)] = {k: float(row[v]) for k, v in ACTUATION_KEYS}
        damped[str(case)] = {
            "c_d_N_s_m3": float(row["damped_c_d"]),
            "P_damping_peak_W": float(row["P_damping_damped_peak"]),
            "E_damping_J": float(row["P_damping_damped_energy"]),
            "P_actuator_peak_W": float(row["P_actuator_damped_peak"]),
            "E_actuator_J": float(row["P_actuator_damped_energy"]),
        }
        c = {k: float(row[v]) for k, v in _CHECK_KEYS}
        c["W_surface_difference_J"] = c["W_surface_run_J"] - float(row["W_surface"])
        c["W_surface_difference_fine_J"] = c["W_surface_run_fine_J"] - c["W_surface_fine_J"]
        c["quadrature_converged"] = bool(row["quadrature_converged"])
        c["run_status"] = str(row["status"].values)
        checks[str(case)] = c
    return contract, damped, checks


def _oscillation(ds: xr.Dataset) -> tuple[dict, dict]:
    """(contract, checks) per direction: sliding at mu = 0, rolling at the largest mu, both at
    the first amplitude; the zero-amplitude extrapolations and the regularised prediction."""
    contract, checks = {}, {}
    amp = float(np.min(ds.amplitude.values))
    roll_mu = float(np.max(ds.mu.values))
    for direction in ("alpha", "R"):
        def pick(mu: float, d: str = direction) -> int:
            sel = np.flatnonzero((ds.direction.values == d) & (ds.mu.values == mu)
                                 & (ds.amplitude.values == amp))
            return int(sel[0])

        def mode(mu: float, d: str = direction) -> float:
            sel = np.flatnonzero((ds.mode_direction.values == d) & (ds.mode_mu.values == mu))
            return float(ds.omega_zero_amplitude.values[sel[0]])

        s, r = pick(0.0), pick(roll_mu)
        kappa = float(ds.attrs["kappa_alpha" if direction == "alpha" else "kappa_R"])
        slide, slide_cf = float(ds.omega.values[s]), float(ds.attrs[f"slide_{direction}"])
        roll, roll_cf = float(ds.omega.values[r]), float(ds.attrs[f"roll_{direction}"])
        reg = float(ds.omega_regularised.values[r])
        tol = oscillation_tolerance(kappa, amp)
        offset = abs(reg - roll_cf) / roll_cf
        contract[direction] = {
            "slide_rad_s": slide,
            "slide_closed_form_rad_s": slide_cf,
            "roll_rad_s": roll,
            "roll_closed_form_rad_s": roll_cf,
        }
        checks[direction] = {
            "amplitude_m": amp,
            "roll_mu": roll_mu,
            "kappa_1_m": kappa,
            "slide_rel_difference": (slide - slide_cf) / slide_cf,
            "slide_tolerance_rel": tol,
            "roll_rel_difference": (roll - roll_cf) / roll_cf,
            "roll_regularisation_offset_rel": offset,
            "roll_tolerance_rel": tol + offset,
            "within_tolerance": bool(abs(slide - slide_cf) <= tol * slide_cf
                                     and abs(roll - roll_cf) <= (tol + offset) * roll_cf),
            "slide_zero_amplitude_rad_s": mode(0.0),
            "roll_zero_amplitude_rad_s": mode(roll_mu),
            "roll_regularised_rad_s": reg,
            "roll_decay_1_s": float(ds.decay.values[r]),
            "roll_decay_regularised_1_s": float(ds.decay_regularised.values[r]),
            "statuses": sorted({str(v) for v in ds.status.values}),
        }
    return contract, checks


def en04_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-04: ``actuation``, ``oscillation`` and ``control`` (null when
    its dataset is not among those given), each with its checks beside it."""
    runs = [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)
    parts = _split(runs)
    out: dict[str, Any] = {"study": "en04"}
    statuses: list[str] = []
    if "actuation" in parts:
        contract, damped, checks = _actuation(parts["actuation"])
        out["actuation"] = contract
        out["actuation_damped"] = damped
        out["actuation_checks"] = checks
        statuses += [c["run_status"] for c in checks.values()]
    if "oscillation" in parts:
        contract, checks = _oscillation(parts["oscillation"])
        out["oscillation"] = contract
        out["oscillation_checks"] = checks
        statuses += [str(s) for s in parts["oscillation"].status.values]
    out["control"] = None
    if "control" in parts:
        contract, checks = _control(parts["control"])
        out["control"] = contract
        out["control_checks"] = checks
        # a controller that loses the sphere has failed, and says so in its case; the part
        # itself fails only when no case carries it
        statuses.append("ok" if checks["cases_carried"] > 0 else "failed")
    out["status"] = "ok" if all(s == "ok" for s in statuses) else "failed"
    return out


_LABELS = {"en02": "EN-02", "en02r": "EN-02R"}


def _powers(ds: xr.Dataset, path: Path) -> None:
    """The powers over the cycle, one panel per study."""
    n = ds.sizes["case"]
    fig, axes = plt.subplots(n, 1, figsize=(10, 3.4 * n), squeeze=False)
    for i, case in enumerate(ds.case.values):
        ax = axes[i, 0]
        row = ds.isel(case=i)
        t = ds.time.values
        for name, style in (("P_surface", "-"), ("P_inertia", "-"), ("P_gravity", ":"),
                            ("P_actuator", "--")):
            ax.plot(t, 1e3 * row[name].values, style, lw=1.2 if name != "P_actuator" else 1.6,
                    label=name.replace("_", " "))
        ax.axhline(0.0, color="0.7", lw=0.6)
        label = _LABELS.get(str(case), str(case))
        ax.set_title(f"{label}: powers over the cycle (sigma = {float(row['sigma']):g} kg/m^2, "
                     f"c_d = {float(row['c_d']):g}); W_surface = "
                     f"{float(row['W_surface']):.4g} J, E_actuator = "
                     f"{float(row['P_actuator_energy']):.4g} J", fontsize=9)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("power (mW)")
        ax.legend(fontsize=8, ncol=4)
    finish_figure(fig, path)


def _oscillations(ds: xr.Dataset, path: Path) -> None:
    """Each still-cavity run's displacement; beside it, the measured frequencies against the
    closed forms."""
    dirs = ("alpha", "R")
    fig, axes = plt.subplots(len(dirs), 2, figsize=(13, 3.6 * len(dirs)), squeeze=False,
                             gridspec_kw={"width_ratios": [2.2, 1]})
    t = ds.time.values
    for j, d in enumerate(dirs):
        ax = axes[j, 0]
        for i in np.flatnonzero(ds.direction.values == d):
            ax.plot(t, 1e3 * ds.displacement.values[i], lw=0.8,
                    label=f"mu = {float(ds.mu.values[i]):g}, a = "
                          f"{1e3 * float(ds.amplitude.values[i]):g} mm")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("displacement (mm)")
        ax.set_title(f"along {d}: contact displacement from the still cavity's bottom",
                     fontsize=9)
        ax.legend(fontsize=7, ncol=2)
        bx = axes[j, 1]
        sel = np.flatnonzero(ds.direction.values == d)
        rel = (ds.omega.values[sel] - ds.omega_closed_form.values[sel]) \
            / ds.omega_closed_form.values[sel]
        labels = [f"mu {float(ds.mu.values[i]):g}\na {1e3 * float(ds.amplitude.values[i]):g}"
                  for i in sel]
        bx.bar(range(sel.size), rel, color=["tab:blue" if ds.mu.values[i] == 0 else "tab:orange"
                                            for i in sel])
        reg = (ds.omega_regularised.values[sel] - ds.omega_closed_form.values[sel]) \
            / ds.omega_closed_form.values[sel]
        bx.plot(range(sel.size), reg, "k_", ms=18, mew=2, label="regularised prediction")
        bx.axhline(0.0, color="0.5", lw=0.6)
        bx.set_xticks(range(sel.size), labels, fontsize=7)
        bx.set_ylabel("(measured - closed form) / closed form")
        bx.set_title(f"along {d}: slide (mu = 0) and roll", fontsize=9)
        bx.legend(fontsize=7)
    finish_figure(fig, path)


def _convergence(act: xr.Dataset | None, path: Path) -> None:
    """The quadrature's refinement, the closed-form check of K_m, and the load energy
    against the run's own bookkeeping."""
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(15, 4.2))
    if act is not None:
        for i, case in enumerate(act.case.values):
            label = _LABELS.get(str(case), str(case))
            na = act.level_n_alpha.values[i]
            nr = act.level_n_R.values[i]
            ok = na > 0
            for k, name in enumerate(act.integral.values):
                y = act.level_rel_change.values[i, :, k][ok]
                if not np.any(y > 0):  # identically zero (damping at c_d = 0)
                    continue
                x = (na[ok] * nr[ok]).astype(float)
                y = np.where(y > 0, y, np.nan)
                a1.semilogy(x, y, "o-", ms=3, lw=0.8, label=f"{label} {name}")
            t = act.time.values
            K = act.K_m.values[i]
            Kc = act.K_m_closed_form.values[i]
            a2.plot(t, (K - Kc) / np.nanmax(np.abs(Kc)), ".", ms=1, label=label)
            d = act.load_work.values[i] - act.surface_work.values[i]
            a3.plot(t, d, lw=0.8, label=f"{label}, dt = {float(act.dt.values[i]):g} s")
        a1.axhline(float(act.attrs.get("quadrature_rtol", math.nan)), color="k", ls=":",
                   lw=0.8, label="rtol")
    a1.set_xlabel("nodes (n_alpha x n_R)")
    a1.set_ylabel("relative change from the grid before")
    a1.set_title("membrane quadrature: refinement", fontsize=9)
    a1.legend(fontsize=6, ncol=2)
    a2.set_xlabel("t (s)")
    a2.set_ylabel("(K_m quadrature - closed form) / max K_m")
    a2.set_title("K_m: quadrature against the flat-annulus closed form", fontsize=9)
    a2.legend(fontsize=7)
    a3.set_xlabel("t (s)")
    a3.set_ylabel("J")
    a3.set_title("W_surface from (N n + f) . c_t minus the run's surface work", fontsize=9)
    a3.legend(fontsize=7)
    finish_figure(fig, path)


def _csv(act: xr.Dataset, path: Path) -> None:
    """The actuation histories every output interval of the studies (the sphere reports'
    sampling), one column per study and variable (units in the header)."""
    from creatio.reports.common import write_csv

    every = float(act.attrs.get("history_interval", act.attrs["sample_interval"]))
    step = max(1, round(every / float(act.attrs["sample_interval"])))
    act = act.isel(time=slice(None, None, step))
    names = [v for v in act.data_vars if act[v].dims == ("case", "time")]
    header = ["time_s"] + [f"{c}_{v} ({act[v].attrs.get('units', '')})"
                           for c in act.case.values for v in names]
    cols = [act.time.values] + [act[v].values[i] for i in range(act.sizes["case"])
                                for v in names]
    write_csv(path, header, list(zip(*cols, strict=True)))


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en04.json/.md/.png, _history.csv (actuation histories), _trajectory.png (the
    still-cavity oscillations), _convergence.png (quadrature, closed form, load energy)."""
    runs, s, paths = start_report(datasets, outdir, en04_summary)
    parts = _split(runs)
    act = parts.get("actuation")
    osc = parts.get("oscillation")
    if act is not None:
        _powers(act, paths["png"])
        _csv(act, paths["csv"])
    else:
        write_text(paths["csv"], "time_s\n")
    if osc is not None:
        _oscillations(osc, paths["trajectory"])
    _convergence(act, paths["convergence"])
    lines = [f"# {runs[0].attrs.get('title', 'EN-04')}", "", *_answer(s, runs[0]),
             f"config sha256 `{str(runs[0].attrs.get('config_sha256', ''))[:12]}`, creatio "
             f"{runs[0].attrs.get('creatio_version')}, commit "
             f"{str(runs[0].attrs.get('git_commit', ''))[:10]} (docs/model.md s.12, "
             "docs/studies.md).", ""]
    if "actuation" in s:
        cases = list(s["actuation"])
        lines += ["## Actuation demand of the prescribed cycles", "",
                  "Each study's own run (its config under `bases`), its load power "
                  "P_surface = (N n + f) . c_t at the contact point, and a membrane of areal "
                  "density sigma over the reference annulus. Peaks are max |P| over the cycle.",
                  "",
                  *table(["figure", *[_LABELS.get(c, c) for c in cases]],
                         [(k, *[s["actuation"][c][k] for c in cases])
                          for k, _ in ACTUATION_KEYS]),
                  "", "### Damped membrane", "",
                  *table(["figure", *[_LABELS.get(c, c) for c in cases]],
                         [(k, *[s["actuation_damped"][c][k] for c in cases])
                          for k in next(iter(s["actuation_damped"].values()))]),
                  "", "### Checks", "",
                  *table(["check", *[_LABELS.get(c, c) for c in cases]],
                         [(k, *[s["actuation_checks"][c][k] for c in cases])
                          for k in next(iter(s["actuation_checks"].values()))]),
                  "", "K_m_closed_form_rel_error: the quadrature against the flat-annulus "
                  "closed form, max over the sample grid over max K_m. W_surface_difference: "
                  "the run's own surface work minus the time integral of the load power "
                  "from its samples, at dt and at dt / refine (the gap is the scheme's "
                  "truncation: it shrinks about 16x when dt halves).", "",
                  f"![powers]({paths['png'].name})", ""]
    if "oscillation" in s:
        rows = []
        for d, v in s["oscillation"].items():
            c = s["oscillation_checks"][d]
            rows.append((d, "slide (mu = 0)", v["slide_rad_s"], v["slide_closed_form_rad_s"],
                         c["slide_rel_difference"], c["slide_tolerance_rel"],
                         c["slide_zero_amplitude_rad_s"] / v["slide_closed_form_rad_s"] - 1.0))
            rows.append((d, f"roll (mu = {c['roll_mu']:g})", v["roll_rad_s"],
                         v["roll_closed_form_rad_s"], c["roll_rel_difference"],
                         c["roll_tolerance_rel"],
                         c["roll_zero_amplitude_rad_s"] / c["roll_regularised_rad_s"] - 1.0))
        decay = [(d, c["roll_decay_1_s"], c["roll_decay_regularised_1_s"],
                  c["roll_regularisation_offset_rel"])
                 for d, c in s["oscillation_checks"].items()]
        amp = next(iter(s["oscillation_checks"].values()))["amplitude_m"]
        lines += ["## Still-cavity oscillations", "",
                  f"The sphere at rest in the still cavity, its contact displaced by {amp:g} m "
                  "(and twice that) along each principal direction; frequencies from the zero "
                  "crossings of every step (docs/model.md s.12.3).", "",
                  *table(["direction", "motion", "measured (rad/s)", "closed form (rad/s)",
                          "rel. difference", "tolerance", "zero amplitude: rel. difference"],
                         rows),
                  "", "Tolerance 2 (kappa a)^2: the frequency shift is second order in the "
                  "amplitude a; for rolling, plus the regularised friction's own offset from "
                  "rolling without slip (below). The zero-amplitude column extrapolates the "
                  "two amplitudes (shift ~ a^2) and compares with the closed form (sliding) "
                  "or with the regularised-friction prediction (rolling).", "",
                  *table(["direction", "roll decay measured (1/s)",
                          "regularised prediction (1/s)",
                          "regularised roll vs rolling without slip (rel.)"], decay),
                  "", "Is the rolling limit reached? The regularised friction couples the slip "
                  "with rate mu g / eps; its linearised prediction differs from rolling "
                  "without slip by the last column, and the measurement follows the "
                  "prediction, decay included.", "",
                  f"![oscillations]({paths['trajectory'].name})", ""]
    lines += ["## Quadrature and load energy", "",
              f"![convergence]({paths['convergence'].name})", ""]
    ctl = parts.get("control")
    if ctl is not None:
        extra = {"control": paths["md"].with_name("en04_control.png"),
                 "control_paths": paths["md"].with_name("en04_control_paths.png")}
        _arrival_figure(ctl, extra["control"])
        _paths_figure(ctl, extra["control_paths"])
        if "demand_P_actuator" in ctl:
            extra["control_powers"] = paths["md"].with_name("en04_control_powers.png")
            _control_powers_figure(ctl, extra["control_powers"])
        paths = {**paths, **extra}
        lines += _control_lines(s["control"], s["control_checks"], extra)
    write_markdown(paths["md"], "\n".join(lines))
    return paths


def _answer(s: dict, ds: xr.Dataset) -> list[str]:
    """EN-04's plain-word answer, from its summary: what each part computed and found."""
    what, answers, basis = [], [], []
    if "actuation" in s:
        what.append("the power and energy the actuators must deliver to drive the membrane "
                    "through " + " and ".join(_LABELS.get(c, c) for c in s["actuation"])
                    + "'s prescribed cycles")
        parts = []
        for case, a in s["actuation"].items():
            d = s["actuation_damped"][case]
            parts.append(f"{_LABELS.get(case, case)} peaks at {num(a['P_actuator_peak_W'], 'W')}"
                         f" and takes {num(a['E_actuator_J'], 'J')} over the cycle "
                         f"({num(d['P_actuator_peak_W'], 'W')} and {num(d['E_actuator_J'], 'J')}"
                         f" with damping c_d = {num(d['c_d_N_s_m3'], 'N s/m^3')}), stroke "
                         f"{num(a['stroke_m'], 'm')}, bandwidth {num(a['bandwidth_hz'], 'Hz')}")
        answers.append("; ".join(parts) + ".")
        first = next(iter(s["actuation"].values()))
        change = max(a["quadrature_rel_change"] for a in s["actuation"].values())
        basis.append(f"a membrane of {num(first['sigma_kg_m2'], 'kg/m^2')} by a quadrature "
                     f"converged to {num(change, digits=2)} relative")
    if "oscillation" in s:
        what.append("the sphere's oscillation frequencies in the still cavity")
        worst = max(abs(c[f"{m}_rel_difference"]) for c in s["oscillation_checks"].values()
                    for m in ("slide", "roll"))
        ok = all(c["within_tolerance"] for c in s["oscillation_checks"].values())
        answers.append(f"the still-cavity frequencies match their closed forms to "
                       f"{num(worst, digits=2)} relative ("
                       + ("within" if ok else "NOT within") + " the second-order tolerance).")
    c = s.get("control")
    if c:
        k = s["control_checks"]
        trap = c["trapezoid_best"]
        answers.append(f"{k['cases_carried']} of {k['cases']} closed-loop controllers carry the "
                       "sphere through -360 deg; the fastest arrives in "
                       f"{num(c['fastest_arrival_s'], 's')}, against "
                       f"{num(k['quintic_boundary_arrival_s'], 's')} for the fastest open-loop "
                       "quintic cycle that still carries it"
                       + ("" if trap is None else
                          f" and {num(trap['arrival_s'], 's')} for the best trapezoid") + ".")
        what.append(f"{k['cases']} closed-loop controllers")
        basis.append(f"RK4 at dt = {num(k['dt_s'], 's')} checked at {num(k['fine_dt_s'], 's')} "
                     f"(carried runs differ by at most "
                     f"{num(k['max_timestep_difference_carried_m'], 'm', 3)})"
                     + "".join(f"; {name}: {acc['line']}" for name, acc in (
                         ("arrivals", k.get("arrival_accuracy")),
                         ("quintic boundary", k.get("quintic_boundary_accuracy"))) if acc))
    if not answers:
        return []
    basis.append(f"config sha256 `{str(ds.attrs.get('config_sha256', ''))[:12]}`")
    return answer_lines("; ".join(what) + ".", answers, "; ".join(basis) + ".")


def _mass_law(rows: Sequence[dict], keys: Sequence[str]) -> str | None:
    """Whether the robustness rows that differ only by the sphere's mass agree on `keys`:
    the sentence saying so and why (None when the rows do not vary m)."""
    by_mu: dict[float, list[dict]] = {}
    for r in rows:
        by_mu.setdefault(r["mu"], []).append(r)
    groups = [g for g in by_mu.values() if len({r["mass_factor"] for r in g}) > 1]
    if not groups:
        return None
    same = all(all(r[key] == g[0][key] for r in g for key in keys) for g in groups)
    factors = ", ".join(f"{f:g}" for f in sorted({r["mass_factor"] for g in groups for r in g}))
    if same:
        return (f"The rows for m factors {factors} at one mu are equal by a law of the model, "
                "not by chance: every force on the sphere (gravity, the normal reaction, "
                "friction mu N, its inertia) scales with m, so its motion, and whether and "
                "when it arrives, do not depend on m.")
    return (f"The rows for m factors {factors} at one mu differ, though every force on the "
            "sphere scales with m: the runs are not mass-invariant, which the model says they "
            "should be.")


#: The times of a controlled case a lost sphere does not have (shown as "lost").
_ARRIVAL_KEYS = ("arrival_s", "settling_s")


def _control_lines(c: dict, k: dict, figures: dict[str, Path]) -> list[str]:
    """The closed-loop section of the markdown report."""
    def f(v: Any, fmt: str = ".3f") -> str:
        return "-" if v is None else format(v, fmt)

    fast = c["fastest_case"]
    trap = c["trapezoid_best"]
    ex = k["fastest_case_extra"] or {}
    default = ", ".join(f"{a} {b:g}" for a, b in k["robustness_controller"].items())
    lines = ["## Closed loop (docs/model.md s.12.2)", "",
             f"EN-02's sphere commanded through -360 deg by the cascade: gains from "
             f"k_alpha = {k['k_alpha_rad2_s2']:.4g} rad^2/s^2 (the rolling sphere's still-cavity "
             f"frequency squared), zeta_c = zeta = 1; RK4 at {k['dt_s']:g} s and "
             f"{k['fine_dt_s']:g} s; {k['cases_carried']} of {k['cases']} controllers carry "
             "the sphere.", "",
             *table(["", "arrival (s)", "how"], [
                 ("closed loop, fastest", f(c["fastest_arrival_s"]),
                  "-" if fast is None else
                  f"Omega_max {fast['Omega_max_rad_s']:g} rad/s, delta_max "
                  f"{fast['delta_max_deg']:g} deg, omega_c {fast['omega_c_rad_s']:g}, "
                  f"omega_n {fast['omega_n_rad_s']:g} rad/s"),
                 ("open loop, quintic at its boundary", f(k["quintic_boundary_arrival_s"]),
                  f"shortest carried cycle T = {f(c['open_loop_boundary_T_s'])} s (bisection)"),
                 ("open loop, best trapezoid", "-" if trap is None else f(trap["arrival_s"]),
                  "-" if trap is None else
                  f"Omega_max {trap['Omega_max_rad_s']:.4g} rad/s, a_max "
                  f"{trap['a_max_rad_s2']:.4g} rad/s^2 (asked {trap['Omega_max_asked_rad_s']:g}"
                  f", {trap['a_max_asked_rad_s2']:g}: switch times on the step grid)"),
             ]), "",
             *([f"The boundary's bisection (to {acc['resolution_s']:g} s): {acc['line']}, "
                f"its final bracket rerun at dt = {acc['reference_dt_s']:g} s"
                + ("." if acc["ok"] else ": BUDGET BROKEN."), ""]
               if (acc := k.get("quintic_boundary_accuracy")) else []),
             *([f"The arrivals (on the {acc['resolution_s']:g}-s steps): {acc['line']}, "
                f"a seeded subsample of the controllers rerun at dt = "
                f"{acc['reference_dt_s']:g} s" + ("." if acc["ok"] else ": BUDGET BROKEN."), ""]
               if (acc := k.get("arrival_accuracy")) else []),
             "The first arrival can come with an overshoot; the case that settles first "
             "(stays within the band to the end of the run) settles at "
             f"{f(k['fastest_settling_s'])} s"
             + ("" if k["fastest_settling_case"] is None else
                " (" + ", ".join(f"{key} {f(v, '.4g') if isinstance(v, float) else v}"
                                 for key, v in k["fastest_settling_case"].items()) + ")")
             + ".", "",
             "Fastest case, beside the contract: " + ", ".join(
                 f"{key} {f(v, '.4g')}" for key, v in ex.items()) + ".", "",
             f"![arrival over the grid]({figures['control'].name})", "",
             f"![closed loop beside open loop]({figures['control_paths'].name})", "",
             "### Robustness", "",
             f"The default controller ({default}; "
             f"gains of the nominal sphere) and the quintic law at T = "
             f"{k['robustness_quintic_T_s']:g} s:", "",
             *table(["mu", "m factor", "closed loop carried", "arrival (s)",
                     "open loop carried", "arrival (s)"],
                    [(r["mu"], r["mass_factor"], r["closed_loop_carried"],
                      f(r["closed_loop_arrival_s"]) if r["closed_loop_carried"] else "lost",
                      r["open_loop_carried"],
                      f(r["open_loop_arrival_s"]) if r["open_loop_carried"] else "lost")
                     for r in c["robustness"]]), "",
             *([law, ""] if (law := _mass_law(c["robustness"], [
                 "closed_loop_carried", "closed_loop_arrival_s", "open_loop_carried",
                 "open_loop_arrival_s"])) else []),
             "An arrival time is shown only for a sphere that was carried: a lost one has "
             "none.", "",
             "### Every controller", "",
             f"Energy residual of the carried cases at most "
             f"{f(k['max_energy_residual_carried_J'], '.3g')} J, dt - dt/2 centre difference "
             f"at most {f(k['max_timestep_difference_carried_m'], '.3g')} m.", "",
             *table([key for key, _ in CONTROL_CASE_KEYS],
                    [tuple("lost" if key in _ARRIVAL_KEYS and not case["carried"]
                           else "-" if case[key] is None else f(case[key], ".4g")
                           if isinstance(case[key], float) or case[key] is None else case[key]
                           for key, _ in CONTROL_CASE_KEYS) for case in c["cases"]]), "",
             "`-`: the run has no such time (it never arrived, or did not stay within the band "
             "to its end); `lost`: the sphere left its cavity (not carried), so it has no "
             "arrival; a run that ends `contact_lost` or `edge_crossed` stopped there."]
    if "demand" in k:
        lines += _demand_lines(c, k["demand"], figures)
    return lines


def _demand_lines(c: dict, d: dict, figures: dict[str, Path]) -> list[str]:
    """What the actuators delivered along each controlled run (the markdown section)."""
    def f(v: Any) -> str:
        return "-" if v is None else format(v, ".4g")

    keys = [key for key, _ in CONTROL_DEMAND_KEYS]
    head = [key for key, _ in CONTROL_CASE_KEYS[:4]] + ["carried", *keys]
    rows = [tuple(f(case[key]) if key != "carried" else case[key] for key in head)
            for case in c["cases"]]
    robust = [(r["mu"], r["mass_factor"], *[f(r[f"closed_loop_{key}"]) for key in keys])
              for r in c["robustness"]]
    sampling = ", ".join(f"{key} {f(v)}" for key, v in d["sampling_rel_change"].items())
    lines = ["### What the actuators delivered along the closed loop", "",
             f"docs/model.md s.12.1 along each controlled run: sigma = {d['sigma_kg_m2']:g} "
             f"kg/m^2, c_d = {d['c_d_N_s_m3']:g} N s/m^3; the membrane integrals by a "
             f"{d['quadrature_n_alpha']} x {d['quadrature_n_R']} quadrature (converged once, "
             f"on case {d['reference_case']}: last change {f(d['quadrature_rel_change'])}), "
             f"at the rows every {d['sample_interval_s']:g} s and at every recorded step "
             "around the peaks; E_actuator takes int P_inertia dt as K_m(end) - K_m(0). "
             f"Against every recorded step on case {d['reference_case']} (relative): "
             f"{sampling}. K_m against its flat-annulus closed form: at most "
             f"{f(d['max_K_m_closed_form_rel_error'])} relative.", ""]
    if "control_powers" in figures:
        lines += [f"![powers along the closed loop]({figures['control_powers'].name})", ""]
    lines += [*table(head, rows), "", "Robustness runs (the default controller):", "",
              *table(["mu", "m factor", *keys], robust), ""]
    return lines


# ------------------------------------------------------------------------- closed loop
def _num(x: Any) -> float | None:
    """A finite float, or None (JSON null) for NaN."""
    v = float(x)
    return v if math.isfinite(v) else None


#: The contract keys of each ``control.cases`` entry and the dataset variable of each.
CONTROL_CASE_KEYS = (
    ("Omega_max_rad_s", "omega_max"),
    ("delta_max_deg", "delta_max_deg"),
    ("omega_c_rad_s", "omega_c"),
    ("omega_n_rad_s", "omega_n"),
    ("status", "status"),
    ("carried", "carried"),
    ("arrival_s", "arrival"),
    ("settling_s", "settling"),
    ("final_error_deg", "final_error"),
    ("overshoot_deg", "overshoot"),
    ("max_phidot_a_rad_s", "max_phidot_a"),
    ("max_u_rad_s2", "max_u"),
    ("min_normal_reaction_N", "min_normal_reaction"),
    ("energy_residual_J", "energy_residual"),
    ("timestep_difference_m", "timestep_difference"),
)

#: What the actuators delivered along each controlled run (docs/model.md s.12.1 along the
#: closed loop): keys added to each ``control.cases`` entry, to ``control.fastest_case`` and
#: (as ``closed_loop_<key>``) to each robustness entry, and the dataset variable of each.
CONTROL_DEMAND_KEYS = (
    ("P_actuator_peak_W", "P_actuator_peak"),
    ("E_actuator_J", "E_actuator"),
    ("P_inertia_peak_W", "P_inertia_peak"),
    ("K_m_max_J", "K_m_max"),
    ("stroke_m", "stroke"),
    ("max_W_t_m_s", "max_W_t"),
    ("max_W_tt_m_s2", "max_W_tt"),
    ("bandwidth_hz", "bandwidth"),
    ("bandwidth99_hz", "bandwidth99"),
)

#: Further figures of each case, beside the contract (``control_checks``).
_CONTROL_EXTRA = (
    ("max_delta_deg", "max_delta"),
    ("max_cavity_tracking_m", "max_cavity_tracking"),
    ("max_slip_m_s", "max_slip"),
    ("P_surface_peak_W", "P_surface_peak"),
    ("P_surface_mean_W", "P_surface_mean"),
)


def _case(ds: xr.Dataset, i: int, keys: Sequence[tuple[str, str]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, var in keys:
        v = ds[var].values[i]
        if var == "status":
            out[key] = str(v)
        elif var == "carried":
            out[key] = bool(v)
        else:
            out[key] = _num(v)
    return out


def _control(ds: xr.Dataset) -> tuple[dict, dict]:
    """(contract, checks) of the closed-loop dataset."""
    demand = tuple(k for k in CONTROL_DEMAND_KEYS if k[1] in ds)
    cases = [_case(ds, i, CONTROL_CASE_KEYS + demand) for i in range(ds.sizes["case"])]
    fastest = int(ds.attrs["fastest_case"])
    best = int(ds.attrs["trapezoid_best"])
    trap = None
    if best >= 0:
        trap = {"Omega_max_rad_s": _num(ds.trap_omega_max.values[best]),
                "a_max_rad_s2": _num(ds.trap_a_max.values[best]),
                "arrival_s": _num(ds.trap_arrival.values[best]),
                "Omega_max_asked_rad_s": _num(ds.trap_omega_max_asked.values[best]),
                "a_max_asked_rad_s2": _num(ds.trap_a_max_asked.values[best]),
                "T_s": _num(ds.trap_T.values[best])}
    robustness = [
        {"mu": float(mu), "mass_factor": float(f),
         "closed_loop_carried": bool(ds.robust_closed_carried.values[i, j]),
         "open_loop_carried": bool(ds.robust_open_carried.values[i, j]),
         "closed_loop_arrival_s": _num(ds.robust_closed_arrival.values[i, j]),
         "open_loop_arrival_s": _num(ds.robust_open_arrival.values[i, j]),
         **{f"closed_loop_{key}": _num(ds[f"robust_closed_{var}"].values[i, j])
            for key, var in demand}}
        for i, mu in enumerate(ds.mu.values) for j, f in enumerate(ds.mass_factor.values)]
    contract = {
        "cases": cases,
        "fastest_arrival_s": _num(ds.attrs["fastest_arrival"]),
        "fastest_case": ({**_case(ds, fastest, CONTROL_CASE_KEYS[:4]), "index": fastest,
                          **_case(ds, fastest, demand)} if fastest >= 0 else None),
        "open_loop_boundary_T_s": _num(ds.attrs["open_loop_boundary_T"]),
        "trapezoid_best": trap,
        "robustness": robustness,
    }
    carried = ds.carried.values.astype(bool)
    res = ds.energy_residual.values[carried]
    settling = np.where(carried, ds.settling.values, np.nan)
    settled = int(np.nanargmin(settling)) if np.isfinite(settling).any() else -1
    checks = {
        "k_alpha_rad2_s2": float(ds.attrs["k_alpha"]),
        "dt_s": float(ds.attrs["dt"]), "fine_dt_s": float(ds.attrs["fine_dt"]),
        "cases_carried": int(carried.sum()), "cases": int(carried.size),
        "max_energy_residual_carried_J": _num(np.max(res)) if res.size else None,
        "max_timestep_difference_carried_m": (
            _num(np.max(ds.timestep_difference.values[carried])) if res.size else None),
        "quintic_boundary_arrival_s": _num(ds.attrs["quintic_boundary_arrival"]),
        "quintic_bisection": [{"T_s": float(T), "carried": bool(c)} for T, c in
                              zip(ds.quintic_T.values, ds.quintic_carried.values, strict=True)],
        "quintic_boundary_accuracy": _accuracy(ds.attrs, "quintic_accuracy_"),
        "arrival_accuracy": _accuracy(ds.attrs, "arrival_accuracy_"),
        "robustness_quintic_T_s": float(ds.attrs["robust_quintic_T"]),
        "robustness_controller": {k: float(ds.attrs[f"default_{k}"]) for k in
                                  ("omega_max", "delta_max_deg", "omega_c", "omega_n")},
        "fastest_case_extra": (_case(ds, fastest, _CONTROL_EXTRA) if fastest >= 0 else None),
        "fastest_settling_s": _num(settling[settled]) if settled >= 0 else None,
        "fastest_settling_case": (_case(ds, settled, CONTROL_CASE_KEYS) if settled >= 0
                                  else None),
    }
    if demand:
        checks["demand"] = _demand_checks(ds)
    return contract, checks


def _accuracy(a: Any, prefix: str) -> dict[str, Any] | None:
    """An accuracy budget as the dataset recorded it under prefix (None in a dataset written
    before it was): resolution, budget and observed error (s), points, steps, the line."""
    if f"{prefix}line" not in a:
        return None
    return {"resolution_s": float(a[f"{prefix}resolution"]),
            "budget_s": _num(a[f"{prefix}budget"]),
            "observed_s": _num(a[f"{prefix}observed"]), "points": int(a[f"{prefix}points"]),
            "dt_s": float(a[f"{prefix}dt"]), "reference_dt_s": float(a[f"{prefix}reference_dt"]),
            "ok": bool(a[f"{prefix}ok"]), "tightened": int(a[f"{prefix}tightened"]),
            "line": str(a[f"{prefix}line"])}


def _demand_checks(ds: xr.Dataset) -> dict[str, Any]:
    """How the actuation figures along the runs were computed, and their own checks: the
    quadrature converged once, the time sampling against every step on the same case, the
    closed form of K_m over every case."""
    a = ds.attrs
    K_rel = ds.K_m_closed_form_rel_error.values
    return {
        "sigma_kg_m2": float(a["demand_sigma"]), "c_d_N_s_m3": float(a["demand_c_d"]),
        "sample_interval_s": float(a["demand_sample_interval"]),
        "quadrature_n_alpha": int(a["demand_quadrature_n_alpha"]),
        "quadrature_n_R": int(a["demand_quadrature_n_R"]),
        "quadrature_rel_change": _num(a["demand_quadrature_rel_change"]),
        "quadrature_converged": bool(a["demand_quadrature_converged"]),
        "reference_case": int(a["demand_reference_case"]),
        "sampling_rel_change": {k[len("demand_sampling_rel_change_"):]: _num(v)
                                for k, v in a.items()
                                if k.startswith("demand_sampling_rel_change_")},
        "max_K_m_closed_form_rel_error": (_num(np.nanmax(K_rel)) if np.isfinite(K_rel).any()
                                          else None),
    }


def _arrival_figure(ds: xr.Dataset, path: Path) -> None:
    """Arrival time over the grid: one panel per (omega_c, omega_n), Omega_max across and
    delta_max up; cases that lost the sphere crossed, the open-loop figures in the title."""
    wcs = np.unique(ds.omega_c.values)
    wns = np.unique(ds.omega_n.values)
    oms = np.unique(ds.omega_max.values)
    dms = np.unique(ds.delta_max_deg.values)
    arrival = np.where(ds.carried.values.astype(bool), ds.arrival.values, np.nan)
    finite = arrival[np.isfinite(arrival)]
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    fig, axes = plt.subplots(len(wns), len(wcs), figsize=(3.6 * len(wcs) + 1.2,
                                                         2.7 * len(wns) + 0.8), squeeze=False)
    image = None
    for r, wn in enumerate(wns):
        for c, wc in enumerate(wcs):
            ax = axes[r, c]
            grid = np.full((dms.size, oms.size), np.nan)
            lost = np.zeros_like(grid, dtype=bool)
            for i in range(ds.sizes["case"]):
                if ds.omega_c.values[i] != wc or ds.omega_n.values[i] != wn:
                    continue
                a = int(np.searchsorted(dms, ds.delta_max_deg.values[i]))
                b = int(np.searchsorted(oms, ds.omega_max.values[i]))
                grid[a, b] = arrival[i]
                lost[a, b] = not bool(ds.carried.values[i])
            image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis_r", vmin=vmin,
                              vmax=vmax)
            for a in range(dms.size):
                for b in range(oms.size):
                    text = "lost" if lost[a, b] else (
                        "-" if math.isnan(grid[a, b]) else f"{grid[a, b]:.2f}")
                    ax.text(b, a, text, ha="center", va="center", fontsize=7,
                            color="red" if lost[a, b] else "white")
            ax.set_xticks(range(oms.size), [f"{v:g}" for v in oms], fontsize=7)
            ax.set_yticks(range(dms.size), [f"{v:g}" for v in dms], fontsize=7)
            ax.set_title(f"omega_c = {wc:g}, omega_n = {wn:g} rad/s", fontsize=8)
            if r == len(wns) - 1:
                ax.set_xlabel("Omega_max (rad/s)", fontsize=8)
            if c == 0:
                ax.set_ylabel("delta_max (deg)", fontsize=8)
    if image is not None:
        fig.colorbar(image, ax=axes, shrink=0.8, label="arrival (s)")
    T = float(ds.attrs["open_loop_boundary_T"])
    best = int(ds.attrs["trapezoid_best"])
    trap = float(ds.trap_arrival.values[best]) if best >= 0 else math.nan
    fig.suptitle(f"Closed loop: arrival within {float(ds.attrs['arrival_tol_deg']):g} deg of "
                 f"{float(ds.attrs['theta_goal_deg']):g} deg (s); fastest "
                 f"{float(ds.attrs['fastest_arrival']):.3f} s. Open loop: quintic boundary "
                 f"T = {T:.3f} s (arrival {float(ds.attrs['quintic_boundary_arrival']):.3f} s), "
                 f"best trapezoid arrival {trap:.3f} s", fontsize=9)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _paths_figure(ds: xr.Dataset, path: Path) -> None:
    """The fastest closed loop beside the open-loop quintic boundary case and the best
    trapezoid: travel, pattern speed, lead and load power over the run."""
    t = ds.time.values
    fig, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
    rows = (("path_theta", "travel theta (deg)"), ("path_pattern_speed",
                                                    "pattern speed -phidot_a / Ka (rad/s)"),
            ("path_lead", "lead delta (deg)"), ("path_power", "load power P_surface (W)"))
    for k, label in enumerate(ds.path_label.values):
        for ax, (var, _) in zip(axes, rows, strict=True):
            ax.plot(t, ds[var].values[k], lw=1.1, label=str(label))
    goal = float(ds.attrs["theta_goal_deg"])
    tol = float(ds.attrs["arrival_tol_deg"])
    axes[0].axhspan(goal - tol, goal + tol, color="0.85", label="arrival band")
    for ax, (_, label) in zip(axes, rows, strict=True):
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.5)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle("Closed loop (fastest carried case) beside the open-loop laws", fontsize=10)
    finish_figure(fig, path)


def _control_powers_figure(ds: xr.Dataset, path: Path) -> None:
    """What the actuators deliver along the fastest closed loop, the quintic at its boundary
    and the best trapezoid: load, membrane inertia and actuator powers and K_m over the run
    (every sample of the actuation figures)."""
    t = ds.demand_time.values
    rows = (("demand_P_surface", "load power P_surface (W)"),
            ("demand_P_inertia", "membrane inertia power dK_m/dt (W)"),
            ("demand_P_actuator", "actuator power P_actuator (W)"),
            ("demand_K_m", "membrane kinetic energy K_m (J)"))
    fig, axes = plt.subplots(len(rows), 1, figsize=(10, 10), sharex=True)
    for k, label in enumerate(ds.path_label.values):
        for ax, (var, _) in zip(axes, rows, strict=True):
            ax.plot(t, ds[var].values[k], lw=1.0, label=str(label))
    for ax, (_, label) in zip(axes, rows, strict=True):
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="0.6", lw=0.5)
    # the runs' tails are still: show up to where the last actuator power falls below 1 % of
    # its peak (and a margin), not the whole 15 s
    P = np.abs(ds.demand_P_actuator.values)
    active = np.nan_to_num(P) > 0.01 * np.nanmax(P) if np.isfinite(P).any() else P > 0
    if active.any():
        last = float(t[np.flatnonzero(active.any(axis=0))[-1]])
        axes[-1].set_xlim(t[0], min(float(t[-1]), 1.15 * last + 0.5))
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t (s)")
    fig.suptitle(f"Actuation along the fastest closed loop and the open-loop laws (sigma = "
                 f"{float(ds.attrs['demand_sigma']):g} kg/m^2, c_d = "
                 f"{float(ds.attrs['demand_c_d']):g} N s/m^3; P_gravity = 0 on the flat "
                 "annulus)", fontsize=9)
    finish_figure(fig, path)
