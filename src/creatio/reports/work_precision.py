"""Report of the work-precision benchmark: work_precision.json, .md and .png.

Derived from the datasets alone (one per base study, creatio.studies.work_precision). The
headline time of a run is the minimum over its timed repeats; beside it the median and the
spread, max / min over the repeats (1 = no scatter). Two timings are told apart only when
their ranges [min, max] do not overlap: a comparison whose ranges overlap is flagged as
within the timing noise, and a negative saving is never printed without such a flag. The
frontier (per error level: the fastest native run, the fastest peer, and the verdict
between them) is the report's headline, in the markdown and in the JSON.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from creatio.reports.answer import answer_lines
from creatio.reports.common import fmt, plt, save_figure, strict_json, table, write_text

__all__ = ["fastest", "overlap", "summary", "verdict", "write_report"]

SPREAD = "max / min of the timed repeats (1 = no scatter)"
TEXT = ("study", "group", "method", "solver", "setting", "setting_kind", "status")
NUMBERS = ("setting_value", "error_m", "final_error_m", "time_s", "time_median_s",
           "first_call_s")
COUNTS = ("repeats", "rhs_evals", "steps", "rejected_steps", "jacobians", "lu_factorisations",
          "newton_iterations", "state_size")
#: The peer every level is also compared with by name (the stiff solver of reference).
CVODE = "sundials-CVODE-BDF"


def entries(ds: Any) -> list[dict[str, Any]]:
    """The runs of one dataset as records (times_s: the repeats taken, in order)."""
    out = []
    for i in range(ds.sizes["entry"]):
        e: dict[str, Any] = {k: str(ds[k].values[i]) for k in TEXT}
        e.update({k: float(ds[k].values[i]) for k in NUMBERS})
        # -1: not in the dataset (written before the count was)
        e.update({k: int(ds[k].values[i]) if k in ds else -1 for k in COUNTS})
        times = np.asarray(ds["times_s"].values[i], dtype=float)
        e["times_s"] = [float(t) for t in times[np.isfinite(times)]]
        e["time_max_s"] = max(e["times_s"], default=math.nan)
        e["time_spread"] = e["time_max_s"] / e["time_s"] if e["time_s"] > 0 else math.nan
        out.append(e)
    return out


def overlap(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether the timing ranges [min, max] of two runs overlap (within the noise)."""
    return a["time_s"] <= b["time_max_s"] and b["time_s"] <= a["time_max_s"]


def verdict(native: dict[str, Any], peer: dict[str, Any]) -> str:
    """Native against peer: ``faster`` or ``slower`` when the ranges [min, max] are apart,
    ``within noise`` when they overlap."""
    if overlap(native, peer):
        return "within noise"
    return "faster" if native["time_s"] < peer["time_s"] else "slower"


def fastest(runs: Sequence[dict[str, Any]], level: float, group: str,
            exclude: str | None = None, method: str | None = None) -> dict[str, Any] | None:
    """The quickest run of a group (native, peer) whose error is <= level, optionally not
    of the method exclude, or only of the method `method`."""
    ok = [e for e in runs if e["group"] == group and e["error_m"] <= level
          and e["method"] != exclude and (method is None or e["method"] == method)]
    return min(ok, key=lambda e: e["time_s"]) if ok else None


def _brief(e: dict[str, Any] | None) -> dict[str, Any] | None:
    keys = ("method", "setting", "error_m", "time_s", "time_median_s", "time_max_s",
            "time_spread")
    counts = ("rhs_evals", "steps", "jacobians", "lu_factorisations", "newton_iterations",
              "rejected_steps")
    # a count a record lacks is -1, as a count a peer does not report
    return {**{k: e[k] for k in keys}, **{k: e.get(k, -1) for k in counts}} if e else None


def _saving(lean: dict[str, Any], full: dict[str, Any]) -> dict[str, Any]:
    """1 - lean / full (min times) and its noise flag."""
    saved = 1 - lean["time_s"] / full["time_s"]
    noise = overlap(lean, full)
    if noise:
        flag = "within noise (ranges overlap)"
    elif saved < 0:
        flag = "noise: negative beyond the ranges (a smaller state does no more work)"
    else:
        flag = ""
    return {"saved": saved, "within_noise": noise or saved < 0, "flag": flag}


def summary(runs: Sequence[dict[str, Any]], evidence: dict[str, Any], levels: Sequence[float],
            resolution_factor: float) -> dict[str, Any]:
    """One base study: fastest native method and best peer per level, minimal-state rows."""
    agreement = max(evidence.get("check_adaptive_max_diff_m", 0.0) or 0.0,
                    evidence.get("check_fixed_max_diff_m", 0.0) or 0.0)
    rows = []
    for level in levels:
        row: dict[str, Any] = {"level_m": level,
                               "resolved": level >= resolution_factor * agreement}
        best = fastest(runs, level, "native") if row["resolved"] else None
        peer = fastest(runs, level, "peer") if row["resolved"] else None
        second = fastest(runs, level, "native", best["method"]) if best else None
        cvode = fastest(runs, level, "peer", method=CVODE) if row["resolved"] else None
        row.update(native=_brief(best), peer=_brief(peer), runner_up=_brief(second),
                   cvode=_brief(cvode),
                   speed_up_cvode=cvode["time_s"] / best["time_s"] if best and cvode else None,
                   verdict_cvode=verdict(best, cvode) if best and cvode else None,
                   tied_with_runner_up=bool(best and second and overlap(best, second)),
                   speed_up=peer["time_s"] / best["time_s"] if best and peer else None,
                   spreads_overlap=bool(best and peer and overlap(best, peer)),
                   verdict=verdict(best, peer) if best and peer else None)
        rows.append(row)
    by_key = {(e["method"], e["setting"]): e for e in runs}
    minimal = []
    for full in runs:
        lean = by_key.get((full["method"].removesuffix("-full"), full["setting"]))
        if full["method"].endswith("-full") and lean is not None:
            minimal.append({"run": f"{lean['method']} {lean['setting']}",
                            "state": lean["state_size"], "time_s": lean["time_s"],
                            "time_spread": lean["time_spread"],
                            "full_state": full["state_size"], "full_time_s": full["time_s"],
                            "full_time_spread": full["time_spread"],
                            "frictionless": lean["group"] == "mu0",
                            **_saving(lean, full)})
    return {"reference": evidence, "fastest": rows, "minimal_state": minimal}


def _ms(x: float) -> str:
    return fmt(x * 1e3)


FRONTIER = ["error level (m)", "fastest native run", "time (ms)", "median (ms)", "spread",
            "error (m)", "fastest peer", "peer time (ms)", "peer median (ms)", "peer spread",
            "speed-up", "verdict", "noise"]


def _frontier(rows: Sequence[dict[str, Any]], factor: float) -> list[str]:
    """The frontier table: per level the fastest native run and peer (min, median, spread),
    the speed-up of the minima and the verdict; every overlap flagged."""
    out = []
    blank = [""] * (len(FRONTIER) - 2)
    for r in rows:
        if not r["resolved"]:
            out.append([r["level_m"], f"not resolved (below {fmt(factor)} x the reference's "
                        "own agreement)", *blank])
            continue
        b, p, second = r["native"], r["peer"], r["runner_up"]
        native = (["none reaches it", "", "", "", ""] if b is None else
                  [f"{b['method']} {b['setting']}", _ms(b["time_s"]), _ms(b["time_median_s"]),
                   fmt(b["time_spread"]), b["error_m"]])
        peer = (["none reaches it", "", "", ""] if p is None else
                [f"{p['method']} {p['setting']}", _ms(p["time_s"]), _ms(p["time_median_s"]),
                 fmt(p["time_spread"])])
        tie = (f"native tied with {second['method']} {second['setting']} (ranges overlap)"
               if r["tied_with_runner_up"] else "")
        noise = "; ".join(x for x in (tie, "speed-up within noise (ranges overlap)"
                                      if r["spreads_overlap"] else "") if x)
        speed = f"{fmt(r['speed_up'])}x" if r["speed_up"] is not None else ""
        out.append([r["level_m"], *native, *peer, speed, r["verdict"] or "", noise])
    return table(FRONTIER, out)


CVODE_TABLE = ["error level (m)", "fastest native run", "time (ms)", "spread",
               "rhs / jac / LU / Newton / rejected", "CVODE BDF run", "CVODE time (ms)",
               "CVODE spread", "CVODE rhs / jac", "speed-up", "verdict"]


def _count(v: int) -> str:
    return "-" if v < 0 else str(v)


def _cvode_frontier(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per level the fastest native run against the fastest CVODE BDF run, the work counts
    beside the times (-: not reported)."""
    out = []
    for r in rows:
        b, c = r["native"], r.get("cvode")
        if not r["resolved"]:
            out.append([r["level_m"], "not resolved", *[""] * (len(CVODE_TABLE) - 2)])
            continue
        native = (["none reaches it", "", "", ""] if b is None else
                  [f"{b['method']} {b['setting']}", _ms(b["time_s"]), fmt(b["time_spread"]),
                   " / ".join(_count(b.get(k, -1)) for k in (
                       "rhs_evals", "jacobians", "lu_factorisations", "newton_iterations",
                       "rejected_steps"))])
        peer = (["none reaches it", "", "", ""] if c is None else
                [c["setting"], _ms(c["time_s"]), fmt(c["time_spread"]),
                 f"{_count(c.get('rhs_evals', -1))} / {_count(c.get('jacobians', -1))}"])
        speed = f"{fmt(r['speed_up_cvode'])}x" if r.get("speed_up_cvode") is not None else ""
        out.append([r["level_m"], *native, *peer, speed, r.get("verdict_cvode") or ""])
    return table(CVODE_TABLE, out)


def _answer(studies: dict[str, dict], runs: Sequence[dict]) -> list[str]:
    """The benchmark's plain-word answer: per study, at its tightest resolved error level,
    the fastest native run against the fastest peer."""
    found = []
    for study, s in studies.items():
        done = [r for r in s["fastest"] if r["resolved"] and r["native"]]
        if not done:
            found.append(f"{study}: no error level is resolved and reached")
            continue
        r = min(done, key=lambda x: x["level_m"])
        b, p = r["native"], r["peer"]
        text = (f"{study} at {r['level_m']:g} m: {b['method']} {b['setting']} in "
                f"{_ms(b['time_s'])} ms")
        if p is not None:
            text += (f" against {p['method']} {p['setting']} in {_ms(p['time_s'])} ms "
                     f"({fmt(r['speed_up'])}x, {r['verdict']})")
        else:
            text += ", no peer reaches it"
        found.append(text)
    methods = sorted({e["method"] for e in runs if e["group"] != "peer"})
    return answer_lines(
        f"the time each integrator ({', '.join(methods)}) takes to reach each error level on "
        f"{', '.join(studies)}, beside scipy's and SUNDIALS' peers.",
        "the fastest native run at the tightest resolved level: " + "; ".join(found) + ".",
        "the centre's largest error against each study's reference on the 0.1 s grid; the "
        "minimum time over interleaved repeats, JIT excluded; speed-ups within the noise "
        "are flagged.")


def _markdown(studies: dict[str, dict], runs: Sequence[dict], machine: dict, jit: dict,
              levels: Sequence[float], factor: float, missing: Sequence[str] = ()) -> str:
    lines = ["# Work-precision benchmark (EN-02, EN-02R)", "",
             *_answer(studies, runs),
             "Error: max over the 0.1 s output grid of the centre-position error against the "
             "reference. Time: core call, single thread, JIT excluded; a warm-up run, then "
             "repeats interleaved round-robin across all settings (each round starting one "
             "setting later); the time is the minimum over the repeats, the median beside "
             f"it, spread = {SPREAD}. Two times whose ranges [min, max] overlap are within the "
             "noise and flagged so; verdict: native faster / slower than the fastest peer "
             "beyond the noise, or within it. Peers: scipy solve_ivp (DOP853, Radau, LSODA) "
             "and SUNDIALS CVODE BDF (scikit-sundae, the `bench` extra), on the same "
             "right-hand side, the same grid and the same error. Regenerate: "
             "`snakemake benchmarks -c 1`.", "",
             "Machine: " + "; ".join(f"{k} {v}" for k, v in machine.items()), ""]
    if missing:
        lines += [f"Peers not installed here, left out: {', '.join(missing)} "
                  "(`pip install -e .[bench]`).", ""]
    if jit:
        lines += ["JIT, excluded from every timing (first call of the compiled loop): "
                  + ", ".join(f"{k.removesuffix('_s').replace('_', ' ')} {fmt(v)} s"
                              for k, v in jit.items()) + ".", ""]
    for study, s in studies.items():
        ev = s["reference"]
        limits = ev.get("stability_limit_dt_s", {})
        lim = ", ".join(f"{m} {fmt(v)} s" for m, v in limits.items() if v is not None)
        lines += [f"## {study}", "",
                  f"Reference {ev.get('reference')} ({ev.get('reference_steps')} steps); "
                  f"agreement with {ev.get('check_adaptive')}: "
                  f"{fmt(ev.get('check_adaptive_max_diff_m', math.nan))} m, with "
                  f"{ev.get('check_fixed')}: {fmt(ev.get('check_fixed_max_diff_m', math.nan))} m."
                  + (f" Fixed-step friction stability limits: {lim}." if lim else "")
                  + "".join(f" Load average (1, 5, 15 min) {k} timing: {v}."
                            for k, v in s.get("load_average", {}).items()), ""]
        lines += _frontier(s["fastest"], factor)
        lines += ["", "Against SUNDIALS CVODE BDF alone, with the work counts:", ""]
        lines += _cvode_frontier(s["fastest"])
        if s["minimal_state"]:
            lines += ["", "Minimal state (`study.outputs=[trajectory]`) against full "
                      "diagnostics. With friction the spin drives the slip, so only the energy "
                      "bookkeeping can go; without friction (mu = 0) rotation goes too:", ""]
            lines += table(
                ["run", "state", "time (ms)", "spread", "full state", "full time (ms)",
                 "full spread", "saved", "noise"],
                [[m["run"] + (", mu = 0" if m["frictionless"] else ""), m["state"],
                  _ms(m["time_s"]), fmt(m["time_spread"]), m["full_state"],
                  _ms(m["full_time_s"]), fmt(m["full_time_spread"]),
                  f"{fmt(100 * m['saved'])}%", m["flag"]] for m in s["minimal_state"]])
        lines.append("")
    lines += ["## All runs", ""]
    lines += table(["study", "method", "setting", "error (m)", "final error (m)", "time (ms)",
                    "median (ms)", "spread", "repeats", "RHS evals", "steps", "rejected",
                    "Jacobians", "LU", "Newton", "status", "first call extra (s)"],
                   [[e["study"], e["method"], e["setting"], e["error_m"], e["final_error_m"],
                     _ms(e["time_s"]), _ms(e["time_median_s"]), e["time_spread"], e["repeats"],
                     e["rhs_evals"], e["steps"] if e["steps"] >= 0 else "not reported",
                     e["rejected_steps"], e["jacobians"], _count(e["lu_factorisations"]),
                     _count(e["newton_iterations"]), e["status"], e["first_call_s"]]
                    for e in runs])
    return "\n".join(lines) + "\n"


def _styles(methods: Sequence[str]) -> dict[str, tuple[Any, str, str]]:
    """(colour, marker, line style) per method, distinct for any number of methods."""
    n = len(methods)
    cmap = plt.get_cmap("tab10" if n <= 10 else "tab20" if n <= 20 else "turbo")
    colours = cmap(np.arange(n) % cmap.N) if n <= 20 else cmap(np.linspace(0, 1, n))
    markers = "osD^vP*Xh<>p"
    return {m: (colours[i], markers[i % len(markers)],
                "--" if m.startswith(("scipy-", "sundials-")) else "-")
            for i, m in enumerate(methods)}


def _figure(runs: Sequence[dict], path: Path) -> None:
    """Log-log work-precision figure per study: error against core time (bars: the range of
    the repeats, min to max) and against right-hand-side evaluations."""
    studies = list(dict.fromkeys(e["study"] for e in runs))
    shown = [e for e in runs if e["group"] in ("native", "peer")
             and math.isfinite(e["error_m"]) and e["error_m"] > 0]
    methods = list(dict.fromkeys(e["method"] for e in shown))
    styles = _styles(methods)
    fig, axes = plt.subplots(max(len(studies), 1), 2, figsize=(15, 4.8 * max(len(studies), 1)),
                             squeeze=False)
    legend: dict[str, Any] = {}
    for row, study in enumerate(studies):
        for col, (key, label) in enumerate((("time_s", "core time (s)"),
                                            ("rhs_evals", "right-hand-side evaluations"))):
            ax = axes[row, col]
            for m in methods:
                pts = sorted((e for e in shown if e["study"] == study and e["method"] == m),
                             key=lambda e: e[key])
                if not pts:
                    continue
                colour, marker, ls = styles[m]
                x = np.array([e[key] for e in pts], dtype=float)
                y = np.array([e["error_m"] for e in pts])
                (line,) = ax.loglog(x, y, ls, color=colour, marker=marker, ms=4, label=m)
                legend.setdefault(m, line)
                if key == "time_s":
                    upper = np.array([e["time_max_s"] for e in pts]) - x
                    ax.errorbar(x, y, xerr=[np.zeros_like(x), upper], fmt="none",
                                ecolor=colour, elinewidth=1.2, capsize=2)
            ax.axhline(1e-10, color="grey", lw=0.8, ls=":")
            ax.set_xlabel(label + (" (bars: min to max of the repeats)" if col == 0 else ""))
            ax.set_ylabel("max centre error (m)")
            ax.set_title(f"{study}: error against {label.split(' (')[0]}")
            ax.grid(True, which="both", alpha=0.3)
    # one legend for every panel, beside them: inside, two dozen entries hid the curves
    fig.legend(list(legend.values()), list(legend), loc="center right", fontsize=8,
               ncol=1 if len(legend) <= 30 else 2)
    fig.tight_layout(rect=(0.0, 0.0, 0.87 if len(legend) <= 30 else 0.77, 1.0))
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write work_precision.{json,md,png} into outdir from the benchmark's datasets."""
    from creatio.store.netcdf import read_dataset

    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    loaded = [read_dataset(p) for p in datasets]
    config = next((c for _, c in loaded if c), {})
    settings = config.get("study", {})
    levels = [float(v) for v in settings.get("levels", [1e-6, 1e-8, 1e-10, 1e-12])]
    factor = float(settings.get("resolution_factor", 10.0))
    runs: list[dict[str, Any]] = []
    studies: dict[str, dict] = {}
    machine: dict[str, str] = {}
    jit: dict[str, float] = {}
    missing: set[str] = set()
    for ds, _ in loaded:
        these = entries(ds)
        runs += these
        base = str(ds.attrs.get("base", these[0]["study"] if these else "?"))
        studies[base] = summary(these, json.loads(ds.attrs.get("reference", "{}")), levels,
                                factor)
        studies[base]["load_average"] = {k: str(ds.attrs[f"load_{k}_timing"])
                                         for k in ("before", "after")
                                         if f"load_{k}_timing" in ds.attrs}
        machine = machine or json.loads(ds.attrs.get("machine", "{}"))
        jit.update(json.loads(ds.attrs.get("jit", "{}") or "{}"))
        missing.update(json.loads(ds.attrs.get("peers_unavailable", "[]") or "[]"))
    paths = {"json": outdir / "work_precision.json", "md": outdir / "work_precision.md",
             "png": outdir / "work_precision.png"}
    report = {"title": settings.get("title", "work-precision benchmark"),
              "time": "core call, min over the repeats (time_s); median (time_median_s)",
              "time_spread": SPREAD, "noise": "two times whose ranges [min, max] overlap",
              "verdict": "native against the fastest peer: faster / slower beyond the noise, "
                         "or within noise (ranges overlap)",
              "machine": machine, "jit": jit, "levels_m": levels,
              "peers_unavailable": sorted(missing),
              "frontier": {k: v["fastest"] for k, v in studies.items()}, "studies": studies,
              "entries": runs}
    write_text(paths["json"], strict_json(report))
    write_text(paths["md"], _markdown(studies, runs, machine, jit, levels, factor,
                                      sorted(missing)))
    _figure(runs, paths["png"])
    return paths
