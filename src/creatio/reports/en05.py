"""Reports of EN-05 (docs/studies.md); `creatio calibrate` has its own (reports.calibration).

From EN-05's datasets (``en05_ishigami``, ``en05_calibration``, ``en05_experiment``,
``en05_sobol``): ``en05.json`` (the contract: sobol, ishigami, carried_fraction,
calibration, design), ``en05.md``, ``en05.png`` (indices with their intervals per output at
each base size), ``en05_sobol.csv`` (the index table), ``en05_calibration.png`` (the round
trip's residuals, estimates over seeds, the spread beside Cramer-Rao) and
``en05_design.png`` (sigma_mu against the cycle length per mu, lost runs marked). Nothing
here recomputes.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.common import fmt, plt, save_figure, strict_json, table, write_text
from creatio.store.atomic import atomic_write
from creatio.studies.budget import Verification
from creatio.studies.en05_schema import ACCURACY_PREFIX

__all__ = ["accuracy_summary", "en05_summary", "residual_axes", "write_report"]

_INDICES = ("S1", "ST", "S1_conf", "ST_conf")


def _by_title(datasets: Sequence[xr.Dataset]) -> dict[str, xr.Dataset]:
    """The datasets by part: ishigami, calibration, experiment, sobol."""
    out = {}
    for ds in datasets:
        if "sigma_mu" in ds:
            out["experiment"] = ds
        elif "seed_estimate" in ds:
            out["calibration"] = ds
        elif "S1_closed_form" in ds:
            out["ishigami"] = ds
        elif "unit_sample" in ds:
            out["sobol"] = ds
    missing = {"ishigami", "calibration", "experiment", "sobol"} - set(out)
    if missing:
        raise ValueError(f"EN-05's report needs the datasets {sorted(missing)} too "
                         "(the Sobol' sample: snakemake en05, or creatio run study=en05)")
    return out


def _mapping(names: Sequence[str], values: Sequence[float]) -> dict[str, float]:
    return {str(n): float(v) for n, v in zip(names, values, strict=True)}


def sobol_summary(ds: xr.Dataset) -> dict[str, Any]:
    """Per base size and output: the indices and half-widths (input -> value; null where not
    computed), runs, runs_not_ok, runs_missing, computed."""
    names = [str(n) for n in ds.input.values]
    out: dict[str, Any] = {}
    for i, N in enumerate(ds.base_size.values):
        per: dict[str, Any] = {}
        for j, name in enumerate(ds.output.values):
            computed = bool(np.all(np.isfinite(ds.S1.values[i, j])))
            entry: dict[str, Any] = {
                k: (_mapping(names, ds[k].values[i, j]) if computed else None) for k in _INDICES}
            entry.update({"runs": int(ds.runs.values[i]),
                          "runs_not_ok": int(ds.runs_not_ok.values[i]),
                          "runs_missing": int(ds.runs_missing.values[i, j]),
                          "computed": computed})
            if not computed:
                entry["why"] = (f"{int(ds.runs_missing.values[i, j])} runs did not produce it"
                                if ds.runs_missing.values[i, j] else "constant over the design")
            per[str(name)] = entry
        out[str(int(N))] = per
    return out


def accuracy_summary(ds: xr.Dataset) -> dict[str, Any] | None:
    """The sample's accuracy check (creatio.pipeline.points): the line "numerical error <= X
    (budget Y, checked on N points)", the setting the runs used and the check's reference,
    each output's budget and observed error, the outputs no setting resolves (with why);
    None for a sample run without a budget."""
    if f"{ACCURACY_PREFIX}outputs" not in ds.attrs:
        return None
    check = Verification.from_attrs(ds.attrs, ACCURACY_PREFIX)
    unresolved = json.loads(str(ds.attrs.get(f"{ACCURACY_PREFIX}unresolved", "{}")))
    return {
        "line": check.line(), "describe": check.describe(), "ok": check.ok,
        "worst_output": check.worst(), "points": check.points, "seed": check.seed,
        "tightened": check.tightened,
        "fraction": float(ds.attrs.get(f"{ACCURACY_PREFIX}fraction", math.nan)),
        "rung": {"method": check.rung.method, "rtol": check.rung.rtol,
                 "atol": check.rung.atol},
        "reference": {"method": check.reference.method, "rtol": check.reference.rtol,
                      "atol": check.reference.atol},
        "outputs": {k: {"budget": check.budget[k], "observed": check.observed[k],
                        "checked": check.budget[k] > 0.0} for k in check.budget},
        "unresolved": unresolved,
    }


def mass_check(ds: xr.Dataset) -> dict[str, Any]:
    """Per base size and kinematic output: the ST of m, its half-width, whether zero lies in
    that interval, and the estimator's noise (the output's largest half-width)."""
    from creatio.studies.en05 import KINEMATIC_OUTPUTS

    names = [str(n) for n in ds.input.values]
    if "m" not in names:
        return {}
    j = names.index("m")
    outs = [str(o) for o in ds.output.values]
    out: dict[str, Any] = {}
    for i, N in enumerate(ds.base_size.values):
        per = {}
        for name in KINEMATIC_OUTPUTS:
            k = outs.index(name)
            st, conf = float(ds.ST.values[i, k, j]), float(ds.ST_conf.values[i, k, j])
            if not math.isfinite(st):
                continue
            per[name] = {"ST": st, "ST_conf": conf, "zero_in_interval": abs(st) <= conf,
                         "estimator_noise": float(np.max(ds.ST_conf.values[i, k]))}
        out[str(int(N))] = per
    return out


def en05_summary(datasets: Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON contract of EN-05 (docs/studies.md)."""
    parts = _by_title(datasets)
    ish, cal, exp, sob = (parts[k] for k in ("ishigami", "calibration", "experiment", "sobol"))
    names = [str(n) for n in ish.input.values]
    top = -1  # the largest base size
    keys = [str(p) for p in cal.parameter.values]
    Ts = [float(t) for t in exp.cycle.values]
    mus = [float(m) for m in exp.mu.values]
    return {
        "study": "en05",
        "sobol": sobol_summary(sob),
        "ishigami": {
            "S1": _mapping(names, ish.S1.values[top]), "ST": _mapping(names, ish.ST.values[top]),
            "S1_conf": _mapping(names, ish.S1_conf.values[top]),
            "ST_conf": _mapping(names, ish.ST_conf.values[top]),
            "S1_closed_form": _mapping(names, ish.S1_closed_form.values),
            "ST_closed_form": _mapping(names, ish.ST_closed_form.values),
            "base_size": int(ish.base_size.values[top]),
            "by_base_size": {str(int(N)): {k: _mapping(names, ish[k].values[i]) for k in _INDICES}
                             for i, N in enumerate(ish.base_size.values)},
        },
        "carried_fraction": float(sob.attrs["carried_fraction"]),
        "sample_accuracy": accuracy_summary(sob),
        "mass_invariance": mass_check(sob),
        "calibration": {
            "truth": _mapping(keys, cal.truth.values),
            "estimate": _mapping(keys, cal.estimate.values),
            "stderr": _mapping(keys, cal.stderr.values),
            "interval_95": {k: [float(v) for v in cal.interval_95.values[i]]
                            for i, k in enumerate(keys)},
            "correlation": [[float(v) for v in row] for row in cal.correlation.values],
            "residual_rms_m": float(cal.attrs["residual_rms_m"]),
            "noise_m": float(cal.attrs["noise_m"]),
            "coverage_95": _mapping(keys, cal.coverage_95.values),
            "seeds": int(cal.sizes["seed"]),
            "cycle_s": float(cal.attrs["cycle_s"]),
            "window_s": [float(cal.attrs["window_start_s"]), float(cal.attrs["window_end_s"])],
            "flags": str(cal.attrs["flags"]),
            "alone": {"key": str(cal.attrs["alone_key"]), "seeds": int(cal.sizes["spread_seed"]),
                      "spread": float(cal.attrs["alone_spread"]),
                      "cramer_rao_sigma": float(cal.attrs["cramer_rao_sigma"])},
            "numerical_error": _check_line(cal.attrs, "accuracy_"),
            "example_numerical_error": _check_line(cal.attrs, "example_accuracy_"),
        },
        "design": {
            "T_s": Ts, "mu": mus,
            "sigma_mu": [[float(v) for v in row] for row in exp.sigma_mu.values],
            "sigma_mu_eps_unknown": [[float(v) for v in row]
                                     for row in exp.sigma_mu_eps_unknown.values],
            "lost": [[bool(v) for v in row] for row in exp.lost.values],
            "max_step_disagreement": float(np.nanmax(np.where(exp.lost.values == 0,
                                                              exp.step_disagreement.values,
                                                              np.nan))),
            "camera_noise_m": float(exp.attrs["camera_noise_m"]),
            "camera_hz": float(exp.attrs["camera_hz"]),
            "pins_mu_to_0_01": {f"{mu:g}": [T for T, p in zip(Ts, exp.pins_mu.values[i],
                                                              strict=True) if p]
                                for i, mu in enumerate(mus)},
            "target": float(exp.attrs["target"]),
            "numerical_error": _check_line(exp.attrs, "accuracy_"),
        },
    }


def _check_line(attrs: Any, prefix: str) -> str | None:
    """The line of a part's accuracy check ("numerical error <= X (budget Y, checked on N
    points)"), or None for a dataset made before budgets."""
    if f"{prefix}outputs" not in attrs:
        return None
    return Verification.from_attrs(attrs, prefix).line()


# ------------------------------------------------------------------------------ figures
def _index_figure(ds: xr.Dataset, path: Path) -> None:
    """S1 and ST with their intervals per input, one panel per output, each base size."""
    names = [str(n) for n in ds.input.values]
    outs = [str(o) for o in ds.output.values]
    acc = accuracy_summary(ds)
    n_b = ds.sizes["base_size"]
    cols = 4
    rows = math.ceil(len(outs) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.3 * rows), squeeze=False)
    x = np.arange(len(names))
    width = 0.8 / (2 * n_b)
    for k, name in enumerate(outs):
        ax = axes.flat[k]
        j = outs.index(name)
        if not np.all(np.isfinite(ds.S1.values[-1, j])):
            why = (f"{int(ds.runs_missing.values[-1, j])} runs did not produce it"
                   if ds.runs_missing.values[-1, j] else
                   f"constant over the design\n(= {float(ds[name].values[0]):g} in every run)")
            ax.text(0.5, 0.5, f"{name}\nno indices:\n{why}", ha="center", va="center",
                    transform=ax.transAxes)
            ax.set_xticks([])
            ax.set_yticks([])
            continue
        for i, N in enumerate(ds.base_size.values):
            for m, (key, color) in enumerate((("S1", "tab:blue"), ("ST", "tab:red"))):
                off = (2 * i + m - n_b + 0.5) * width
                ax.bar(x + off, ds[key].values[i, j], width, yerr=ds[f"{key}_conf"].values[i, j],
                       color=color, alpha=0.45 + 0.5 * i / max(n_b - 1, 1), capsize=2,
                       label=f"{key}, N = {int(N)}")
        ax.set_xticks(x, names)
        ax.axhline(0.0, color="k", lw=0.6)
        noise = acc["unresolved"] if acc else {}
        ax.set_title(name + (" (not resolved: noise)" if name in noise else ""), fontsize=10)
        ax.set_ylim(-0.15, 1.1)
        ax.grid(alpha=0.3, axis="y")
    for ax in list(axes.flat)[len(outs):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7, loc="upper right")
    fig.suptitle("EN-05: first-order (S1) and total (ST) Sobol' indices of EN-02's outputs, "
                 f"bootstrap {ds.attrs['confidence']:.0%} intervals; carried fraction "
                 f"{ds.attrs['carried_fraction']:.3f}"
                 + (f"\nruns: {acc['line']}" if acc else ""), fontsize=11)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def _design_figure(ds: xr.Dataset, path: Path) -> None:
    """sigma_mu against T per mu (log-log), the target line, lost runs marked."""
    fig, ax = plt.subplots(figsize=(9, 5.5))
    T = ds.cycle.values
    z, target = float(ds.attrs["z"]), float(ds.attrs["target"])
    for i, mu in enumerate(ds.mu.values):
        line, = ax.loglog(T, ds.sigma_mu.values[i], "o-", ms=4, label=f"mu = {mu:g}, eps known")
        ax.loglog(T, ds.sigma_mu_eps_unknown.values[i], "--", color=line.get_color(), lw=1,
                  label=f"mu = {mu:g}, eps fitted too")
        lost = ds.lost.values[i] == 1
        if lost.any():
            ax.plot(T[lost], np.full(lost.sum(), target / z), "x", color=line.get_color(),
                    ms=10, mew=2, label=f"mu = {mu:g}: sphere lost")
    ax.axhline(target / z, color="k", lw=1, ls=":",
               label=f"pins mu to +-{target:g} ({ds.attrs['confidence']:.0%}): sigma <= "
                     f"{target / z:.3g}")
    ax.axvline(120.0, color="grey", lw=0.8)
    ax.text(120.0, ax.get_ylim()[1], " EN-02", va="top", color="grey")
    ax.set_xlabel("cycle length T (s)")
    ax.set_ylabel("Cramer-Rao standard error of mu")
    ax.set_title(f"Which test pins mu: a {ds.attrs['camera_noise_m'] * 1e3:g} mm, "
                 f"{ds.attrs['camera_hz']:g} Hz camera ({ds.attrs['camera_coordinates']}) over "
                 "one cycle", fontsize=11)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def residual_axes(axes: Any, ds: xr.Dataset, noise: float) -> None:
    """Residuals against time per coordinate, and their histogram in units of the noise."""
    t = ds.time.values
    for c, name in enumerate(ds.coordinate.values):
        axes[0].plot(t, ds.residual.values[:, c] * 1e3, ".", ms=2, label=f"{name}")
    axes[0].set_xlabel("t (s)")
    axes[0].set_ylabel("model - track (mm)")
    axes[0].legend(fontsize=8)
    axes[0].grid(alpha=0.3)
    if math.isfinite(noise) and noise > 0:
        u = ds.residual.values.ravel() / noise
        axes[1].hist(u, bins=40, density=True, alpha=0.6, label="residual / noise")
        g = np.linspace(-4, 4, 200)
        axes[1].plot(g, np.exp(-g * g / 2) / math.sqrt(2 * math.pi), "k", label="N(0, 1)")
        axes[1].set_xlabel("residual / stated noise")
        axes[1].legend(fontsize=8)
    else:
        axes[1].hist(ds.residual.values.ravel() * 1e3, bins=40)
        axes[1].set_xlabel("residual (mm); no noise stated")


def _calibration_figure(ds: xr.Dataset, path: Path) -> None:
    """The round trip: residuals of the example seed, estimates over seeds, the first key
    fitted alone beside its Cramer-Rao bound."""
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    noise = float(ds.attrs["noise_m"])
    residual_axes(axes[0], ds, noise)
    axes[0, 0].set_title(f"example seed: residuals (rms {ds.attrs['residual_rms_m'] * 1e3:.3g} "
                         f"mm, noise {noise * 1e3:g} mm)", fontsize=10)
    keys = [str(p) for p in ds.parameter.values]
    est = ds.seed_estimate.values
    ax = axes[1, 0]
    if len(keys) >= 2:
        cov = ds.seed_covered.values.all(axis=1)
        ax.plot(est[cov, 0], est[cov, 1], ".", ms=4, label="interval holds the truth")
        ax.plot(est[~cov, 0], est[~cov, 1], ".", ms=5, color="tab:red",
                label="interval misses it (some key)")
        ax.plot(*ds.truth.values[:2], "k*", ms=12, label="truth")
        ax.set_xlabel(keys[0])
        ax.set_ylabel(keys[1])
    else:
        ax.hist(est[:, 0], bins=30)
        ax.set_xlabel(keys[0])
    cov_text = ", ".join(f"{k}: {v:.3f}" for k, v in zip(keys, ds.coverage_95.values,
                                                         strict=True))
    ax.set_title(f"estimates over {ds.sizes['seed']} noise seeds; 95 % coverage {cov_text}",
                 fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[1, 1]
    alone = ds.alone_estimate.values
    cr = float(ds.attrs["cramer_rao_sigma"])
    truth0 = float(ds.truth.values[0])
    ax.hist(alone, bins=15, density=True, alpha=0.6, label="fitted alone, per seed")
    g = np.linspace(truth0 - 4 * cr, truth0 + 4 * cr, 200)
    ax.plot(g, np.exp(-0.5 * ((g - truth0) / cr) ** 2) / (cr * math.sqrt(2 * math.pi)), "k",
            label=f"N(truth, Cramer-Rao {cr:.3g})")
    ax.set_xlabel(f"{ds.attrs['alone_key']} (other keys known)")
    ax.set_title(f"spread {ds.attrs['alone_spread']:.3g} vs Cramer-Rao {cr:.3g}", fontsize=10)
    ax.legend(fontsize=8)
    ax.ticklabel_format(axis="x", useOffset=False)
    fig.suptitle(f"EN-05 calibration round trip: EN-02 at T = {ds.attrs['cycle_s']:g} s, "
                 f"camera over [{ds.attrs['window_start_s']:g}, {ds.attrs['window_end_s']:g}] s "
                 "(synthetic tracks)", fontsize=11)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------ markdown
def _answer(summary: dict[str, Any]) -> list[str]:
    """EN-05's plain-word answer, from its summary: what matters, what the fit returns,
    which cycle pins mu."""
    N = max(summary["sobol"], key=int)
    per = summary["sobol"][N]
    drivers = []
    acc = summary.get("sample_accuracy")
    noise = acc["unresolved"] if acc else {}
    for out, e in per.items():
        if e["computed"] and out not in noise:
            finite = {n: v for n, v in e["ST"].items() if v is not None and math.isfinite(v)}
            if finite:
                name, st = max(finite.items(), key=lambda kv: kv[1])
                drivers.append(f"{out}: {name} (ST {st:.2f})")
    runs = next(iter(per.values()))["runs"]
    cal = summary["calibration"]
    fit = ", ".join(f"{k} = {num(cal['estimate'][k])} +- {num(cal['stderr'][k], digits=2)} "
                    f"(truth {num(cal['truth'][k])})" for k in cal["truth"])
    cover = ", ".join(f"{k} {100 * v:.1f} %" for k, v in cal["coverage_95"].items())
    des = summary["design"]
    pins = "; ".join(f"mu = {mu}: T = {', '.join(f'{t:g}' for t in Ts)} s" if Ts
                     else f"mu = {mu}: no cycle" for mu, Ts in des["pins_mu_to_0_01"].items())
    what = ("which of EN-02's inputs move its outcomes (Sobol' total indices ST over "
            f"{runs} runs at N = {N}), a fit of {', '.join(cal['truth'])} back from a "
            f"synthetic {num(cal['cycle_s'], 's')} camera track, and which cycle length T "
            f"lets a {des['camera_noise_m'] * 1e3:g} mm, {des['camera_hz']:g} Hz camera pin "
            f"mu to +-{des['target']:g}.")
    answer = ["the input that moves each output most: " + (", ".join(drivers) or "none "
              "computed") + ".",
              f"the round trip returns {fit}; the 95 % intervals cover the truth for {cover} "
              f"of {cal['seeds']} noise seeds.",
              f"the cycles that pin mu to +-{des['target']:g}: {pins}."]
    ish = summary["ishigami"]
    worst = max(abs(ish[k][n] - ish[f"{k}_closed_form"][n]) for k in ("S1", "ST")
                for n in ish["S1"])
    checks = [f"{part}: {line}" for part, line in
              (("the sample", (summary.get("sample_accuracy") or {}).get("line")),
               ("the round trip", cal.get("numerical_error")),
               ("the design", des.get("numerical_error"))) if line]
    basis = ((f"model accuracy checked, {'; '.join(checks)}; " if checks else "")
             + f"{100 * summary['carried_fraction']:.1f} % of the sample runs carried; the same "
             f"estimators on the Ishigami function within {worst:.3f} of its closed forms; "
             f"central differences at two steps agree to "
             f"{num(des['max_step_disagreement'], digits=2)} (relative).")
    return answer_lines(what, answer, basis)


def _accuracy_lines(acc: dict[str, Any] | None) -> list[str]:
    """The section on the sample's numerical accuracy: the check's line, the setting, each
    output's error beside its budget, the outputs no setting resolves."""
    if acc is None:
        return ["## Numerical accuracy of the sample", "",
                "No accuracy budget (study.sensitivity.budget: null): every run at the "
                "sample's own tolerances, unchecked.", ""]
    r, ref = acc["rung"], acc["reference"]
    out = ["## Numerical accuracy of the sample", "",
           f"**{acc['line']}** (worst output: {acc['worst_output'] or 'none'}). The budget is "
           f"{acc['fraction']:g} of each output's standard deviation over the sample; the runs "
           f"used {r['method']} at rtol {r['rtol']:g}, atol {r['atol']:g} (chosen by a pilot), "
           f"checked on {acc['points']} seeded points rerun at rtol {ref['rtol']:g}"
           + (f"; the budget was broken at first and the rung tightened "
              f"{acc['tightened']} time(s) by 10x" if acc["tightened"] else "")
           + ("." if acc["ok"] else "; **the budget is broken**."), ""]
    rows = [[k, v["observed"], v["budget"] if v["checked"] else "constant: none",
             ("yes" if v["observed"] <= v["budget"] else "no") if v["checked"] else ""]
            for k, v in acc["outputs"].items()]
    rows += [[k, v["observed"], v["budget"], f"not resolved: {v['why']}"]
             for k, v in acc["unresolved"].items()]
    out += table(["output", "largest error on the check", "budget", "within"], rows) + [""]
    return out


def _markdown(summary: dict[str, Any], sob: xr.Dataset) -> str:
    names = [str(n) for n in sob.input.values]
    keys = [str(k) for k in sob.input_key.values]
    lines = ["# EN-05 uncertainty, sensitivity and calibration", "", *_answer(summary),
             "Inputs: " + ", ".join(f"{n} ({k})" for n, k in zip(names, keys, strict=True)) +
             f"; sample runs with `{sob.attrs['sample_base_overrides']}` over EN-02.", "",
             f"Carried fraction (status ok and never out of its cavity): "
             f"{summary['carried_fraction']:.4f} of {int(sob.sizes['point'])} runs.", ""]
    acc = summary.get("sample_accuracy")
    noise = acc["unresolved"] if acc else {}
    lines += _accuracy_lines(acc)
    for N, per in summary["sobol"].items():
        lines += [f"## Sobol' indices, N = {N} ({next(iter(per.values()))['runs']} runs, "
                  f"{next(iter(per.values()))['runs_not_ok']} not ok)", ""]
        if acc:
            lines += [f"Numerical accuracy of the runs: {acc['line']}.", ""]
        rows = []
        for out, e in per.items():
            if not e["computed"]:
                rows.append([out, e["why"], *["" for _ in names]])
                continue
            label = f"{out} (not resolved: noise)" if out in noise else out
            rows.append([label, "S1", *[f"{e['S1'][n]:.3f} +- {e['S1_conf'][n]:.3f}"
                                        for n in names]])
            rows.append(["", "ST", *[f"{e['ST'][n]:.3f} +- {e['ST_conf'][n]:.3f}"
                                     for n in names]])
        lines += table(["output", "index", *names], rows) + [""]
    lines += ["## The mass's total index on the kinematic outputs", "",
              "Zero in exact arithmetic (docs/model.md s.13.1); what remains is the sample "
              "integrator's (radau5's step sequence sees m through the energy accumulators).", ""]
    rows = [[N, out, e["ST"], e["ST_conf"], "yes" if e["zero_in_interval"] else "no",
             e["estimator_noise"]]
            for N, per in summary["mass_invariance"].items() for out, e in per.items()]
    lines += table(["N", "output", "ST of m", "+-", "0 in its interval",
                    "estimator noise (largest +-)"], rows) + [""]
    ish = summary["ishigami"]
    lines += [f"## Ishigami check (N = {ish['base_size']}, same design and estimators)", ""]
    lines += table(["input", "S1", "+-", "closed form", "ST", "+-", "closed form"],
                   [[n, ish["S1"][n], ish["S1_conf"][n], ish["S1_closed_form"][n], ish["ST"][n],
                     ish["ST_conf"][n], ish["ST_closed_form"][n]] for n in ish["S1"]]) + [""]
    cal = summary["calibration"]
    lines += ["## Calibration round trip (synthetic tracks made by the model)", "",
              f"EN-02 at T = {cal['cycle_s']:g} s, camera over {cal['window_s']} s; residual rms "
              f"{fmt(cal['residual_rms_m'])} m against the stated noise {fmt(cal['noise_m'])} m.",
              ""]
    lines += table(["key", "truth", "estimate", "stderr", "95 % interval", "coverage over "
                    f"{cal['seeds']} seeds"],
                   [[k, cal["truth"][k], cal["estimate"][k], cal["stderr"][k],
                     f"[{fmt(cal['interval_95'][k][0])}, {fmt(cal['interval_95'][k][1])}]",
                     cal["coverage_95"][k]] for k in cal["truth"]]) + [""]
    alone = cal["alone"]
    lines += [f"{alone['key']} fitted alone over {alone['seeds']} seeds: spread "
              f"{fmt(alone['spread'])}, Cramer-Rao bound {fmt(alone['cramer_rao_sigma'])} "
              f"(ratio {alone['spread'] / alone['cramer_rao_sigma']:.3f}).", ""]
    if cal["flags"]:
        lines += [f"Flags: {cal['flags']}", ""]
    des = summary["design"]
    lines += ["## Which test pins mu (Cramer-Rao sigma_mu, eps known)", "",
              f"Camera {des['camera_noise_m'] * 1e3:g} mm, {des['camera_hz']:g} Hz over one "
              f"cycle; 'x' marks a run that loses the sphere; central differences at two steps "
              f"agree to {fmt(des['max_step_disagreement'])} (relative, carried runs).", ""]
    rows = []
    for j, T in enumerate(des["T_s"]):
        rows.append([T, *[("x (lost)" if des["lost"][i][j] else des["sigma_mu"][i][j])
                          for i in range(len(des["mu"]))]])
    lines += table(["T (s)", *[f"mu = {m:g}" for m in des["mu"]]], rows) + [""]
    for mu, Ts in des["pins_mu_to_0_01"].items():
        lines.append(f"* mu = {mu}: pinned to +-{des['target']:g} by T = "
                     f"{', '.join(f'{t:g}' for t in Ts) or 'none'} s")
    return "\n".join(lines) + "\n"


def _csv(ds: xr.Dataset, path: Path) -> None:
    with atomic_write(path) as fh:
        w = csv.writer(fh)
        w.writerow(["base_size", "output", "input", "input_key", "S1", "S1_conf", "ST",
                    "ST_conf"])
        for i, N in enumerate(ds.base_size.values):
            for j, out in enumerate(ds.output.values):
                for k, name in enumerate(ds.input.values):
                    w.writerow([int(N), str(out), str(name), str(ds.input_key.values[k]),
                                *(repr(float(ds[key].values[i, j, k]))
                                  for key in ("S1", "S1_conf", "ST", "ST_conf"))])


def write_report(datasets: Sequence[Path], outdir: Path) -> dict[str, Path]:
    """EN-05's report files from its four datasets."""
    # times stay seconds (decoded, a time in "s" would become a date)
    loaded = [xr.load_dataset(p, engine="netcdf4", decode_times=False) for p in datasets]
    parts = _by_title(loaded)
    summary = en05_summary(loaded)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    paths = {"json": write_text(outdir / "en05.json", strict_json(summary)),
             "md": write_text(outdir / "en05.md", _markdown(summary, parts["sobol"]))}
    _index_figure(parts["sobol"], outdir / "en05.png")
    _csv(parts["sobol"], outdir / "en05_sobol.csv")
    _calibration_figure(parts["calibration"], outdir / "en05_calibration.png")
    _design_figure(parts["experiment"], outdir / "en05_design.png")
    paths.update({"png": outdir / "en05.png", "csv": outdir / "en05_sobol.csv",
                  "calibration": outdir / "en05_calibration.png",
                  "design": outdir / "en05_design.png"})
    return paths
