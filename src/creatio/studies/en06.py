"""EN-06: what the membrane must be made of (docs/materials.md).

Part ``strain``: for each surface (EN-02, EN-02R) the largest principal membrane strain over
the membrane and the cycle (creatio.model.strain.maximum: where, when, the grid that found
it), its map over (R, alpha) at that time and its envelope along R (the largest over alpha
and the base grid's times); for each material and surface the largest principal face strain
at the material's thickness, the largest principal membrane stress (neo-Hookean Cauchy, or
Saint Venant-Kirchhoff second Piola-Kirchhoff), both located by the same refinement, and
the reference-area fraction beyond the material's eps_u (strain.area_beyond).

Part ``fatigue``: for each material and surface the damage per transport cycle over a grid
(creatio.model.fatigue.fatigue_map on the largest principal face strain at the material's
thickness), its largest value, where, the life in transport cycles and the rainflow count
there; and the closed-form check on one surface at h = 0 (docs/materials.md s.5): the
cycles counted at every point against |phi_a travel| / pi, their range against |a - b| and
their mean against (a + b) / 2.

Parts ``tilt``, ``sobol``, ``allocation`` and ``joint``: the energy check under a mounting
tilt and the tolerances of EN-02's transport (creatio.studies.en06_tolerances).

Assumptions (stated in every dataset): (alpha, R) are material coordinates, the reference is
the surface without corrugation, the sheet is thin, and the shipped materials are
illustrative. Every part is one entry of PART_RUNS, the rib surfaces' too (en06_ribs.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from creatio.model import fatigue as FT
from creatio.model import strain as S
from creatio.model.laws import Law, LawKind
from creatio.model.surface import Motion, Surface
from creatio.studies import en06_ribs as RIBS
from creatio.studies import en06_tolerances as TOL
from creatio.studies.en06_schema import En06Config
from creatio.studies.material_schema import MaterialConfig, MaterialLaw
from creatio.studies.registry import Part

__all__ = ["ASSUMPTIONS", "PARTS", "PART_RUNS", "check_dataset", "closed_form", "envelope",
           "fatigue_dataset", "motion_of", "parts", "phase_times", "ribs_dataset", "run",
           "strain_dataset",
           "stress_field"]

Array = NDArray[np.float64]

#: What every figure rests on, one line each (datasets' attrs and the report's opening).
ASSUMPTIONS = ("material coordinates: (alpha, R) label material points, the sheet does not "
               "slide; the reference is the same surface without corrugation (A = 0); "
               "thin sheet (Kirchhoff-Love faces); the shipped materials are illustrative, "
               "not measured")

#: Points per block when a field is evaluated over a whole base grid (as strain.maximum).
_BLOCK = 400_000


def parts(cfg: En06Config) -> list[Part]:
    """EN-06's datasets: one per part, each computed by its own job."""
    return [Part(f"en06_{name}", {"part": name}) for name in PARTS]


def run(cfg: En06Config, part: str) -> xr.Dataset:
    """One dataset of EN-06 (a name of PARTS)."""
    if part not in PART_RUNS:
        raise ValueError(f"part must be one of {', '.join(PARTS)}, got {part!r}")
    return PART_RUNS[part](cfg)


def motion_of(cfg: En06Config, name: str) -> tuple[Surface, Motion, float]:
    """The numeric surface, motion and cycle length T of one of the study's surfaces."""
    ph = cfg.study.surfaces[name]
    return cfg.geometry.surface(), Motion(*ph.laws()), float(ph.T)


def stress_field(surface: Surface, motion: Motion, mat: MaterialConfig) -> S.Field:
    """The field (alpha, R, t) -> largest principal membrane stress (Pa) of a material:
    neo-Hookean Cauchy from the principal stretches, or SVK second Piola-Kirchhoff."""
    law = MaterialLaw(mat.law)

    def field(alpha: Array, R: Array, t: Array) -> Array:
        st = S.strains(surface, motion, alpha, R, t)
        if law is MaterialLaw.neo_hookean:
            return S.neo_hookean_stress(*st.membrane_stretches(), float(mat.shear_modulus))[0]
        return S.svk_stress(st.membrane, float(mat.youngs_modulus),
                            float(mat.poisson)).principal()[0]
    return field


def envelope(field: S.Field, alpha: Array, R: Array, times: Array) -> Array:
    """The largest value over alpha and the times at each R (blocks of times, so that no
    more than about _BLOCK points are held at once)."""
    out = np.full(R.size, -np.inf)
    per = max(1, _BLOCK // (alpha.size * R.size))
    for start in range(0, times.size, per):
        tt = times[start:start + per]
        vals = np.broadcast_to(field(alpha[None, :, None], R[None, None, :], tt[:, None, None]),
                               (tt.size, alpha.size, R.size))
        out = np.maximum(out, vals.max(axis=(0, 1)))
    return out


def _maximum(field: S.Field, dR: float, times: Array, cfg: En06Config) -> S.Maximum:
    g = cfg.study.strain
    return S.maximum(field, dR, times, n_alpha=g.n_alpha, n_R=g.n_R, rtol=g.rtol,
                     candidates=g.candidates, max_levels=g.max_levels)


_GRID = ("levels", "d_alpha", "d_R", "d_t", "drop")
_GRID_UNITS = {"levels": "1", "d_alpha": "rad", "d_R": "m", "d_t": "s", "drop": "1"}


def strain_dataset(cfg: En06Config) -> xr.Dataset:
    """Part ``strain`` (module docstring): per surface the maximum, map and envelope; per
    material and surface the face strain's and the stress's maximum and the area beyond
    eps_u."""
    st = cfg.study
    g, b = st.strain, st.beyond
    names, mats = list(st.surfaces), list(st.materials)
    dR = float(cfg.geometry.dR)
    alpha = 2.0 * math.pi * np.arange(g.n_alpha) / g.n_alpha
    R = np.linspace(0.0, dR, g.n_R)
    alpha_c = 2.0 * math.pi * (np.arange(b.n_alpha) + 0.5) / b.n_alpha
    R_c = dR * (np.arange(b.n_R) + 0.5) / b.n_R
    ns, nm = len(names), len(mats)
    smap = np.empty((ns, g.n_R, g.n_alpha))
    env = np.empty((ns, g.n_R))
    peak = {k: np.empty(ns) for k in ("value", "alpha", "R", "t", "lam1", "lam2", *_GRID)}
    face = {k: np.empty((nm, ns)) for k in ("value", "alpha", "R", "t")}
    stress = {k: np.empty((nm, ns)) for k in ("value", "alpha", "R", "t")}
    beyond = np.empty((nm, ns))
    mask = np.zeros((nm, ns, b.n_R, b.n_alpha), np.int8)
    for i, name in enumerate(names):
        surface, motion, T = motion_of(cfg, name)
        times = np.linspace(0.0, T, g.n_t)
        membrane = S.largest_face_strain(surface, motion, 0.0)
        m = _maximum(membrane, dR, times, cfg)
        lam1, lam2 = S.strains(surface, motion, m.alpha, m.R, m.t).membrane_stretches()
        for key, value in (("value", m.value), ("alpha", m.alpha), ("R", m.R), ("t", m.t),
                           ("lam1", lam1), ("lam2", lam2), *((k, getattr(m, k)) for k in _GRID)):
            peak[key][i] = float(value)
        smap[i] = np.broadcast_to(membrane(alpha[None, :], R[:, None], np.asarray(m.t)),
                                  (g.n_R, g.n_alpha))
        env[i] = envelope(membrane, alpha, R, times)
        for j, mname in enumerate(mats):
            mat = st.materials[mname]
            faces = S.largest_face_strain(surface, motion, float(mat.thickness))
            for target, fld in ((face, faces), (stress, stress_field(surface, motion, mat))):
                mf = _maximum(fld, dR, times, cfg)
                for key in target:
                    target[key][j, i] = float(getattr(mf, key))
            ab = S.area_beyond(faces, surface, motion, float(mat.eps_u),
                               np.linspace(0.0, T, b.n_t), n_alpha=b.n_alpha, n_R=b.n_R)
            beyond[j, i] = ab.fraction
            mask[j, i] = ab.mask.T
    ds = xr.Dataset(coords={
        "surface": ("surface", names),
        "material": ("material", mats),
        "R": ("R", R, {"units": "m", "long_name": "radial material coordinate (base grid)"}),
        "alpha": ("alpha", alpha, {"units": "rad",
                                   "long_name": "angular material coordinate (base grid)"}),
        "R_cell": ("R_cell", R_c, {"units": "m", "long_name": "radial cell centre of the area "
                                   "beyond eps_u"}),
        "alpha_cell": ("alpha_cell", alpha_c, {"units": "rad", "long_name": "angular cell "
                                               "centre of the area beyond eps_u"})})
    one = "1"
    ds["strain_map"] = (("surface", "R", "alpha"), smap, {
        "units": one, "long_name": "largest principal membrane strain at the surface's worst "
        "time (worst_time)"})
    ds["strain_envelope"] = (("surface", "R"), env, {
        "units": one, "long_name": "largest principal membrane strain over alpha and the base "
        "grid's times"})
    ds["max_strain"] = ("surface", peak["value"], {
        "units": one, "long_name": "largest principal membrane strain over the membrane and "
        "the cycle (refined)"})
    ds["worst_time"] = ("surface", peak["t"], {"units": "s", "long_name": "time of max_strain"})
    ds["max_strain_R"] = ("surface", peak["R"], {"units": "m", "long_name": "R of max_strain"})
    ds["max_strain_alpha"] = ("surface", peak["alpha"], {"units": "rad",
                                                         "long_name": "alpha of max_strain"})
    ds["max_stretch"] = ("surface", peak["lam1"], {"units": one, "long_name": "first "
                                                   "principal stretch at max_strain"})
    ds["min_stretch"] = ("surface", peak["lam2"], {"units": one, "long_name": "second "
                                                   "principal stretch at max_strain"})
    for key in _GRID:
        ds[f"grid_{key}"] = ("surface", peak[key], {"units": _GRID_UNITS[key], "long_name":
                                                    f"refinement of max_strain: {key}"})
    pair = ("material", "surface")
    for prefix, src, unit, what in (("max_face_strain", face, one, "largest principal face "
                                     "strain at the material's thickness"),
                                    ("max_stress", stress, "Pa", "largest principal membrane "
                                     "stress")):
        ds[prefix] = (pair, src["value"], {"units": unit, "long_name": what})
        for key, u in (("R", "m"), ("alpha", "rad"), ("t", "s")):
            ds[f"{prefix}_{key}"] = (pair, src[key], {"units": u,
                                                      "long_name": f"{key} of {prefix}"})
    ds["beyond_ultimate_fraction"] = (pair, beyond, {
        "units": one, "long_name": "reference-area fraction where the largest principal face "
        "strain exceeds eps_u at some time"})
    ds["beyond_ultimate_mask"] = (("material", "surface", "R_cell", "alpha_cell"), mask, {
        "units": one, "long_name": "1 where the face strain exceeds eps_u at some time"})
    _material_vars(ds, cfg, mats)
    ds.attrs.update({
        "part": "strain",
        "assumptions": ASSUMPTIONS,
        "stress_law": "neo_hookean: principal Cauchy stress; svk: principal second "
                      "Piola-Kirchhoff stress; both of the membrane (mid-surface) strain",
        "grid_n_alpha": g.n_alpha, "grid_n_R": g.n_R, "grid_n_t": g.n_t, "grid_rtol": g.rtol,
        "grid_candidates": g.candidates, "beyond_n_alpha": b.n_alpha, "beyond_n_R": b.n_R,
        "beyond_n_t": b.n_t,
        "comment": "times over [0, T] with both ends; strain map at each surface's worst_time",
    })
    return ds


def _material_vars(ds: xr.Dataset, cfg: En06Config, mats: list[str]) -> None:
    """Each material's thickness and strain-life law, beside the figures that used them."""
    st = cfg.study
    for key, unit, what in (("thickness", "m", "sheet thickness h"),
                            ("eps_u", "1", "ultimate strain"),
                            ("eps_f", "1", "strain-life coefficient"),
                            ("c", "1", "strain-life exponent")):
        ds[f"material_{key}"] = ("material", [float(getattr(st.materials[m], key))
                                              for m in mats], {"units": unit, "long_name": what})


def phase_times(law: Law, T: float, per_half_turn: int) -> Array:
    """Times of one cycle where the law has travelled n pi / per_half_turn (n = 0, 1, ...,
    the last short of the full travel), by bisection on [0, T] of a law monotone there."""
    start, end = float(law(0.0).value), float(law(T).value)
    turns = round(abs(end - start) / math.pi)
    target = start + math.copysign(1.0, end - start) * np.arange(turns * per_half_turn) \
        * math.pi / per_half_turn
    lo, hi = np.zeros(target.size), np.full(target.size, T)
    rising = end > start
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        below = (law(mid).value < target) if rising else (law(mid).value > target)
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def closed_form(surface: Surface, phi_r: float, R: Array) -> tuple[Array, Array]:
    """The two strains EN-02's history swings between at radius R (gamma = 0, h = 0):
    a = A^2 k^2 cos^2 u / 2 and b = A^2 (Ka / rho)^2 sin^2 u / 2, u = k R + phi_r."""
    u = surface.k * R + phi_r
    a = 0.5 * surface.A**2 * surface.k**2 * np.cos(u) ** 2
    b = 0.5 * surface.A**2 * (surface.Ka / (surface.R0 + R)) ** 2 * np.sin(u) ** 2
    return a, b


def _check_applies(cfg: En06Config, name: str) -> str:
    """Why the closed form does not apply to a surface's phases ('' where it does)."""
    ph = cfg.study.surfaces[name]
    if ph.gamma.kind is not LawKind.constant or ph.gamma.phi0 != 0.0:
        return "the inclination is not 0"
    if ph.r.kind is not LawKind.constant:
        return "phi_r moves"
    law = ph.a.to_law(ph.T)
    sample = law(np.linspace(0.0, ph.T, 4097)).value
    d = np.diff(sample)
    if not (np.all(d > 0) or np.all(d < 0)):
        return "phi_a is not monotone over the cycle"
    turns = abs(float(sample[-1] - sample[0])) / math.pi
    if abs(turns - round(turns)) > 1e-9 or round(turns) < 1:
        return f"phi_a travels {turns:.6g} pi, not a whole number of half-turns"
    return ""


def check_dataset(cfg: En06Config) -> dict[str, float | str]:
    """The closed-form check (module docstring): counted cycles (min and max over the
    points), the expected count, the largest |range - |a - b|| and |mean - (a + b) / 2|
    over every counted cycle; NaN with the reason where the closed form does not apply."""
    fc = cfg.study.fatigue_check
    why = _check_applies(cfg, fc.surface)
    nan = math.nan
    out: dict[str, float | str] = {"cycles_min": nan, "cycles_max": nan, "expected": nan,
                                   "range_error": nan, "mean_error": nan, "reason": why}
    if why:
        return out
    surface, motion, T = motion_of(cfg, fc.surface)
    times = phase_times(motion.phi_a, T, fc.samples_per_half_turn)
    alpha = 2.0 * math.pi * np.arange(fc.n_alpha) / fc.n_alpha
    R = np.linspace(0.0, surface.dR, fc.n_R)
    hist = FT.history(S.largest_face_strain(surface, motion, 0.0), alpha, R, times)
    a, b = closed_form(surface, float(motion.phi_r(0.0).value), R)
    counts, range_err, mean_err = [], 0.0, 0.0
    for j in range(R.size):
        for i in range(alpha.size):
            cyc = FT.count_cycles(hist[i, j])
            counts.append(cyc.total)
            if cyc.count.size:
                range_err = max(range_err, float(np.max(np.abs(cyc.range - abs(a[j] - b[j])))))
                mean_err = max(mean_err, float(np.max(np.abs(cyc.mean - 0.5 * (a[j] + b[j])))))
    out.update(cycles_min=float(min(counts)), cycles_max=float(max(counts)),
               expected=float(times.size // fc.samples_per_half_turn),
               range_error=range_err, mean_error=mean_err)
    return out


def fatigue_dataset(cfg: En06Config) -> xr.Dataset:
    """Part ``fatigue`` (module docstring): damage maps per material and surface, their
    largest value, where, the life and the count there; and the closed-form check."""
    st = cfg.study
    fg = st.fatigue
    names, mats = list(st.surfaces), list(st.materials)
    dR = float(cfg.geometry.dR)
    alpha = 2.0 * math.pi * np.arange(fg.n_alpha) / fg.n_alpha
    R = np.linspace(0.0, dR, fg.n_R)
    nm, ns = len(mats), len(names)
    damage = np.empty((nm, ns, fg.n_R, fg.n_alpha))
    counts = np.empty_like(damage)
    figures = {k: np.empty((nm, ns)) for k in ("max_damage", "life", "R_max", "alpha_max",
                                                "cycles_at_worst")}
    for i, name in enumerate(names):
        surface, motion, T = motion_of(cfg, name)
        times = T * np.arange(fg.n_t) / fg.n_t
        for j, mname in enumerate(mats):
            mat = st.materials[mname]
            fm = FT.fatigue_map(S.largest_face_strain(surface, motion, float(mat.thickness)),
                                mat.strain_life(), alpha, R, times)
            damage[j, i], counts[j, i] = fm.damage.T, fm.cycles.T
            ia, ir = int(np.argmin(np.abs(alpha - fm.alpha_max))), int(
                np.argmin(np.abs(R - fm.R_max)))
            for key in ("max_damage", "life", "R_max", "alpha_max"):
                figures[key][j, i] = float(getattr(fm, key))
            figures["cycles_at_worst"][j, i] = float(fm.cycles[ia, ir])
    ds = xr.Dataset(coords={
        "surface": ("surface", names), "material": ("material", mats),
        "R": ("R", R, {"units": "m", "long_name": "radial material coordinate"}),
        "alpha": ("alpha", alpha, {"units": "rad", "long_name": "angular material coordinate"})})
    grid = ("material", "surface", "R", "alpha")
    pair = ("material", "surface")
    ds["damage"] = (grid, damage, {"units": "1", "long_name": "Miner damage per transport "
                                   "cycle (inf: a cycle's mean strain reaches eps_u)"})
    ds["cycles"] = (grid, counts, {"units": "1", "long_name": "rainflow cycles per transport "
                                   "cycle"})
    ds["max_damage"] = (pair, figures["max_damage"], {"units": "1", "long_name": "largest "
                                                      "damage per transport cycle"})
    ds["life"] = (pair, figures["life"], {"units": "1", "long_name": "life in transport "
                                          "cycles: 1 / max_damage"})
    ds["worst_R"] = (pair, figures["R_max"], {"units": "m", "long_name": "R of max_damage"})
    ds["worst_alpha"] = (pair, figures["alpha_max"], {"units": "rad",
                                                      "long_name": "alpha of max_damage"})
    ds["cycles_at_worst"] = (pair, figures["cycles_at_worst"], {
        "units": "1", "long_name": "rainflow cycles per transport cycle at the worst point"})
    _material_vars(ds, cfg, mats)
    chk = check_dataset(cfg)
    fc = st.fatigue_check
    for key, what in (("cycles_min", "fewest cycles counted at a point"),
                      ("cycles_max", "most cycles counted at a point"),
                      ("expected", "cycles per point of the closed form: |phi_a travel| / pi"),
                      ("range_error", "largest |range - |a - b|| of a counted cycle"),
                      ("mean_error", "largest |mean - (a + b) / 2| of a counted cycle")):
        ds[f"check_{key}"] = ((), float(chk[key]), {"units": "1", "long_name": what})
    ds.attrs.update({
        "part": "fatigue",
        "assumptions": ASSUMPTIONS,
        "grid_n_alpha": fg.n_alpha, "grid_n_R": fg.n_R, "grid_n_t": fg.n_t,
        "check_surface": fc.surface, "check_samples_per_half_turn": fc.samples_per_half_turn,
        "check_n_alpha": fc.n_alpha, "check_n_R": fc.n_R,
        "check_not_applicable": str(chk["reason"]),
        "comment": "largest principal face strain at each material's thickness; one period "
                   "of n_t times (the last not repeating the first); rainflow (ASTM E1049) "
                   "of the periodic history and Miner's rule",
    })
    return ds


#: The dataset parts of EN-06, in report order: name -> the function config -> dataset; each
#: is one job of the workflow.
def ribs_dataset(cfg: En06Config) -> xr.Dataset:
    """The rib part: EN-02's config (bases.en02) on the rib surfaces of study.ribs, with the
    study's surfaces and the tolerance parts' spec."""
    r, spec = cfg.study.ribs, cfg.study.tolerances.spec
    ds = RIBS.ribs_dataset(cfg.base, dict(cfg.study.surfaces), counts=r.counts,
                           refused=r.refused, errors_N=r.errors_N, seeds=r.seeds,
                           sigma_e=r.sigma_e, sigma_d_deg=r.sigma_d_deg,
                           angle_deg=spec.angle_deg, radius_m=spec.radius_m)
    ds.attrs.update({"part": "ribs", "assumptions": "spline skin: between the ribs the membrane "
                     "is the periodic quintic spline through them"})
    return ds


PART_RUNS: dict[str, Callable[[En06Config], xr.Dataset]] = {
    "strain": strain_dataset,
    "fatigue": fatigue_dataset,
    "tilt": TOL.tilt_dataset,
    "sobol": TOL.sobol_dataset,
    "allocation": TOL.allocation_dataset,
    "joint": TOL.joint_dataset,
    "ribs": ribs_dataset,
}
#: The part names, in report order.
PARTS = tuple(PART_RUNS)
