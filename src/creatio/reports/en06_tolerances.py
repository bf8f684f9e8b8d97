"""EN-06's tolerance and tilt sections (docs/materials.md s.8): from the datasets of the parts
``tilt``, ``sobol``, ``allocation`` and ``joint`` the JSON keys ``tilt_check`` and
``tolerances`` (the report contract), the markdown sections, and ``en06_tolerances.png``
(the Sobol' bars with their intervals, and the allocation against the declared tolerances).
Nothing here recomputes the study."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import num
from creatio.reports.common import fixed_layout, fmt, plt, save_figure, table
from creatio.studies.budget import Verification

__all__ = ["SUMMARIES", "answer", "figure", "section"]

#: Units of each output, for the tables (the datasets carry them too).
_UNITS = {"final_angle_error": "deg", "final_radius_error": "m", "carried": "1",
          "surface_work": "J"}


def _f(x: Any) -> float:
    return float(np.asarray(x))


def _tilt_summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """tilt_check: the largest energy residual at dt, dt / 2, dt / 4 and the finest pair's
    observed order (every pair's under ``orders``)."""
    orders = [float(v) for v in ds.observed_order.values]
    out["tilt_check"] = {
        "energy_residual_J": [float(v) for v in ds.energy_residual.values],
        "order": orders[-1],
        "orders": orders,
        "dt_s": [float(v) for v in ds.dt.values],
        "scheme_order": int(ds.attrs["scheme_order"]),
        "method": str(ds.attrs["method"]),
        "beta_deg": float(ds.attrs["beta_deg"]), "psi_deg": float(ds.attrs["psi_deg"]),
        "cycle_s": float(ds.attrs["cycle_s"]),
        "status": [str(s) for s in ds.status.values],
    }


def _tolerances(ds: xr.Dataset, out: dict[str, Any]) -> dict[str, Any]:
    """The ``tolerances`` entry, with what every tolerance part shares (spec, nominal,
    declared inputs) filled from the first one read."""
    tol = out.setdefault("tolerances", {})
    if "spec" not in tol:
        tol["spec"] = {"angle_deg": float(ds.attrs["spec_angle_deg"]),
                       "radius_m": float(ds.attrs["spec_radius_m"]), "carried": True}
        tol["nominal"] = {"final_angle_deg": _f(ds.nominal_final_angle),
                          "final_radius_m": _f(ds.nominal_final_radius),
                          "surface_work_J": _f(ds.nominal_surface_work),
                          "status": str(ds.attrs["nominal_status"]),
                          "method": str(ds.attrs["method"]), "dt_s": float(ds.attrs["dt"]),
                          "budgeted": "accuracy_method" in ds.attrs}
        tol["assumption"] = str(ds.attrs["assumptions"])
        tol["inputs"] = {str(n): {"key": str(k), "units": str(u), "nominal": float(x0),
                                  "low": float(lo), "high": float(hi)}
                         for n, k, u, x0, lo, hi in zip(
                             ds.input.values, ds.input_key.values, ds.input_units.values,
                             ds.input_nominal.values, ds.input_low.values, ds.input_high.values,
                             strict=True)}
    return tol


def _accuracy(ds: xr.Dataset, tol: dict[str, Any], part: str) -> None:
    """tolerances.accuracy.<part>: the accuracy budget's check recorded in the dataset
    (creatio.studies.budget): the line, the method and tolerances it chose, per output the
    budget and the largest error observed, the points checked and the tightenings; or why
    there is none."""
    acc = tol.setdefault("accuracy", {})
    if "accuracy_method" not in ds.attrs:
        acc[part] = {"note": str(ds.attrs.get("accuracy_budget",
                                              "none (bases.en02's own solver)"))}
        return
    v = Verification.from_attrs(ds.attrs)
    acc[part] = {"line": v.line(), "describe": v.describe(), "worst": v.worst(),
                 "method": v.rung.method,
                 "rtol": v.rung.rtol, "atol": v.rung.atol, "budget": v.budget,
                 "observed": v.observed, "points": v.points, "seed": v.seed,
                 "tightened": v.tightened, "ok": v.ok,
                 "units": str(ds.attrs.get("accuracy_units", "the output's"))}


def _sobol_summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """tolerances.sobol.<output>: {S1, S1_conf, ST, ST_conf}, each input -> value, at the
    largest base size; every size's under sobol_by_base_size; the runs."""
    tol = _tolerances(ds, out)
    inputs = [str(n) for n in ds.input.values]

    def at(i: int) -> dict[str, Any]:
        return {str(o): {k: {n: float(ds[k].values[i, j, m]) for m, n in enumerate(inputs)}
                         for k in ("S1", "S1_conf", "ST", "ST_conf")}
                for j, o in enumerate(ds.output.values)}

    sizes = [int(n) for n in ds.base_size.values]
    tol["sobol"] = at(len(sizes) - 1)
    tol["sobol_by_base_size"] = {str(n): at(i) for i, n in enumerate(sizes)}
    tol["sobol_runs"] = {
        "base_sizes": sizes, "runs": [int(v) for v in ds.runs.values],
        "runs_not_ok": [int(v) for v in ds.runs_not_ok.values],
        "runs_missing": {str(o): [int(v) for v in ds.runs_missing.values[:, j]]
                         for j, o in enumerate(ds.output.values)},
        "carried_fraction": float(np.mean(ds.carried.values)),
        "seed": int(ds.attrs["seed"]), "resamples": int(ds.attrs["resamples"]),
        "confidence": float(ds.attrs["confidence"])}
    _accuracy(ds, tol, "sobol")


def _allocation_summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """tolerances.allocation.<input>: {minus, plus, cap} (null: the side is not allocated),
    with the first deviation found out of spec, whether the cap itself was within spec,
    the declared tolerance and the runs; only inputs with an allocated side."""
    tol = _tolerances(ds, out)
    alloc = {}
    for i, name in enumerate(str(n) for n in ds.input.values):
        if not ds.allocated.values[i].any():
            continue
        side = {}
        for j, s in enumerate(("minus", "plus")):
            on = bool(ds.allocated.values[i, j])
            side[s] = float(ds.allocation.values[i, j]) if on else None
            side[f"{s}_first_outside"] = float(ds.first_outside.values[i, j]) if on else None
            side[f"{s}_capped"] = bool(ds.capped.values[i, j]) if on else None
        alloc[name] = {**{k: side[k] for k in ("minus", "plus")},
                       "cap": [float(c) for c in ds.cap.values[i]],
                       "relative": bool(ds.relative.values[i]),
                       "declared": [float(c) for c in ds.declared.values[i]],
                       "first_outside": [side["minus_first_outside"],
                                         side["plus_first_outside"]],
                       "capped": [side["minus_capped"], side["plus_capped"]],
                       "runs": int(ds.runs.values[i].sum())}
    tol["allocation"] = alloc
    tol["allocation_search"] = {k: int(ds.attrs[k]) for k in ("scan", "iterations",
                                                               "azimuths")}
    _accuracy(ds, tol, "allocation")


def _joint_summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """tolerances.joint: {n, fraction_within_spec, interval_95} (interval_95 when the
    confidence is 0.95; ``interval`` and ``confidence`` always), the method and seed."""
    tol = _tolerances(ds, out)
    conf = float(ds.attrs["confidence"])
    ival = [_f(ds.interval_low), _f(ds.interval_high)]
    joint: dict[str, Any] = {"n": int(ds.attrs["n"]),
                             "fraction_within_spec": _f(ds.fraction_within_spec)}
    if conf == 0.95:
        joint["interval_95"] = ival
    joint.update({"interval": ival, "confidence": conf, "within": int(ds.within_count),
                  "carried": int(np.sum(ds.carried.values == 1.0)),
                  "interval_method": str(ds.attrs["interval_method"]),
                  "seed": int(ds.attrs["seed"])})
    tol["joint"] = joint
    _accuracy(ds, tol, "joint")


#: Each part's summary (creatio.reports.en06 reads them with its own).
SUMMARIES = {"tilt": _tilt_summary, "sobol": _sobol_summary,
             "allocation": _allocation_summary, "joint": _joint_summary}


# ---------------------------------------------------------------------------- the answer
def _dev(v: float | None, relative: bool, units: str = "") -> str:
    """A deviation as the tables print it: a relative one in %, else with its units."""
    if v is None or not math.isfinite(v):
        return "-"
    if relative:
        return f"{fmt(100.0 * v)} %"
    return f"{fmt(v)} {_SHORT.get(units, units)}".rstrip()


_SHORT = {"degree": "deg", "1": ""}


def answer(s: dict[str, Any]) -> str:
    """One answer fragment (empty without tolerances): the joint fraction within spec and
    its interval, and the tightest allocation against its declared tolerance."""
    tol = s.get("tolerances", {})
    parts = []
    if "joint" in tol:
        j = tol["joint"]
        lo, hi = j["interval"]
        parts.append(f"at the declared tolerances {num(100.0 * j['fraction_within_spec'], '%')}"
                     f" of {j['n']} transports stay within spec ({num(100.0 * j['confidence'])}"
                     f" % interval {num(100.0 * lo, digits=3)}-{num(100.0 * hi, '%', 3)})")
    ratios = []
    for name, a in tol.get("allocation", {}).items():
        for i, side in enumerate(("minus", "plus")):
            declared = a["declared"][i]
            if a[side] is not None and declared > 0.0:
                ratios.append((a[side] / declared, name, side, a[side], a["relative"]))
    if ratios:
        r, name, side, v, rel = min(ratios)
        sign = "-" if side == "minus" else "+"
        key, units = tol["inputs"][name]["key"], tol["inputs"][name]["units"]
        parts.append(f"the tightest allocation is {name} ({key}) {sign}{_dev(v, rel, units)}, "
                     f"{num(r, digits=3)} x its declared tolerance")
    return "; ".join(parts)


# ---------------------------------------------------------------------------- the figure
def figure(parts: dict[str, xr.Dataset], path: Path) -> bool:
    """The Sobol' bars (S1 and ST with their bootstrap half-widths, largest base size) of
    each output with indices, and the allocation over the declared tolerance per input and
    side (hatched: the cap itself is within spec); False when neither part is there."""
    sob, al = parts.get("sobol"), parts.get("allocation")
    panels = []
    if sob is not None:
        panels += [j for j in range(sob.sizes["output"])
                   if np.isfinite(sob.ST.values[-1, j]).any()]
    n = len(panels) + int(al is not None)
    if n == 0:
        return False
    fig, axes = plt.subplots(1, n, figsize=(4.4 * n, 4.2), squeeze=False)
    for ax, j in zip(axes[0], panels, strict=False):
        assert sob is not None
        names = [str(x) for x in sob.input.values]
        x = np.arange(len(names))
        for key, off, colour in (("S1", -0.2, "C0"), ("ST", 0.2, "C1")):
            ax.bar(x + off, sob[key].values[-1, j], 0.4, yerr=sob[f"{key}_conf"].values[-1, j],
                   capsize=3, color=colour, label=key)
        ax.set_xticks(x, names)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel("Sobol' index (1)")
        ax.set_title(f"{sob.output.values[j]} (N = {int(sob.base_size.values[-1])})",
                     fontsize=9)
        ax.legend(fontsize=8)
    if al is not None:
        ax = axes[0][-1]
        names = [str(x) for x in al.input.values]
        y = np.arange(len(names))
        for j, sign in enumerate((-1.0, 1.0)):
            on = al.allocated.values[:, j] == 1
            declared = al.declared.values[:, j]
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(on & (declared > 0), al.allocation.values[:, j] / declared,
                                 np.nan)
            bars = ax.barh(y, sign * ratio, 0.6, color="C2" if j else "C3",
                           label="plus" if j else "minus")
            for b, capped in zip(bars, al.capped.values[:, j], strict=True):
                if capped:
                    b.set_hatch("//")
        ax.axvline(-1.0, color="k", ls="--", lw=0.8, label="declared")
        ax.axvline(1.0, color="k", ls="--", lw=0.8)
        ax.set_xscale("symlog", linthresh=1.0)
        ax.set_yticks(y, names)
        ax.set_xlabel("allocated deviation / declared tolerance")
        ax.set_title("allocation (hatched: the cap is within spec)", fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    fig.suptitle("EN-06: tolerances of EN-02's transport (Sobol' indices, allocation)",
                 fontsize=10)
    fixed_layout(fig, 0.6, 0.2, 0.6, 0.55, wgap=0.9)
    save_figure(fig, path, dpi=100)
    plt.close(fig)
    return True


# ------------------------------------------------------------------------ the markdown text
def section(parts: dict[str, xr.Dataset], s: dict[str, Any], path: Path | None) -> list[str]:
    """The markdown of the tilt check and the tolerances (empty without their parts); path:
    the figure written, None for none."""
    lines: list[str] = []
    if "tilt_check" in s:
        t = s["tilt_check"]
        lines += ["## Energy identity under a mounting tilt", "",
                  f"EN-02 tilted beta = {fmt(t['beta_deg'])} deg toward psi = "
                  f"{fmt(t['psi_deg'])} deg on a {fmt(t['cycle_s'])} s cycle ({t['method']}, "
                  f"order {t['scheme_order']}): the largest |E - E0 - W_surface + D_friction| "
                  "with V = -m g . X.", "",
                  *table(["dt (s)", "energy residual (J)", "observed order", "status"],
                         [[dt, r, t["orders"][i - 1] if i else "", st]
                          for i, (dt, r, st) in enumerate(zip(t["dt_s"], t["energy_residual_J"],
                                                              t["status"], strict=True))]),
                  ""]
    tol = s.get("tolerances")
    if not tol:
        return lines
    spec, nom = tol["spec"], tol["nominal"]
    lines += ["## Tolerances of EN-02's transport", "",
              f"Within spec: carried, |final angle error| <= {fmt(spec['angle_deg'])} deg and "
              f"|final radius error| <= {fmt(spec['radius_m'])} m, from the nominal run "
              f"(final angle {fmt(nom['final_angle_deg'])} deg, radius "
              f"{fmt(nom['final_radius_m'])} m, W_surface {fmt(nom['surface_work_J'])} J; "
              + (f"{nom['method']}, each part at the tolerances its accuracy budget chose"
                 if nom.get("budgeted") else f"{nom['method']} at dt = {fmt(nom['dt_s'])} s")
              + "). Each input is uniform on its declared tolerance:", "",
              *table(["input", "key", "units", "nominal", "low", "high"],
                     [[n, v["key"], v["units"], v["nominal"], v["low"], v["high"]]
                      for n, v in tol["inputs"].items()]), "",
              f"Assumption: {tol['assumption']}.", ""]
    if "sobol" in tol:
        runs = tol["sobol_runs"]
        rows = []
        for out, v in tol["sobol"].items():
            for n in v["S1"]:
                rows.append([out, n, f"{fmt(v['S1'][n])} +- {fmt(v['S1_conf'][n])}",
                             f"{fmt(v['ST'][n])} +- {fmt(v['ST_conf'][n])}"])
        lines += ["### Sobol' indices", "",
                  f"EN-05's Saltelli design and estimators at N = "
                  f"{', '.join(str(n) for n in runs['base_sizes'])} ("
                  f"{', '.join(str(r) for r in runs['runs'])} runs; "
                  f"{runs['runs_not_ok'][-1]} not ok at the largest), bootstrap half-widths at "
                  f"{fmt(runs['confidence'])}; largest N shown. An output constant over the "
                  f"design (carried, when every run carries: carried fraction "
                  f"{fmt(runs['carried_fraction'])}) has no indices (nan).", "",
                  *table(["output", "input", "S1", "ST"], rows), "",
                  *_accuracy_lines(tol, "sobol", "of each output's standard deviation over "
                                   "the design")]
    if path is not None:
        lines += [f"![tolerances]({path.name})", ""]
    if "allocation" in tol:
        rows = []
        for n, a in tol["allocation"].items():
            rel, u = a["relative"], tol["inputs"][n]["units"]

            def pair(lo: float | None, hi: float | None, signed: bool = True,
                     rel: bool = rel, u: str = u) -> str:
                texts = [_dev(lo, rel, u), _dev(hi, rel, u)]
                if signed:
                    texts = [t if t == "-" else f"{s}{t}" for s, t in zip("-+", texts,
                                                                          strict=True)]
                return " / ".join(texts)

            capped = [side for side, c in zip(("minus", "plus"), a["capped"], strict=True) if c]
            rows.append([n, tol["inputs"][n]["key"], "relative" if rel else "absolute",
                         pair(*a["declared"]), pair(a["minus"], a["plus"]),
                         pair(*a["first_outside"], signed=False),
                         pair(*a["cap"], signed=False),
                         f"cap within spec ({', '.join(capped)})" if capped else "",
                         a["runs"]])
        srch = tol["allocation_search"]
        lines += ["### Tolerance allocation", "",
                  f"Each input alone (the others nominal), each side: {srch['scan']} equal steps "
                  f"to the cap up to the first out of spec, then {srch['iterations']} "
                  f"bisections; a tilted point is within spec only at every one of "
                  f"{srch['azimuths']} azimuths. '-' : the side is not allocated.", "",
                  *table(["input", "key", "deviation", "declared (-/+)", "allocated (-/+)",
                          "first out of spec (-/+)", "cap (-/+)", "note", "runs"], rows), "",
                  *_accuracy_lines(tol, "allocation", "of the bisection's resolution (numbers "
                                   "in resolutions: each boundary's shift)")]
    if "joint" in tol:
        j = tol["joint"]
        lo, hi = j["interval"]
        lines += ["### Joint Monte Carlo", "",
                  f"{j['n']} independent draws at the declared tolerances (seed {j['seed']}): "
                  f"{j['within']} within spec, fraction {fmt(j['fraction_within_spec'])}, "
                  f"{fmt(100.0 * j['confidence'])} % interval [{fmt(lo)}, {fmt(hi)}] "
                  f"({j['interval_method']}); {j['carried']} carried.", "",
                  *_accuracy_lines(tol, "joint", "of the spec's bounds")]
    return lines


def _accuracy_lines(tol: dict[str, Any], part: str, what: str) -> list[str]:
    """The part's accuracy paragraph: the budget's line, the method it ran at, any
    tightening (nothing when the dataset records no budget)."""
    a = tol.get("accuracy", {}).get(part)
    if a is None:
        return []
    if "line" not in a:
        return [f"Accuracy budget: {a['note']}.", ""]
    text = (f"Accuracy ({a['worst']}, the output nearest its budget): {a['line']}; the budget "
            f"a fraction {what}; run at {a['method']} rtol {a['rtol']:g}, atol {a['atol']:g}, "
            "the first setting a pilot found within budget, checked 100x tighter")
    if a["tightened"]:
        text += f"; the check broke the budget: tightened {a['tightened']} time(s) by 10x"
    if not a["ok"]:
        text += "; BUDGET STILL BROKEN at the last tightening"
    return [text + ".", ""]
