"""Reports of the kinematic studies (CT-02, EN-01): JSON contract, markdown with published vs
computed side by side, CSV table and the convergence figure (docs/studies.md).

JSON keys follow the report contract: ``fd_error`` and ``observed_order`` are nested
{derivative: {h: value}}, h written as Python writes the float (0.01, 0.0003, 1e-05); an
observed order is keyed by the finer step of its pair (order between the previous h and it).
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.model.numerics import observed_order
from creatio.reports.answer import answer_lines, num
from creatio.reports.common import (
    PUBLISHED_HEADER,
    RunCase,
    config_paragraph,
    config_title,
    h_key,
    nested,
    plt,
    published_row,
    run_case,
    save_figure,
    strict_json,
    table,
    write_markdown,
    write_text,
)
from creatio.store.atomic import atomic_write
from creatio.studies import registry

__all__ = ["PATTERN_LABELS", "kinematic_summary", "write_report"]

#: How the EN-01 pattern figures read in the report (their JSON keys are the contract's).
PATTERN_LABELS = {
    "pattern_max_rate_rad_s": "largest pattern rate |alpha_p'| (rad/s)",
    "pattern_max_rate_time_s": "time of the largest rate (s)",
    "pattern_travel_deg": "pattern travel over the cycle (deg)",
    "pattern_fd_error": "max |alpha_p' - central difference| (rad/s)",
}


def kinematic_summary(ds: xr.Dataset) -> dict[str, Any]:
    """The JSON report of CT-02 or EN-01 from its dataset."""
    study = ds.attrs["study"]
    hs = ds.h.values
    names = [str(d) for d in ds.derivative.values]
    if study == "ct02":
        fd = np.maximum(ds.fd_error.max("inclination").values, ds.fd_error_varying.values)
    else:
        fd = ds.fd_error.max("law").values
    keys = [h_key(h) for h in hs]
    order = observed_order(hs, fd)
    out: dict[str, Any] = {
        "study": study,
        "fd_error": nested(names, keys, fd),
        "observed_order": nested(names, keys[1:], order),
        "j_min": float(ds.attrs["j_lower_bound"]),
        "j_min_sampled": float(ds.j_min_sampled.min()),
    }

    def worst(name: str) -> float:
        values = [ds[name].max()]
        if f"{name}_varying" in ds:
            values.append(ds[f"{name}_varying"])
        return float(max(float(v) for v in values))

    out["j_identity_error"] = worst("j_identity_error")
    out["normal_tangent_dot"] = worst("normal_tangent_dot")
    out["normal_length_error"] = worst("normal_length_error")
    if study == "ct02":
        out["seam_closure"] = worst("seam_closure")
        out["feature_velocity_error"] = float(ds.feature_velocity_error.max())
        out["feature_acceleration_error"] = float(ds.feature_acceleration_error.max())
        out["pitch_error"] = float(np.abs(ds.pitch_formula - ds.pitch_measured).max())
        out["surface_class"] = {f"{float(g):g}": str(c) for g, c in
                                zip(ds.inclination.values, ds.surface_class.values, strict=True)}
    else:
        rate = np.abs(ds.pattern_rate.values)
        i = int(np.argmax(rate))
        out["pattern_max_rate_rad_s"] = float(rate[i])
        out["pattern_max_rate_time_s"] = float(ds.time.values[i])
        out["pattern_travel_deg"] = float(ds.pattern_angle.values[-1]
                                          - ds.pattern_angle.values[0])
        out["pattern_fd_error"] = float(np.abs(ds.pattern_rate - ds.pattern_rate_fd).max())
    out["config_sha256"] = ds.attrs.get("config_sha256", "")
    return out



def _fd_rows(summary: dict, pub: Mapping[str, Any]) -> tuple[list[str], list[list[Any]]]:
    published = pub.get("fd_error", {})
    names = list(summary["fd_error"])
    keys = list(summary["fd_error"][names[0]])
    header = ["h"]
    for n in names:
        header += [f"{n} computed", f"{n} order"]
        if published:
            header += [f"{n} published", f"{n} ratio"]
    rows = []
    for k in keys:
        row: list[Any] = [k]
        for n in names:
            e = summary["fd_error"][n][k]
            row += [e, summary["observed_order"][n].get(k, "")]
            if published:
                p = published[n].get(k, float("nan"))
                row += [p, e / p]
        rows.append(row)
    return header, rows


def _convergence_figure(summary: dict, study: str, path: Path, pub: Mapping[str, Any]) -> None:
    published = pub.get("fd_error", {})
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for n, errs in summary["fd_error"].items():
        hs = [float(k) for k in errs]
        (line,) = ax.loglog(hs, list(errs.values()), "o-", label=f"{n} computed")
        if published:
            pub = published[n]
            ax.loglog([float(k) for k in pub], list(pub.values()), "x--",
                      color=line.get_color(), alpha=0.6, label=f"{n} published")
    h = np.array([1e-2, 1e-4])
    ax.loglog(h, 1.5 * h**2, "k:", label="slope 2")
    ax.set_xlabel("finite-difference step h")
    ax.set_ylabel("max Euclidean error")
    ax.set_title(f"{study.upper()}: analytic derivatives vs central differences")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write <study>.json, .md (and its .html), _fd_error.csv and .png for a CT-02/EN-01
    dataset."""
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(datasets[0])
    study = ds.attrs["study"]
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    summary = kinematic_summary(ds)
    case = run_case(datasets, ds)
    # the notebook's figures belong to its own config: compared only on the published case
    pub = registry.get(study).published if case.published_case else {}
    summary.update(case.json())
    paths = {ext: outdir / f"{study}.{ext}" for ext in ("json", "md", "html", "png")}
    paths["csv"] = outdir / f"{study}_fd_error.csv"
    write_text(paths["json"], strict_json(summary))
    header, rows = _fd_rows(summary, pub)
    with atomic_write(paths["csv"], newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(rows)
    _convergence_figure(summary, study, paths["png"], pub)
    write_markdown(paths["md"], _kinematic_markdown(ds, summary, header, rows, paths, case, pub))
    return paths


#: The unit of each derivative's error and of its step, per study (CT-02 measures lengths
#: in the model unit u, docs/datasets.md; EN-01 in metres).
def _units(study: str) -> dict[str, str]:
    """Units of the kinematic figures: the study's length unit L (u or m) put in place."""
    L = "u" if study == "ct02" else "m"
    return {"c_R": "dimensionless", "c_alpha": f"{L}/rad", "c_t": f"{L}/s",
            "j_identity_error": L, "normal_tangent_dot": "dimensionless",
            "normal_length_error": "dimensionless", "j_min": L, "j_min_sampled": L,
            "seam_closure": L, "feature_velocity_error": f"{L}/s",
            "feature_acceleration_error": f"{L}/s^2", "pitch_error": L, "length": L}


def _unit_header(header: Sequence[str], study: str) -> list[str]:
    """The derivative table's header with a unit on every column."""
    u = _units(study)
    L = u["length"]
    out = []
    for h in header:
        name = h.split(" ")[0]
        if h == "h":
            out.append(f"h ({L} for c_R, rad for c_alpha, s for c_t)")
        elif h.endswith(("order", "ratio")):
            out.append(f"{h} (dimensionless)")
        else:
            out.append(f"{h} ({u.get(name, '?')})")
    return out


#: Steps at and above this are truncation-dominated: the observed order of the answer is
#: taken over them (below it the central difference's rounding error takes over).
TRUNCATION_H = 1e-4


def _geometry(ds: xr.Dataset) -> str:
    """The geometry the dataset was computed with, from its config (R0, dR, A)."""
    import yaml

    geo = (yaml.safe_load(str(ds.attrs.get("config_yaml", ""))) or {}).get("geometry", {})
    L = _units(str(ds.attrs["study"]))["length"]
    return ", ".join(f"{k} = {geo[k]:g} {L}" for k in ("R0", "dR", "A") if k in geo)


def _answer(ds: xr.Dataset, s: dict) -> list[str]:
    """The plain-word answer of a kinematic report, from its summary."""
    study = s["study"]
    u = _units(study)
    L = u["length"]
    orders = [o for n in s["observed_order"].values() for k, o in n.items()
              if float(k) >= TRUNCATION_H]
    lo, hi = min(orders), max(orders)
    at = h_key(TRUNCATION_H)
    errors = ", ".join(f"{n} {num(v.get(at), u[n])}" for n, v in s["fd_error"].items())
    right = "right" if 1.9 <= lo and hi <= 2.1 else "NOT confirmed"
    what = ("the analytic derivatives c_R, c_alpha, c_t of the surface map c(R, alpha, t) "
            f"against central differences at {len(next(iter(s['fd_error'].values())))} steps h, "
            f"over {ds.attrs.get('n_samples')} sample points"
            + (", every inclination gamma and a time-varying one" if study == "ct02"
               else ", over the EN-02 cycle's time laws") + "; the normal and J.")
    answer = [f"the derivatives are {right}: the error falls as h^2 (observed order "
              f"{lo:.3f} to {hi:.3f} for h >= {TRUNCATION_H:g}; at h = {at}: {errors}).",
              f"the normal is a unit vector to {num(s['normal_length_error'], 'dimensionless')} "
              f"and normal to the surface to {num(s['normal_tangent_dot'], 'dimensionless')}; "
              f"J stays at least {num(s['j_min_sampled'], L)}, above its bound R0 - A = "
              f"{num(s['j_min'], L)}."]
    if study == "en01":
        answer.append("the pattern turns "
                      f"{num(s['pattern_travel_deg'], 'deg')} over the cycle, fastest "
                      f"{num(s['pattern_max_rate_rad_s'], 'rad/s')} at "
                      f"{num(s['pattern_max_rate_time_s'], 's')}.")
    basis = (f"the dataset {study}.nc (config sha256 `{s['config_sha256'][:12]}`); "
             + (f"lengths in the notebook's model length unit u ({_geometry(ds)}), not "
                "metres." if study == "ct02" else f"lengths in metres ({_geometry(ds)})."))
    return answer_lines(what, answer, basis)


def _kinematic_markdown(ds: xr.Dataset, s: dict, header, rows, paths, case: RunCase,
                        pub: Mapping[str, Any]) -> str:
    study = s["study"]
    u = _units(study)
    lines = [config_title(ds, case), "", *_answer(ds, s), *config_paragraph(ds, case),
             "## Derivative check (max Euclidean error, analytic vs central difference)", "",
             f"Samples: {ds.attrs.get('n_samples')}. Observed order between the previous h "
             "and this one.", ""]
    lines += table(_unit_header(header, study), rows)
    if study == "en01" and pub:
        lines += ["", "Rows below h = 1e-4 are rounding-dominated. The angular sampling starts "
                  "at alpha = 0; the notebook does not state its own, and c_alpha / c_t come "
                  "out slightly below the published values (ratio column)."]
    lines += ["", f"![convergence]({paths['png'].name})", "", "## Regularity", ""]
    reg_pub = pub.get("regularity", {})
    reg = [
        ("max | J identity - |c_R x c_alpha| |", "j_identity_error"),
        ("max normalised normal-tangent dot", "normal_tangent_dot"),
        ("max | |n| - 1 |", "normal_length_error"),
        ("analytic lower bound of J (R0 - A)", "j_min"),
        ("smallest sampled J", "j_min_sampled"),
    ]
    if study == "ct02":
        reg += [("angular seam closure", "seam_closure")]
    reg = [(f"{label} ({u[key]})", key) for label, key in reg]
    compared = [published_row(label, s[key], reg_pub[key]) for label, key in reg
                if key in reg_pub]
    if compared:
        lines += ["Beside the notebook's figures: the rounding-noise ones compare by their "
                  "order of magnitude.", ""]
        lines += table(PUBLISHED_HEADER, compared) + ["", "Not in the notebook:", ""]
    lines += table(["figure", "computed"],
                   [(label, s[key]) for label, key in reg if key not in reg_pub])
    if study == "ct02":
        lines += ["", "## Cavity trajectories and pitch", ""]
        lines += table(["figure", "computed"], [
            (f"max |C' - central difference| ({u['feature_velocity_error']})",
             s["feature_velocity_error"]),
            (f"max |C'' - second difference| ({u['feature_acceleration_error']})",
             s["feature_acceleration_error"]),
            (f"max |pitch formula - displacement over one turn| ({u['pitch_error']})",
             s["pitch_error"]),
        ])
        lines += ["", "Surface class per inclination: " + ", ".join(
            f"{k} deg {v}" for k, v in s["surface_class"].items()) + ".",
            "", f"u is the notebook's model length unit: the CT-02 geometry is read in it "
            f"({_geometry(ds)}); it is not tied to metres."]
    else:
        lines += ["", "## Pattern velocity over the EN-02 cycle", ""]
        pattern = registry.get(study).published.get("pattern", {})
        if pub:
            lines += table(PUBLISHED_HEADER, [
                published_row(PATTERN_LABELS.get(k, k), s[k], v) for k, v in pattern.items()])
        else:
            lines += table(["figure", "computed"],
                           [(PATTERN_LABELS.get(k, k), s[k]) for k in pattern])
    return "\n".join(lines) + "\n"
