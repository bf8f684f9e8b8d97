"""Membrane strain, curvature change and stress that the prescribed surface demands (EN-06).

No membrane dynamics is solved: (alpha, R) label material points and the reference
configuration is the same surface without corrugation (W = 0, i.e. amplitude A = 0) at the
same inclination, whose metric is E0 = 1, F0 = 0, G0 = rho0^2 with rho0 = R0 + R cos(gamma)
(the flat annulus at gamma = 0). Tensors are symmetric 2 x 2 in the reference orthonormal frame
(e_R, e_alpha). Formulas (docs/materials.md, restated):

    eps    = 1/2 [[(E - E0) / E0, (F - F0) / sqrt(E0 G0)], [., (G - G0) / G0]]   (Green-Lagrange)
    dkappa =     [[(L - L0) / E0, (M - M0) / sqrt(E0 G0)], [., (N - N0) / G0]]
    faces  = eps -+ (h / 2) dkappa   (the face on the +n side takes the minus sign)

with L = c_RR . n, M = c_Ra . n, N = c_aa . n. The metric, second derivatives and normal
come from creatio.model.surface (the reference is the same Frame at A = 0), so every formula
of the surface lives there once. Vectorised NumPy over broadcastable (alpha, R, t).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from creatio.model.surface import Frame, Motion, Surface

__all__ = [
    "AreaBeyond",
    "Field",
    "Maximum",
    "Strains",
    "Sym2",
    "area_beyond",
    "curvature_change",
    "green_lagrange",
    "largest_face_strain",
    "maximum",
    "neo_hookean_stress",
    "reference",
    "strains",
    "stretches",
    "svk_stress",
]

Array = NDArray[np.float64]
#: A scalar field of the membrane at broadcastable (alpha, R, t).
Field = Callable[[Array, Array, Array], Array]


@dataclass(frozen=True)
class Sym2:
    """A symmetric 2 x 2 tensor field in the frame (e_R, e_alpha): components rr, ra, aa."""

    rr: Array
    ra: Array
    aa: Array

    def plus(self, other: Sym2, scale: float = 1.0) -> Sym2:
        """self + scale * other, componentwise."""
        return Sym2(self.rr + scale * other.rr, self.ra + scale * other.ra,
                    self.aa + scale * other.aa)

    def principal(self) -> tuple[Array, Array, Array]:
        """Principal values (first >= second) and the first one's angle from e_R (radians)."""
        mean = 0.5 * (self.rr + self.aa)
        radius = np.hypot(0.5 * (self.rr - self.aa), self.ra)
        angle = 0.5 * np.arctan2(2.0 * self.ra, self.rr - self.aa)
        return mean + radius, mean - radius, angle

    @property
    def trace(self) -> Array:
        """rr + aa."""
        return self.rr + self.aa


def reference(surface: Surface) -> Surface:
    """The reference configuration's surface: the same one without corrugation (A = 0)."""
    return dataclasses.replace(surface, A=0.0)


def _in_reference_frame(a: Array, b: Array, c: Array, ref: Frame) -> Sym2:
    """Coordinate components (RR, Ra, aa) of a form, expressed in the reference's
    orthonormal frame by the reference metric (E0, F0 = 0, G0)."""
    E0, _, G0 = ref.metric()
    return Sym2(a / E0, b / np.sqrt(E0 * G0), c / G0)


def green_lagrange(frame: Frame, ref: Frame) -> Sym2:
    """Green-Lagrange membrane strain 1/2 (I - I0) in the reference orthonormal frame."""
    E, F, G = frame.metric()
    E0, F0, G0 = ref.metric()
    return _in_reference_frame(0.5 * (E - E0), 0.5 * (F - F0), 0.5 * (G - G0), ref)


def _second_form(frame: Frame) -> tuple[Array, Array, Array]:
    """Second fundamental form (L, M, N) = (c_RR . n, c_Ra . n, c_aa . n)."""
    n = frame.normal
    return (np.sum(frame.c_RR * n, axis=-1), np.sum(frame.c_Ra * n, axis=-1),
            np.sum(frame.c_aa * n, axis=-1))


def curvature_change(frame: Frame, ref: Frame) -> Sym2:
    """Change of curvature II - II0 in the reference orthonormal frame (1 / length)."""
    L, M, N = _second_form(frame)
    L0, M0, N0 = _second_form(ref)
    return _in_reference_frame(L - L0, M - M0, N - N0, ref)


def stretches(eps1: ArrayLike, eps2: ArrayLike) -> tuple[Array, Array]:
    """Principal stretches lambda_i = sqrt(1 + 2 eps_i) from principal Green-Lagrange strains."""
    return np.sqrt(1.0 + 2.0 * np.asarray(eps1)), np.sqrt(1.0 + 2.0 * np.asarray(eps2))


@dataclass(frozen=True)
class Strains:
    """Membrane strain, bending strain (h / 2) dkappa and the two faces' strains at points.

    Principal pairs are (first >= second); ``angle`` is the membrane's first principal
    direction from e_R. ``upper`` is the face on the +n side (eps - (h/2) dkappa), ``lower``
    the other (eps + (h/2) dkappa).
    """

    membrane: Sym2
    dkappa: Sym2
    h: float

    @property
    def bending(self) -> Sym2:
        """Bending strain (h / 2) dkappa."""
        return Sym2(0.5 * self.h * self.dkappa.rr, 0.5 * self.h * self.dkappa.ra,
                    0.5 * self.h * self.dkappa.aa)

    @property
    def upper(self) -> Sym2:
        """Strain of the face on the +n side: eps - (h / 2) dkappa."""
        return self.membrane.plus(self.dkappa, -0.5 * self.h)

    @property
    def lower(self) -> Sym2:
        """Strain of the face on the -n side: eps + (h / 2) dkappa."""
        return self.membrane.plus(self.dkappa, 0.5 * self.h)

    def largest_face(self) -> Array:
        """Largest principal strain over both faces (the membrane's own when h = 0)."""
        return np.maximum(self.upper.principal()[0], self.lower.principal()[0])

    def membrane_stretches(self) -> tuple[Array, Array]:
        """Principal stretches (lambda1 >= lambda2) of the mid-surface."""
        e1, e2, _ = self.membrane.principal()
        return stretches(e1, e2)


def strains(surface: Surface, motion: Motion, alpha: ArrayLike, R: ArrayLike, t: ArrayLike,
            h: float = 0.0) -> Strains:
    """Strains of a sheet of thickness h on the moving surface at broadcastable (alpha, R, t)."""
    frame = Frame(surface, motion, alpha, R, t)
    ref = Frame(reference(surface), motion, alpha, R, t)
    return Strains(green_lagrange(frame, ref), curvature_change(frame, ref), float(h))


def largest_face_strain(surface: Surface, motion: Motion, h: float = 0.0) -> Field:
    """The field (alpha, R, t) -> largest principal face strain, for maximum and fatigue."""
    def field(alpha: Array, R: Array, t: Array) -> Array:
        return strains(surface, motion, alpha, R, t, h).largest_face()
    return field


def neo_hookean_stress(lam1: ArrayLike, lam2: ArrayLike, mu_s: float) -> tuple[Array, Array]:
    """Principal Cauchy stresses of an incompressible neo-Hookean membrane in plane stress:
    sigma_i = mu_s (lambda_i^2 - (lambda1 lambda2)^-2)."""
    l1, l2 = np.asarray(lam1, float), np.asarray(lam2, float)
    j2 = 1.0 / (l1 * l2) ** 2
    return mu_s * (l1**2 - j2), mu_s * (l2**2 - j2)


def svk_stress(eps: Sym2, E: float, nu: float) -> Sym2:
    """Saint Venant-Kirchhoff plane-stress second Piola-Kirchhoff stress
    S = E / (1 - nu^2) [(1 - nu) eps + nu tr(eps) I]."""
    scale = E / (1.0 - nu**2)
    tr = nu * eps.trace
    return Sym2(scale * ((1.0 - nu) * eps.rr + tr), scale * (1.0 - nu) * eps.ra,
                scale * ((1.0 - nu) * eps.aa + tr))


# ------------------------------------------------------------------ maximum over the membrane
@dataclass(frozen=True)
class Maximum:
    """The largest value of a field over the membrane and the times, where and when, and the
    grid that found it: the base grid (n_alpha x n_R x n_t), then local doublings (``levels``
    halvings of the spacing) around the best candidates down to (d_alpha, d_R, d_t).
    ``drop`` is the largest fall from the maximum to a neighbour at that spacing, relative:
    for a smooth interior peak at least 4 x the remaining error."""

    value: float
    alpha: float
    R: float
    t: float
    n_alpha: int
    n_R: int
    n_t: int
    levels: int
    d_alpha: float
    d_R: float
    d_t: float
    drop: float


#: Points per evaluated block of the base grid (memory: a few tens of float64 fields each).
_BLOCK = 400_000
#: Patch points per axis around a candidate (two each side of the centre).
_PATCH = np.arange(-2, 3, dtype=float)


def _base_candidates(field: Field, alpha: Array, R: Array, t: Array, keep: int
                     ) -> list[tuple[float, int, int, int]]:
    """The best `keep` base-grid points, more than two cells apart in some index."""
    per = max(1, _BLOCK // (alpha.size * R.size))
    best: list[tuple[float, int, int, int]] = []
    for start in range(0, t.size, per):
        tt = t[start:start + per]
        vals = field(alpha[None, :, None], R[None, None, :], tt[:, None, None])
        vals = np.broadcast_to(vals, (tt.size, alpha.size, R.size)).reshape(-1)
        top = min(vals.size, 64 * keep)
        idx = np.argpartition(-vals, top - 1)[:top]
        for flat in idx:
            k, i, j = np.unravel_index(flat, (tt.size, alpha.size, R.size))
            best.append((float(vals[flat]), int(i), int(j), int(start + k)))
    best.sort(key=lambda c: -c[0])
    chosen: list[tuple[float, int, int, int]] = []
    n_a = alpha.size
    for cand in best:
        if all(min(abs(cand[1] - c[1]), n_a - abs(cand[1] - c[1])) > 2
               or abs(cand[2] - c[2]) > 2 or abs(cand[3] - c[3]) > 2 for c in chosen):
            chosen.append(cand)
        if len(chosen) == keep:
            break
    return chosen


def _axis(centre: float, step: float, lo: float, hi: float) -> Array:
    """Patch coordinates along one axis: centre + step * (-2..2) clipped to [lo, hi], without
    repeats (a single point when step is 0)."""
    return np.unique(np.clip(centre + step * _PATCH, lo, hi))


def _at_edge(index: int, coords: Array, lo: float, hi: float) -> bool:
    """Whether the best point sits on the patch's edge with room to move beyond it."""
    if coords.size == 1:
        return False
    return (index == 0 and coords[0] > lo) or (index == coords.size - 1 and coords[-1] < hi)


def _climb(field: Field, start: tuple[float, float, float, float],
           spacing: tuple[float, float, float], bounds: tuple[float, float, float],
           rtol: float, max_levels: int) -> tuple[list[float], tuple[float, float, float], int,
                                                  float]:
    """Refine one candidate: a patch of up to 5 points per axis around it, recentred on its
    best point; the spacing halves whenever the best is not on the patch's edge, until the
    relative change between two halvings and the relative fall to the best point's
    neighbours are <= rtol."""
    value, a0, r0, t0 = start
    d_a, d_r, d_t = spacing
    dR, t_lo, t_hi = bounds
    levels, drop, previous = 0, math.inf, value
    for _ in range(8 * max_levels):
        a = a0 + d_a * _PATCH
        r = _axis(r0, d_r, 0.0, dR)
        tt = _axis(t0, d_t, t_lo, t_hi)
        vals = np.broadcast_to(field(np.mod(a, 2.0 * math.pi)[:, None, None], r[None, :, None],
                                     tt[None, None, :]), (a.size, r.size, tt.size))
        i, j, k = (int(x) for x in np.unravel_index(int(np.argmax(vals)), vals.shape))
        if vals[i, j, k] >= value:
            value, a0, r0, t0 = (float(vals[i, j, k]), float(np.mod(a[i], 2.0 * math.pi)),
                                 float(r[j]), float(tt[k]))
        if i in (0, a.size - 1) or _at_edge(j, r, 0.0, dR) or _at_edge(k, tt, t_lo, t_hi):
            continue
        near = [vals[i - 1, j, k], vals[i + 1, j, k]]
        near += [vals[i, jj, k] for jj in (j - 1, j + 1) if 0 <= jj < r.size]
        near += [vals[i, j, kk] for kk in (k - 1, k + 1) if 0 <= kk < tt.size]
        scale = max(abs(value), np.finfo(float).tiny)
        drop = float(value - min(near)) / scale
        change = abs(value - previous) / scale
        previous = value
        if (levels >= 1 and change <= rtol and drop <= rtol) or levels >= max_levels:
            break
        levels += 1
        d_a, d_r, d_t = 0.5 * d_a, 0.5 * d_r, 0.5 * d_t
    return [value, a0, r0, t0], (d_a, d_r, d_t), levels, drop


def maximum(field: Field, dR: float, times: ArrayLike, *, n_alpha: int = 256, n_R: int = 65,
            rtol: float = 1e-6, candidates: int = 4, max_levels: int = 40,
            refine_time: bool = True) -> Maximum:
    """Maximum of a field over R in [0, dR], alpha in [0, 2 pi) and the times (or, with
    refine_time, the interval they span), where and when.

    The base grid (alpha_i = 2 pi i / n_alpha, R_j = dR j / (n_R - 1), the times) locates the
    best `candidates` separated points; around each, a 5-point-per-axis patch is recentred
    on its best point and its spacing halved (doubling the grid there) until the maximum
    changes by at most rtol relative between two halvings and the fall to its neighbours at
    the final spacing is at most rtol relative (so a stalled centre is not taken for
    convergence). The base grid must resolve the field's features (a few points per
    wavelength); a candidate's time spacing is the larger gap of the times beside it."""
    t_all = np.unique(np.asarray(times, float))
    if t_all.size == 0 or n_alpha < 3 or n_R < 2:
        raise ValueError("maximum needs at least one time, n_alpha >= 3 and n_R >= 2")
    alpha = 2.0 * math.pi * np.arange(n_alpha) / n_alpha
    R = np.linspace(0.0, dR, n_R)
    gaps = np.diff(t_all)
    bounds = (dR, float(t_all[0]), float(t_all[-1]))
    results = []
    for value, i, j, k in _base_candidates(field, alpha, R, t_all, candidates):
        d_t = 0.0
        if refine_time and gaps.size:
            d_t = float(max(gaps[k - 1] if k > 0 else 0.0, gaps[k] if k < gaps.size else 0.0))
        spacing = (2.0 * math.pi / n_alpha, dR / (n_R - 1), d_t)
        results.append(_climb(field, (value, float(alpha[i]), float(R[j]), float(t_all[k])),
                              spacing, bounds, rtol, max_levels))
    (value, a, r, t), (d_a, d_r, d_t), levels, drop = max(results, key=lambda x: x[0][0])
    return Maximum(value=value, alpha=a, R=r, t=t, n_alpha=n_alpha, n_R=n_R,
                   n_t=int(t_all.size), levels=levels, d_alpha=d_a, d_R=d_r, d_t=d_t,
                   drop=drop)


# ------------------------------------------------------------------ beyond the ultimate strain
@dataclass(frozen=True)
class AreaBeyond:
    """Where a strain exceeds a limit: the fraction of the reference area at each time and
    at any time of the set, and the map (alpha x R cell centres) of points that ever do."""

    fraction: float
    per_time: Array
    mask: Array
    alpha: Array
    R: Array


def area_beyond(field: Field, surface: Surface, motion: Motion, limit: float,
                times: ArrayLike, n_alpha: int = 256, n_R: int = 64) -> AreaBeyond:
    """Reference-area fraction of the membrane where field > limit (a finding, not an error):
    midpoint rule on cell centres, each weighted by the reference area element rho0 dR dalpha
    (for the fraction at any time, by its mean over the times)."""
    t = np.atleast_1d(np.asarray(times, float))
    alpha = 2.0 * math.pi * (np.arange(n_alpha) + 0.5) / n_alpha
    R = surface.dR * (np.arange(n_R) + 0.5) / n_R
    ever = np.zeros((n_alpha, n_R), bool)
    w_sum = np.zeros((n_alpha, n_R))
    per_time = np.empty(t.size)
    for n, tn in enumerate(t):
        beyond = np.broadcast_to(field(alpha[:, None], R[None, :], np.asarray(tn)) > limit,
                                 ever.shape)
        w = np.broadcast_to(Frame(reference(surface), motion, alpha[:, None], R[None, :],
                                  tn).rho, ever.shape)
        per_time[n] = float(np.sum(w * beyond) / np.sum(w))
        ever |= beyond
        w_sum += w
    fraction = float(np.sum(w_sum * ever) / np.sum(w_sum)) if t.size else 0.0
    return AreaBeyond(fraction=fraction, per_time=per_time, mask=ever, alpha=alpha, R=R)
