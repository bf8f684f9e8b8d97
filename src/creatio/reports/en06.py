"""EN-06's report (docs/materials.md): what the membrane must be made of. From the study's
datasets (one per part, told apart by their ``part`` attribute) it writes ``en06.json``,
``.md`` and ``.html``, ``.png`` (the strain maps at the worst time), ``_envelope.png`` (the
strain envelopes along R), ``_fatigue.png`` (the damage maps and the life per material) and
``_tolerances.png`` (the Sobol' bars and the allocation: creatio.reports.en06_tolerances),
``_ribs_transport.png`` and ``_rib_errors.png`` (the rib surfaces: creatio.reports
.en06_ribs). Each part has its summary (SUMMARIES), and each later part its section, answer
fragment and figures (LATER_SECTIONS). Nothing here recomputes the study."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.colors import ListedColormap

from creatio.reports import en06_ribs as RIBS
from creatio.reports import en06_tolerances as TOL
from creatio.reports.answer import answer_lines, num
from creatio.reports.common import (
    fixed_layout,
    fmt,
    plt,
    save_figure,
    start_report,
    table,
    write_markdown,
)

__all__ = ["LATER_SECTIONS", "SUMMARIES", "en06_summary", "write_report"]


def _by_part(runs: Sequence[xr.Dataset]) -> dict[str, xr.Dataset]:
    """The datasets keyed by their part."""
    return {str(ds.attrs.get("part", "")): ds for ds in runs}


def _deg(x: float) -> float:
    return math.degrees(float(x))


def _strain_summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """Per surface: the maximum, where, when, the stretches and the grid; per material and
    surface: face strain, stress and the area beyond eps_u."""
    mats = [str(m) for m in ds.material.values]
    thick = ds.material_thickness.values
    face_m = int(np.argmax(thick))
    strain = {}
    for i, name in enumerate(str(s) for s in ds.surface.values):
        strain[name] = {
            "max_strain": float(ds.max_strain.values[i]),
            "R_m": float(ds.max_strain_R.values[i]),
            "alpha_deg": _deg(ds.max_strain_alpha.values[i]),
            "t_s": float(ds.worst_time.values[i]),
            "max_stretch": float(ds.max_stretch.values[i]),
            "min_stretch": float(ds.min_stretch.values[i]),
            "max_face_strain": float(ds.max_face_strain.values[face_m, i]),
            "face_material": mats[face_m],
            "face_thickness_m": float(thick[face_m]),
            "grid": {"n_alpha": int(ds.attrs["grid_n_alpha"]), "n_R": int(ds.attrs["grid_n_R"]),
                     "n_t": int(ds.attrs["grid_n_t"]), "rtol": float(ds.attrs["grid_rtol"]),
                     "levels": int(ds.grid_levels.values[i]),
                     "d_alpha_rad": float(ds.grid_d_alpha.values[i]),
                     "d_R_m": float(ds.grid_d_R.values[i]),
                     "d_t_s": float(ds.grid_d_t.values[i]),
                     "drop": float(ds.grid_drop.values[i])},
        }
    out["strain"] = strain
    materials = out.setdefault("materials", {})
    for j, m in enumerate(mats):
        entry = materials.setdefault(m, {})
        by = entry.setdefault("by_surface", {})
        for i, name in enumerate(str(s) for s in ds.surface.values):
            by.setdefault(name, {}).update({
                "max_face_strain": float(ds.max_face_strain.values[j, i]),
                "max_stress_Pa": float(ds.max_stress.values[j, i]),
                "stress_R_m": float(ds.max_stress_R.values[j, i]),
                "stress_alpha_deg": _deg(ds.max_stress_alpha.values[j, i]),
                "stress_t_s": float(ds.max_stress_t.values[j, i]),
                "beyond_ultimate_area_fraction": float(ds.beyond_ultimate_fraction.values[j, i]),
            })
        cells = list(by.values())
        entry.update({
            "thickness_m": float(thick[j]), "eps_u": float(ds.material_eps_u.values[j]),
            "max_stress_Pa": max(c["max_stress_Pa"] for c in cells),
            "max_force_N_per_m": max(c["max_stress_Pa"] for c in cells) * float(thick[j]),
            "max_face_strain": max(c["max_face_strain"] for c in cells),
            "beyond_ultimate_area_fraction": max(c["beyond_ultimate_area_fraction"]
                                                 for c in cells),
        })
    out["beyond_grid"] = {k: int(ds.attrs[f"beyond_{k}"]) for k in ("n_alpha", "n_R", "n_t")}
    out["assumptions"] = str(ds.attrs.get("assumptions", ""))


def _fatigue_summary(ds: xr.Dataset, out: dict[str, Any]) -> None:
    """Per material and surface: the damage's maximum, where, the life and the count there;
    per material the worst surface's; the closed-form check."""
    materials = out.setdefault("materials", {})
    names = [str(s) for s in ds.surface.values]
    for j, m in enumerate(str(x) for x in ds.material.values):
        entry = materials.setdefault(m, {})
        by = entry.setdefault("by_surface", {})
        for i, name in enumerate(names):
            dmg = ds.damage.values[j, i]
            by.setdefault(name, {}).update({
                "max_damage_per_transport": float(ds.max_damage.values[j, i]),
                "life_transport_cycles": float(ds.life.values[j, i]),
                "worst_R_m": float(ds.worst_R.values[j, i]),
                "worst_alpha_deg": _deg(ds.worst_alpha.values[j, i]),
                "cycles_per_transport_at_worst": float(ds.cycles_at_worst.values[j, i]),
                "failed_at_once_fraction": float(np.mean(np.isinf(dmg))),
            })
        worst = min(names, key=lambda n: by[n]["life_transport_cycles"])
        w = by[worst]
        entry.update({"life_transport_cycles": w["life_transport_cycles"],
                      "max_damage_per_transport": w["max_damage_per_transport"],
                      "worst_surface": worst, "worst_R_m": w["worst_R_m"],
                      "worst_alpha_deg": w["worst_alpha_deg"],
                      "cycles_per_transport_at_worst": w["cycles_per_transport_at_worst"]})
    lo, hi = float(ds.check_cycles_min.values), float(ds.check_cycles_max.values)
    out["fatigue_check"] = {
        "surface": str(ds.attrs.get("check_surface", "")),
        "cycles_per_point": lo if lo == hi else math.nan,
        "cycles_per_point_range": [lo, hi],
        "expected_cycles_per_point": float(ds.check_expected.values),
        "max_range_error": float(ds.check_range_error.values),
        "max_mean_error": float(ds.check_mean_error.values),
        "not_applicable": str(ds.attrs.get("check_not_applicable", "")),
    }
    out["fatigue_grid"] = {k: int(ds.attrs[f"grid_{k}"]) for k in ("n_alpha", "n_R", "n_t")}


#: Each part's summary: fills the report's JSON from that part's dataset.
SUMMARIES: dict[str, Callable[[xr.Dataset, dict[str, Any]], None]] = {
    "strain": _strain_summary, "fatigue": _fatigue_summary, **TOL.SUMMARIES,
    "ribs": RIBS.summary}


def _tolerance_section(parts: dict[str, xr.Dataset], s: dict[str, Any], outdir: Path
                       ) -> list[str]:
    """The tilt check and the tolerances: en06_tolerances.png and their markdown."""
    path = outdir / f"{s['study']}_tolerances.png"
    return TOL.section(parts, s, path if TOL.figure(parts, path) else None)


#: The sections after fatigue, in order: (markdown writer (datasets by part, summary, report
#: directory) -> lines, answer fragment (summary) -> text, '' for none): the tolerances,
#: then the rib surfaces.
LATER_SECTIONS: list[tuple[Callable[[dict[str, xr.Dataset], dict[str, Any], Path], list[str]],
                           Callable[[dict[str, Any]], str]]] = [
    (_tolerance_section, TOL.answer),
    (lambda parts, s, outdir: RIBS.section(parts.get("ribs"), s, outdir), RIBS.answer)]


def en06_summary(datasets: xr.Dataset | Sequence[xr.Dataset]) -> dict[str, Any]:
    """The JSON report of EN-06: strain per surface, materials, the fatigue check."""
    runs = [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)
    first = runs[0]
    out: dict[str, Any] = {"study": first.attrs.get("study", "en06")}
    for part, ds in _by_part(runs).items():
        if part in SUMMARIES:
            SUMMARIES[part](ds, out)
    out["config_sha256"] = first.attrs.get("config_sha256", "")
    order = ("study", "strain", "materials", "fatigue_check", "tilt_check", "tolerances",
             "ribs")
    return {**{k: out[k] for k in order if k in out},
            **{k: v for k, v in out.items() if k not in order}}


# ------------------------------------------------------------------------------ the answer
def _life_text(life: float | None) -> str:
    if life is None or not math.isfinite(life):
        return "unlimited" if life is not None and life > 0 else "not computed"
    return "0 (a cycle's mean strain reaches eps_u: it fails at once)" if life == 0.0 \
        else f"{num(life, digits=3)} transport cycles"


def _answer(s: dict[str, Any]) -> list[str]:
    """The plain-word opening: what was computed, the answer, what it rests on."""
    strain = s.get("strain", {})
    mats = s.get("materials", {})
    what = ("the largest strain the prescribed surfaces (" + ", ".join(strain) + ") demand of "
            "the membrane over the cycle, the stress and fatigue life that means for each "
            "material (" + ", ".join(mats) + "), and a closed-form check of the fatigue count.")
    peaks = "; ".join(
        f"{name}: {num(v['max_strain'])} at R = {num(v['R_m'], 'm')}, alpha = "
        f"{num(v['alpha_deg'], 'deg')}, t = {num(v['t_s'], 's')} (stretch "
        f"{num(v['max_stretch'])})" for name, v in strain.items())
    lines = [f"largest principal membrane strain {peaks}."]
    verdicts = []
    for m, v in mats.items():
        beyond = v.get("beyond_ultimate_area_fraction")
        part = f"{m}: {num(100.0 * beyond, '%', 3)} of the membrane beyond eps_u = " \
            f"{num(v.get('eps_u'))}" if beyond is not None else m
        if "life_transport_cycles" in v:
            part += f", life {_life_text(v['life_transport_cycles'])} on {v['worst_surface']}"
            failed = v["by_surface"][v["worst_surface"]]["failed_at_once_fraction"]
            if failed:
                part += f" at {num(100.0 * failed, '%', 3)} of the grid's points"
        verdicts.append(part)
    if verdicts:
        lines.append("; ".join(verdicts) + ".")
    later = [text for _, fragment in LATER_SECTIONS if (text := fragment(s))]
    if later:
        lines.append("; ".join(later) + ".")
    chk = s.get("fatigue_check")
    basis = ("material coordinates (the sheet follows the surface, reference = the surface "
             "without corrugation); illustrative materials, not measured")
    if chk and not chk["not_applicable"]:
        basis += (f"; the fatigue count reproduces the closed form on {chk['surface']} "
                  f"({fmt(chk['cycles_per_point'])} cycles per point, range and mean to "
                  f"{num(max(chk['max_range_error'], chk['max_mean_error']), digits=2)})")
    return answer_lines(what, lines, basis + ".")


# ---------------------------------------------------------------------------- the figures
def _strain_figure(ds: xr.Dataset, path: Path) -> None:
    """The strain maps (R x alpha) at each surface's worst time, the maximum marked."""
    n = ds.sizes["surface"]
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.4), squeeze=False)
    alpha = np.degrees(ds.alpha.values)
    for i, ax in enumerate(axes[0]):
        mesh = ax.pcolormesh(alpha, ds.R.values, ds.strain_map.values[i], shading="nearest",
                             cmap="viridis")
        ax.plot(_deg(ds.max_strain_alpha.values[i]), float(ds.max_strain_R.values[i]), "r+",
                ms=12, mew=2, label=f"maximum {fmt(float(ds.max_strain.values[i]))}")
        ax.set_xlabel("alpha (deg)")
        ax.set_ylabel("R (m)")
        ax.set_title(f"{ds.surface.values[i]}: t = {fmt(float(ds.worst_time.values[i]))} s",
                     fontsize=10)
        ax.legend(fontsize=8, loc="upper right")
        fig.colorbar(mesh, ax=ax, label="largest principal membrane strain (1)")
    fig.suptitle("EN-06: Green-Lagrange strain at the worst time (material coordinates)",
                 fontsize=10)
    fixed_layout(fig, 0.6, 0.2, 0.55, 0.55, wgap=1.3)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _envelope_figure(ds: xr.Dataset, path: Path) -> None:
    """The envelope along R of each surface, with each material's eps_u."""
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    for i, name in enumerate(ds.surface.values):
        ax.semilogy(ds.R.values, ds.strain_envelope.values[i], "-o", ms=3, lw=1.2,
                    label=f"{name} (max {fmt(float(ds.max_strain.values[i]))})")
    for j, m in enumerate(ds.material.values):
        ax.axhline(float(ds.material_eps_u.values[j]), ls="--", lw=0.9, color=f"C{j + 3}",
                   label=f"eps_u of {m} = {fmt(float(ds.material_eps_u.values[j]))}")
    ax.set_xlabel("R (m)")
    ax.set_ylabel("largest principal membrane strain over alpha and t (1)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title("EN-06: strain envelope along R (material coordinates)", fontsize=10)
    fixed_layout(fig, 0.8, 0.2, 0.55, 0.35)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _fatigue_figure(ds: xr.Dataset, path: Path) -> None:
    """log10 of the damage per transport cycle per material and surface (red: infinite, a
    cycle's mean strain reaches eps_u; white: no damage), and the life per material and
    surface."""
    mats, names = list(ds.material.values), list(ds.surface.values)
    nm, ns = len(mats), len(names)
    fig = plt.figure(figsize=(4.6 * ns + 4.2, 3.5 * nm))
    grid = fig.add_gridspec(nm, ns + 1)
    alpha = np.degrees(ds.alpha.values)
    cmap = plt.get_cmap("viridis").with_extremes(bad="white")
    red = ListedColormap(["tab:red"])
    for j, m in enumerate(mats):
        for i, name in enumerate(names):
            ax = fig.add_subplot(grid[j, i])
            dmg = ds.damage.values[j, i]
            finite = np.isfinite(dmg) & (dmg > 0)
            with np.errstate(divide="ignore", invalid="ignore"):
                log = np.where(finite, np.log10(dmg), np.nan)
            if finite.any():
                mesh = ax.pcolormesh(alpha, ds.R.values, log, shading="nearest", cmap=cmap)
                fig.colorbar(mesh, ax=ax, label="log10 damage per transport cycle")
            ax.pcolormesh(alpha, ds.R.values, np.ma.masked_where(~np.isinf(dmg), np.ones_like(dmg)),
                          shading="nearest", cmap=red)
            note = "" if finite.any() else " (infinite everywhere)"
            ax.set_title(f"{m}, {name}: life {_short_life(float(ds.life.values[j, i]))}{note}",
                         fontsize=9)
            ax.set_xlabel("alpha (deg)")
            ax.set_ylabel("R (m)")
    ax = fig.add_subplot(grid[:, ns])
    width = 0.8 / ns
    lives = ds.life.values
    positive = lives[np.isfinite(lives) & (lives > 0)]
    for i, name in enumerate(names):
        x = np.arange(nm) + (i - (ns - 1) / 2) * width
        life = lives[:, i]
        ax.bar(x, np.where(life > 0, life, np.nan), width, label=name, color=f"C{i}")
        for xi, v in zip(x, life, strict=True):
            text = "0: fails\nat once" if v == 0 else fmt(float(v))
            ax.annotate(text, (xi, 0.02 if v == 0 else 0.98), xycoords=("data", "axes fraction"),
                        ha="center", va="bottom" if v == 0 else "top", fontsize=7,
                        rotation=0 if v == 0 else 90)
    ax.set_yscale("log")
    if positive.size:
        ax.set_ylim(positive.min() / 10.0, positive.max() * 30.0)
    ax.set_xticks(np.arange(nm), [str(m) for m in mats])
    ax.set_xlim(-0.6, nm - 0.4)
    ax.set_ylabel("life (transport cycles)")
    ax.legend(fontsize=8, loc="upper right")
    ax.set_title("life per material (worst point)", fontsize=9)
    fig.suptitle("EN-06: fatigue damage per transport cycle (red: infinite, a cycle's mean "
                 "strain reaches eps_u); illustrative materials", fontsize=10)
    fixed_layout(fig, 0.6, 0.3, 0.55, 0.6, wgap=1.5, hgap=0.75)
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def _short_life(life: float) -> str:
    return "0 (fails at once)" if life == 0.0 else f"{fmt(life)} cycles"


# ------------------------------------------------------------------------ the markdown text
def _strain_section(ds: xr.Dataset, s: dict[str, Any], paths: dict[str, Path]) -> list[str]:
    lines = ["## Strain the surfaces demand", ""]
    head = ["surface", "max strain", "R (m)", "alpha (deg)", "t (s)", "stretch 1",
            "stretch 2", "max face strain", "base grid", "halvings", "final dR (m)",
            "final dt (s)", "drop"]
    rows = []
    for name, v in s["strain"].items():
        g = v["grid"]
        rows.append([name, v["max_strain"], v["R_m"], v["alpha_deg"], v["t_s"], v["max_stretch"],
                     v["min_stretch"], v["max_face_strain"],
                     f"{g['n_alpha']} x {g['n_R']} x {g['n_t']}", g["levels"], g["d_R_m"],
                     g["d_t_s"], g["drop"]])
    lines += table(head, rows)
    face = next(iter(s["strain"].values()))
    lines += ["", f"Membrane (Green-Lagrange) strain, the larger principal value; the maximum "
              f"is refined until it changes by at most {fmt(face['grid']['rtol'])} relative "
              f"between two halvings and its neighbours at the final spacing are within that. "
              f"The face strain is that of the thickest material ({face['face_material']}, "
              f"h = {fmt(face['face_thickness_m'])} m).", "",
              f"![strain maps]({paths['png'].name})", "",
              f"![strain envelopes]({paths['envelope'].name})", ""]
    return lines


def _materials_section(s: dict[str, Any]) -> list[str]:
    lines = ["## Materials (illustrative)", ""]
    head = ["material", "surface", "max face strain", "max stress (Pa)", "force (N/m)",
            "area beyond eps_u", "damage per transport", "life (transport cycles)",
            "worst R (m)", "worst alpha (deg)", "cycles per transport there"]
    rows = []
    for m, v in s["materials"].items():
        for name, c in v["by_surface"].items():
            rows.append([m, name, c.get("max_face_strain", math.nan),
                         c.get("max_stress_Pa", math.nan),
                         c.get("max_stress_Pa", math.nan) * v.get("thickness_m", math.nan),
                         c.get("beyond_ultimate_area_fraction", math.nan),
                         c.get("max_damage_per_transport", math.nan),
                         c.get("life_transport_cycles", math.nan),
                         c.get("worst_R_m", math.nan), c.get("worst_alpha_deg", math.nan),
                         c.get("cycles_per_transport_at_worst", math.nan)])
    lines += table(head, rows)
    lines += ["", "Stress: the larger principal stress of the membrane strain (neo-Hookean: "
              "Cauchy; SVK: second Piola-Kirchhoff); force = stress x unstrained thickness. "
              "The area beyond eps_u is the reference-area fraction where the larger face "
              "strain exceeds the material's ultimate strain at some time: a finding, not an "
              "error. Damage: rainflow of the periodic face-strain history and Miner's rule; "
              "an infinite damage (life 0) means a cycle's mean strain reaches eps_u.", ""]
    return lines


def _fatigue_section(s: dict[str, Any], paths: dict[str, Path]) -> list[str]:
    chk = s["fatigue_check"]
    lines = [f"![fatigue]({paths['fatigue'].name})", "", "## Fatigue count against the closed "
             "form", ""]
    if chk["not_applicable"]:
        return [*lines, f"Not applicable to {chk['surface']}: {chk['not_applicable']}.", ""]
    lo, hi = chk["cycles_per_point_range"]
    lines += table(["surface", "cycles per point (min, max)", "closed form",
                    "max range error", "max mean error"],
                   [[chk["surface"], f"{fmt(lo)}, {fmt(hi)}",
                     chk["expected_cycles_per_point"], chk["max_range_error"],
                     chk["max_mean_error"]]])
    lines += ["", "At h = 0 the strain at radius R swings between a = A^2 k^2 cos^2 u / 2 and "
              "b = A^2 (Ka / rho)^2 sin^2 u / 2 once per half-turn of v: |phi_a travel| / pi "
              "cycles at every point, of range |a - b| and mean (a + b) / 2 (times where phi_a "
              "is a multiple of pi / samples_per_half_turn, so every extreme is sampled).", ""]
    return lines


def write_report(datasets: Sequence[Path], outdir: str | Path) -> dict[str, Path]:
    """Write en06.json/.md/.html, en06.png, en06_envelope.png, en06_fatigue.png and the
    later sections' figures (en06_tolerances.png, en06_ribs_transport.png,
    en06_rib_errors.png)."""
    runs, s, paths = start_report(datasets, outdir, en06_summary)
    out = Path(outdir)
    paths = {"json": paths["json"], "md": paths["md"], "html": paths["html"],
             "png": paths["png"], "envelope": out / f"{s['study']}_envelope.png",
             "fatigue": out / f"{s['study']}_fatigue.png"}
    parts = _by_part(runs)
    first = runs[0]
    lines = [f"# {first.attrs.get('title', s['study'])}", "", *_answer(s),
             f"Config sha256 `{str(s['config_sha256'])[:12]}`, creatio "
             f"{first.attrs.get('creatio_version')}, commit "
             f"{str(first.attrs.get('git_commit', ''))[:10]}.", ""]
    if "strain" in parts:
        _strain_figure(parts["strain"], paths["png"])
        _envelope_figure(parts["strain"], paths["envelope"])
        lines += _strain_section(parts["strain"], s, paths)
    if "materials" in s:
        lines += _materials_section(s)
    if "fatigue" in parts:
        _fatigue_figure(parts["fatigue"], paths["fatigue"])
        lines += _fatigue_section(s, paths)
    for write, _ in LATER_SECTIONS:
        lines += write(parts, s, out)
    if {"sobol", "allocation"} & set(parts):
        paths["tolerances"] = out / f"{s['study']}_tolerances.png"
    lines += ["## Assumptions", "", f"{s.get('assumptions', '')}.", ""]
    write_markdown(paths["md"], "\n".join(lines))
    return paths
