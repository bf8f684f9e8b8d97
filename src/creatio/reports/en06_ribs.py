"""EN-06's rib section: the ``ribs`` dict of data/reports/en06.json and its two figures (the
transport error against N on log-log axes with the order-6 line, the rib-error histogram),
from the dataset of creatio.studies.en06_ribs.ribs_dataset."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.reports.answer import num
from creatio.reports.common import fmt, save_figure, table

__all__ = ["ASSUMPTION", "answer", "error_histogram", "ribs_section", "section", "summary",
           "transport_figure"]

#: The one line each rib figure rests on.
ASSUMPTION = ("spline skin: between the ribs the membrane is the periodic quintic spline "
              "through them (docs/model.md s.14.4)")


def _f(x: Any) -> float | None:
    """A JSON number (None for NaN)."""
    v = float(x)
    return None if math.isnan(v) else v


def ribs_section(ds: xr.Dataset, surface: str = "en02") -> dict[str, Any]:
    """The report contract's ``ribs``: refusals, the ideal run, the cases of `surface` by N,
    the smallest N within spec and the rib errors' fraction within spec."""
    s = ds.sel(surface=surface)
    cases = []
    for N in ds.N.values:
        c = s.sel(N=N)
        cases.append({
            "N": int(N), "shape_error_rel": _f(ds.shape_error_rel.sel(N=N)),
            "h0": _f(ds.h0.sel(N=N)),
            "largest_alias": {"n": int(ds.largest_alias_n.sel(N=N)),
                              "h": _f(ds.largest_alias_h.sel(N=N))},
            "final_angle_deg": _f(c.final_angle_deg), "final_radius_m": _f(c.final_radius_m),
            "W_surface_J": _f(c.W_surface_J), "min_normal_N": _f(c.min_normal_N),
            "dt_difference_m": _f(c.dt_difference_m), "within_spec": bool(c.within_spec == 1.0),
        })
    within = [c["N"] for c in cases if c["within_spec"]]
    return {
        "refused": [{"N": int(N), "reason": str(r)}
                    for N, r in zip(ds.refused_N.values, ds.refused_reason.values, strict=True)],
        "ideal": {"final_angle_deg": _f(s.ideal_final_angle_deg),
                  "final_radius_m": _f(s.ideal_final_radius_m),
                  "W_surface_J": _f(s.ideal_W_surface_J),
                  "min_normal_N": _f(s.ideal_min_normal_N)},
        "cases": cases,
        "smallest_N_within_spec": min(within) if within else None,
        "errors": {"N": int(ds.attrs["errors_N"]), "seeds": int(ds.seed.size),
                   "sigma_e": float(ds.attrs["sigma_e"]),
                   "sigma_d_deg": float(ds.attrs["sigma_d_deg"]),
                   "fraction_within_spec": _f(ds.attrs["fraction_within_spec"]),
                   "interval_95": [_f(ds.attrs["interval_95_low"]),
                                   _f(ds.attrs["interval_95_high"])]},
    }


def transport_figure(ds: xr.Dataset, path: Path) -> Path:
    """The largest centre deviation from the ideal run against N (log-log), per surface, with
    the skin's shape error and an order-6 line through the first point."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    N = ds.N.values.astype(float)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for name in ds.surface.values:
        ax.loglog(N, ds.transport_error_m.sel(surface=name), "o-",
                  label=f"{name}: max |X_N - X_ideal| (m)")
    ax.loglog(N, ds.shape_error_rel, "s--", label="skin's relative RMS shape error (-)")
    first = float(ds.transport_error_m.isel(surface=0, N=0))
    ax.loglog(N, first * (N / N[0]) ** -6.0, "k:", label="order 6: N^-6")
    ax.set_xticks(N, [str(int(n)) for n in N])
    ax.minorticks_off()
    ax.set_xlabel("ribs N")
    ax.set_ylabel("transport error (m) / shape error")
    ax.set_title("Transport error against the number of ribs\n" + "assumption: spline skin",
                 fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def error_histogram(ds: xr.Dataset, path: Path) -> Path:
    """The final angle error over the seeds of the ribs with errors, with the spec's bounds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    err = np.asarray(ds.error_angle_deg, float)
    spec = float(ds.attrs["spec_angle_deg"])
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.hist(err[np.isfinite(err)], bins=min(20, max(5, err.size // 3)), color="tab:blue")
    for x in (-spec, spec):
        ax.axvline(x, color="k", ls=":")
    ax.set_xlabel("final angle error against the ideal surface (deg)")
    ax.set_ylabel("seeds")
    ax.set_title(f"Rib errors at N = {int(ds.attrs['errors_N'])}: sigma_e = "
                 f"{float(ds.attrs['sigma_e']):g}, sigma_d = {float(ds.attrs['sigma_d_deg']):g} "
                 f"deg ({err.size} seeds)\nassumption: spline skin", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path, dpi=120)
    plt.close(fig)
    return path


def summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """The rib part's entry of the JSON report: ``ribs`` (the first surface's cases)."""
    out["ribs"] = ribs_section(ds, str(ds.surface.values[0]))


def answer(s: dict[str, Any]) -> str:
    """One answer fragment (empty without the rib part): the fewest ribs within spec and the
    fraction of rib-error draws within spec there."""
    r = s.get("ribs")
    if not r:
        return ""
    n = r["smallest_N_within_spec"]
    e = r["errors"]
    lo, hi = e["interval_95"]
    head = (f"{n} ribs are the fewest of {', '.join(str(c['N']) for c in r['cases'])} that keep "
            "the transport within spec" if n is not None
            else "no rib count tried keeps the transport within spec")
    return (f"{head}; with rib errors (sigma {num(100.0 * e['sigma_e'], '%')}, "
            f"{num(e['sigma_d_deg'], 'deg')}) at N = {e['N']}, "
            f"{num(100.0 * e['fraction_within_spec'], '%')} of {e['seeds']} seeds stay within spec "
            f"(95 % interval {num(100.0 * lo, digits=3)}-{num(100.0 * hi, '%', 3)})")


def section(ds: xr.Dataset | None, s: dict[str, Any], outdir: Path) -> list[str]:
    """The markdown of the rib surfaces with its two figures (empty without the rib part)."""
    r = s.get("ribs")
    if ds is None or not r:
        return []
    study = s["study"]
    transport = transport_figure(ds, outdir / f"{study}_ribs_transport.png")
    histogram = error_histogram(ds, outdir / f"{study}_rib_errors.png")
    refused = "; ".join(f"N = {x['N']}: {x['reason']}" for x in r["refused"])
    ideal = r["ideal"]
    rows = [[c["N"], c["shape_error_rel"], c["h0"], f"{c['largest_alias']['n']}: "
             f"{fmt(c['largest_alias']['h'])}", c["final_angle_deg"], c["final_radius_m"],
             c["W_surface_J"], c["min_normal_N"], c["dt_difference_m"],
             "yes" if c["within_spec"] else "no"] for c in r["cases"]]
    e = r["errors"]
    return ["## Actuator integration: the surface N ribs make", "",
            f"Assumption: {ASSUMPTION}.", "",
            f"Refused: {refused}.", "",
            f"Ideal surface ({ds.surface.values[0]}): final angle "
            f"{fmt(ideal['final_angle_deg'])} deg, radius {fmt(ideal['final_radius_m'])} m, "
            f"W_surface {fmt(ideal['W_surface_J'])} J, min N {fmt(ideal['min_normal_N'])} N.", "",
            *table(["N", "shape error (rel.)", "h0", "largest alias m: h", "final angle (deg)",
                    "final radius (m)", "W_surface (J)", "min N (N)", "dt vs dt/2 (m)",
                    "within spec"], rows), "",
            f"Smallest N within spec: {r['smallest_N_within_spec']}. Rib errors at N = "
            f"{e['N']} over {e['seeds']} seeds (sigma_e {fmt(e['sigma_e'])}, sigma_d "
            f"{fmt(e['sigma_d_deg'])} deg): {fmt(100.0 * e['fraction_within_spec'])} % within "
            f"spec, 95 % interval {fmt(100.0 * e['interval_95'][0])}-"
            f"{fmt(100.0 * e['interval_95'][1])} %.", "",
            f"![transport error against N]({transport.name})", "",
            f"![rib errors]({histogram.name})", ""]
