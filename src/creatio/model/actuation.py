"""What a prescribed cycle asks of the actuators (docs/model.md s.12.1).

Pure NumPy over the surface of creatio.model.surface (its material velocity c_t and
acceleration c_tt by :class:`~creatio.model.surface.Frame`'s formulas, on the quadrature's
grids with only the fields they use and the same numbers):

* the load: the power the membrane puts into the sphere, P_surface = (N n + f) . c_t at the
  contact point, from a run's recorded (t, R, alpha, N, f) (:func:`load_power`);
* the membrane itself, of areal density sigma per unit reference area
  (dm = sigma (R0 + R) dR dalpha): its kinetic energy K_m and the inertia, gravity and
  damping powers, by a tensor quadrature (trapezoid in alpha, Gauss-Legendre in R) refined
  until every integral is stable (:func:`membrane_integrals`, :func:`converge_quadrature`),
  checked by the closed form of the flat annulus (:func:`annulus_kinetic_energy`);
* the normal motion W: stroke, largest |W_t| and |W_tt| with their spatial closed forms
  (:func:`normal_rate_bounds`), numeric maxima over the surface and the cycle
  (:func:`normal_rate_maxima`), and the bandwidth (:func:`local_frequency`,
  :func:`energy_frequency`);
* every figure above along one run at once (:func:`actuation_demand`), for a prescribed
  cycle (the laws themselves) or a phase given as samples, the controlled phase of
  docs/model.md s.12.2 (:class:`SampledLaw`, :func:`sampled_motion`).

Nothing here runs a simulation: a study passes in the histories of one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from creatio.model.laws import L_AMPLITUDE, L_DELTA, L_PHI0, L_RATE, LawKind, LawValue
from creatio.model.surface import (
    Frame,
    Motion,
    Surface,
    Wave,
    acceleration_parts,
    ideal_W,
    ideal_W_t,
    ideal_W_tt,
    velocity_parts,
)

__all__ = [
    "INTEGRALS",
    "NM_FTOL",
    "POLISHED",
    "POWERS",
    "ActuationDemand",
    "Convergence",
    "MembraneIntegrals",
    "NormalExtrema",
    "Quadrature",
    "SampledLaw",
    "actuation_demand",
    "annulus_kinetic_energy",
    "angular_law_bounds",
    "converge_quadrature",
    "energy_frequency",
    "load_power",
    "local_frequency",
    "membrane_integrals",
    "normal_rate_bounds",
    "normal_rate_maxima",
    "power_figures",
    "quadrature",
    "refine_maximum",
    "sampled_motion",
    "time_integral",
    "time_maximum",
]

Array = NDArray[np.float64]

#: The membrane integrals, in the order of MembraneIntegrals' arrays and of the convergence
#: table: kinetic energy K_m and the inertia, gravity and damping powers.
INTEGRALS = ("kinetic", "inertia", "gravity", "damping")


@dataclass(frozen=True)
class Quadrature:
    """Nodes and weights of the reference annulus: sum(weight * f(alpha, R)) approximates
    int_0^2pi int_0^dR f (R0 + R) dR dalpha (the weight includes the area factor R0 + R)."""

    alpha: Array
    R: Array
    weight: Array

    @property
    def shape(self) -> tuple[int, int]:
        """(n_alpha, n_R)."""
        return self.weight.shape


def quadrature(surface: Surface, n_alpha: int, n_R: int) -> Quadrature:
    """The tensor rule: n_alpha equal steps in alpha (the trapezoid rule of a periodic
    integrand, exact for every harmonic below n_alpha) times n_R Gauss-Legendre nodes on
    [0, dR]."""
    if n_alpha < 1 or n_R < 1:
        raise ValueError(f"quadrature needs n_alpha, n_R >= 1, got {n_alpha}, {n_R}")
    alpha = 2.0 * math.pi * np.arange(n_alpha) / n_alpha
    x, w = np.polynomial.legendre.leggauss(n_R)
    half = 0.5 * surface.dR
    R = half * (x + 1.0)
    wR = half * w * (surface.R0 + R)
    weight = np.full(n_alpha, 2.0 * math.pi / n_alpha)[:, None] * wR[None, :]
    return Quadrature(alpha, R, weight)


def _laws_at(motion: Motion, t: ArrayLike, gamma: bool = True) -> tuple[LawValue, ...]:
    """The motion's laws at times t (phi_r, phi_a and, with ``gamma``, the inclination), each
    part an array (0-d at one time), as :class:`~creatio.model.surface.Wave` broadcasts them."""
    t = np.asarray(t, float)
    laws = (motion.phi_r, motion.phi_a, motion.gamma) if gamma else (motion.phi_r, motion.phi_a)
    return tuple(LawValue(*(np.asarray(x, float) for x in (v.value, v.d1, v.d2)))
                 for v in (law(t) for law in laws))


class _Normal:
    """W, W_t and W_tt of :class:`~creatio.model.surface.Wave` on the ideal surface, from
    the phases already evaluated at the times (:func:`_laws_at`): the same operations in the
    same order element by element, so the same numbers, but only the fields asked for, and
    each sine and cosine taken on the shape it depends on ((R, t) or (alpha, t)) before
    the products broadcast it (the membrane's grids are times x nodes)."""

    def __init__(self, surface: Surface, pr: LawValue, pa: LawValue, alpha: ArrayLike,
                 R: ArrayLike) -> None:
        self.A = surface.A
        self.u = surface.k * np.asarray(R, float) + pr.value
        self.v = surface.Ka * np.asarray(alpha, float) + pa.value
        self.pr, self.pa = pr, pa

    @cached_property
    def su(self) -> Array:
        """sin u, u = k R + phi_r."""
        return np.sin(self.u)

    @cached_property
    def cu(self) -> Array:
        """cos u."""
        return np.cos(self.u)

    @cached_property
    def sv(self) -> Array:
        """sin v, v = Ka alpha + phi_a."""
        return np.sin(self.v)

    @cached_property
    def cv(self) -> Array:
        """cos v."""
        return np.cos(self.v)

    @cached_property
    def W(self) -> Array:
        """W (creatio.model.surface.ideal_W)."""
        return ideal_W(self.A, self.su, self.cv)

    @cached_property
    def W_t(self) -> Array:
        """W_t (creatio.model.surface.ideal_W_t)."""
        return ideal_W_t(self.A, self.pr.d1, self.pa.d1, self.su, self.cu, self.sv, self.cv)

    @cached_property
    def W_tt(self) -> Array:
        """W_tt (creatio.model.surface.ideal_W_tt)."""
        return ideal_W_tt(self.A, self.pr.d1, self.pr.d2, self.pa.d1, self.pa.d2, self.su,
                          self.cu, self.sv, self.cv)


def _normal(surface: Surface, motion: Motion, alpha: ArrayLike, R: ArrayLike, t: ArrayLike,
            laws: tuple[LawValue, ...] | None = None) -> _Normal | Wave:
    """W and its time derivatives at (alpha, R, t): :class:`_Normal` on the ideal surface
    (``laws``: the phases at t when the caller has them), Wave itself on a rib skin."""
    if surface.ribs is not None:
        return Wave(surface, motion, alpha, R, t)
    pr, pa = laws[:2] if laws is not None else _laws_at(motion, t, gamma=False)
    return _Normal(surface, pr, pa, alpha, R)


def _combine(a: Array, u: Sequence[Array], b: Array, v: Sequence[Array]) -> Array:
    """The vector field a u + b v, shape a.shape + (3,), from the components of u and v
    (each broadcast against a): the surface frame's ``a[..., None] * u + b[..., None] * v``
    element by element, built one contiguous component at a time (three times faster than
    broadcasting into a last axis of length 3)."""
    out = np.empty(np.broadcast_shapes(np.shape(a), np.shape(b), *(np.shape(x) for x in u),
                                       *(np.shape(x) for x in v)) + (3,))
    for j in range(3):
        np.add(a * u[j], b * v[j], out=out[..., j])
    return out


class _Rates:
    """c_t and c_tt of :class:`~creatio.model.surface.Frame` on the ideal surface: Frame's
    formulas in its order, so the same numbers, but the frame vectors e_rho, e_z, e_g, e_n
    kept as components on the shape of (alpha, t), the phases' sines on those of (R, t) and
    (alpha, t) (:class:`_Normal`), and none of the fields c_t and c_tt do not use."""

    def __init__(self, surface: Surface, motion: Motion, alpha: ArrayLike, R: ArrayLike,
                 t: ArrayLike) -> None:
        pr, pa, gm = _laws_at(motion, t)
        alpha, self.R = np.asarray(alpha, float), np.asarray(R, float)
        self.w = _Normal(surface, pr, pa, alpha, self.R)
        sa, ca = np.sin(alpha), np.cos(alpha)
        sg, cg = np.sin(gm.value), np.cos(gm.value)
        self.dg, self.ddg = gm.d1, gm.d2
        e_rho = (ca, sa, 0.0 * ca)
        e_z = (0.0 * ca, 0.0 * ca, 1.0 + 0.0 * ca)
        self.e_g = [cg * x + sg * z for x, z in zip(e_rho, e_z, strict=True)]
        self.e_n = [-sg * x + cg * z for x, z in zip(e_rho, e_z, strict=True)]

    @cached_property
    def c_t(self) -> Array:
        """dc/dt (creatio.model.surface.velocity_parts on e_n and e_g)."""
        a, b = velocity_parts(self.w.W, self.w.W_t, self.R, self.dg)
        return _combine(a, self.e_n, b, self.e_g)

    @cached_property
    def c_tt(self) -> Array:
        """d2c/dt2 (creatio.model.surface.acceleration_parts on e_n and e_g)."""
        w = self.w
        a, b = acceleration_parts(w.W, w.W_t, w.W_tt, self.R, self.dg, self.ddg)
        return _combine(a, self.e_n, b, self.e_g)


def _material_rates(surface: Surface, motion: Motion, alpha: ArrayLike, R: ArrayLike,
                    t: ArrayLike) -> _Rates | Frame:
    """c_t and c_tt at (alpha, R, t), each computed when first asked for: :class:`_Rates`
    on the ideal surface, Frame itself on a rib skin."""
    if surface.ribs is not None:
        return Frame(surface, motion, alpha, R, t)
    return _Rates(surface, motion, alpha, R, t)


@dataclass(frozen=True)
class MembraneIntegrals:
    """The membrane integrals at times t (docs/model.md s.12.1), each shape t.shape:

    kinetic  K_m      = 1/2 sigma int |c_t|^2 dA          (J)
    inertia  P_inertia = sigma int c_t . c_tt dA = dK_m/dt (W)
    gravity  P_gravity = -sigma int g . c_t dA             (W, lifting the membrane)
    damping  P_damping = c_d int |c_t|^2 dA                (W)

    with dA = (R0 + R) dR dalpha; ``speed_square`` is int |c_t|^2 dA (m^4 s^-2), so that
    the damping power of any other c_d is c_d times it. ``scale`` holds, per integral, the
    same integral of the integrand's absolute value: what a relative change of the
    quadrature is measured against (an integral that vanishes, like the gravity power of the
    flat annulus, has a non-zero scale).
    """

    t: Array
    kinetic: Array
    inertia: Array
    gravity: Array
    damping: Array
    speed_square: Array
    scale: Array

    def values(self) -> Array:
        """The four integrals stacked along a last axis, in the order of INTEGRALS."""
        return np.stack([self.kinetic, self.inertia, self.gravity, self.damping], axis=-1)


def membrane_integrals(surface: Surface, motion: Motion, t: ArrayLike, rule: Quadrature,
                       sigma: float, c_d: float, g: float, chunk: int = 100_000
                       ) -> MembraneIntegrals:
    """K_m, P_inertia, P_gravity, P_damping at times t by the rule, in chunks of times of at
    most ``chunk`` nodes x times (arrays that stay in cache: four times faster than one
    pass here). Gravity is (0, 0, -g)."""
    t = np.atleast_1d(np.asarray(t, float))
    n_nodes = rule.weight.size
    step = max(1, chunk // n_nodes)
    out = np.empty((t.size, 4))
    scale = np.empty((t.size, 4))
    square = np.empty(t.size)
    a = rule.alpha[None, :, None]
    R = rule.R[None, None, :]
    w = rule.weight[None, :, :]
    for start in range(0, t.size, step):
        tt = t[start:start + step, None, None]
        rates = _material_rates(surface, motion, a, R, tt)
        ct, ctt = rates.c_t, rates.c_tt
        speed2 = np.einsum("...i,...i->...", ct, ct)
        power = np.einsum("...i,...i->...", ct, ctt)
        lift = g * ct[..., 2]  # -g_vec . c_t with g_vec = (0, 0, -g)
        sl = slice(start, start + tt.shape[0])
        out[sl, 0] = 0.5 * sigma * np.sum(w * speed2, axis=(1, 2))
        out[sl, 1] = sigma * np.sum(w * power, axis=(1, 2))
        out[sl, 2] = sigma * np.sum(w * lift, axis=(1, 2))
        square[sl] = np.sum(w * speed2, axis=(1, 2))
        out[sl, 3] = c_d * square[sl]
        scale[sl, 0] = out[sl, 0]
        scale[sl, 1] = sigma * np.sum(w * np.abs(power), axis=(1, 2))
        scale[sl, 2] = sigma * np.sum(w * np.abs(lift), axis=(1, 2))
        scale[sl, 3] = out[sl, 3]
    return MembraneIntegrals(t, out[:, 0], out[:, 1], out[:, 2], out[:, 3], square, scale)


def _kinetic_energy(surface: Surface, motion: Motion, t: ArrayLike, rule: Quadrature,
                    sigma: float, chunk: int = 100_000) -> Array:
    """K_m of :func:`membrane_integrals` alone (the same chunks and operations, without
    c_tt or the other integrals): what a search of K_m's largest value evaluates."""
    t = np.atleast_1d(np.asarray(t, float))
    step = max(1, chunk // rule.weight.size)
    out = np.empty(t.size)
    a = rule.alpha[None, :, None]
    R = rule.R[None, None, :]
    w = rule.weight[None, :, :]
    for start in range(0, t.size, step):
        tt = t[start:start + step, None, None]
        ct = _material_rates(surface, motion, a, R, tt).c_t
        speed2 = np.einsum("...i,...i->...", ct, ct)
        out[start:start + tt.shape[0]] = 0.5 * sigma * np.sum(w * speed2, axis=(1, 2))
    return out


@dataclass(frozen=True)
class Convergence:
    """The quadrature's own convergence: the grids tried, in order, and for each after the
    first the relative change of every integral from the grid before (NaN for the first).

    A relative change is max over t of |I_new - I_old| divided by max over t of the
    integral's scale (MembraneIntegrals.scale); an integral whose scale is zero (damping
    with c_d = 0) changes by 0. ``rule`` is the last grid, the one the study uses.
    """

    levels: tuple[tuple[int, int], ...]
    rel_change: Array
    rtol: float
    rule: Quadrature

    @property
    def converged(self) -> bool:
        """Whether the last refinement changed every integral by at most rtol."""
        return bool(len(self.levels) > 1 and np.all(self.rel_change[-1] <= self.rtol))

    @property
    def final_rel_change(self) -> float:
        """The largest relative change of the last refinement (NaN with a single grid)."""
        return float(np.max(self.rel_change[-1])) if len(self.levels) > 1 else math.nan


def _relative_change(new: MembraneIntegrals, old: MembraneIntegrals) -> Array:
    diff = np.max(np.abs(new.values() - old.values()), axis=0)
    scale = np.max(new.scale, axis=0)
    return np.where(scale > 0.0, diff / np.where(scale > 0.0, scale, 1.0), 0.0)


def converge_quadrature(surface: Surface, motion: Motion, t: ArrayLike, sigma: float,
                        c_d: float, g: float, n_alpha: int, n_R: int, rtol: float = 1e-10,
                        growth: float = 1.5, max_levels: int = 12) -> Convergence:
    """Refine the rule from (n_alpha, n_R), each count multiplied by ``growth`` and made odd
    per level, until one refinement changes every integral at times t by at most rtol
    (relative, see :class:`Convergence`) or max_levels grids were tried.

    Odd counts that are not nested keep two successive alpha grids from aliasing the same
    harmonic (a doubling sequence would integrate a harmonic that is a multiple of both
    counts equally wrongly, and look converged).
    """
    def odd(x: float) -> int:
        return 2 * int(round(x / 2.0)) + 1

    levels = [(odd(n_alpha), odd(n_R))]
    rule = quadrature(surface, *levels[0])
    prev = membrane_integrals(surface, motion, t, rule, sigma, c_d, g)
    changes = [np.full(4, math.nan)]
    while len(levels) < max_levels:
        na, nr = levels[-1]
        nxt = (max(odd(na * growth), na + 2), max(odd(nr * growth), nr + 2))
        rule_next = quadrature(surface, *nxt)
        cur = membrane_integrals(surface, motion, t, rule_next, sigma, c_d, g)
        changes.append(_relative_change(cur, prev))
        levels.append(nxt)
        rule, prev = rule_next, cur
        if np.all(changes[-1] <= rtol):
            break
    return Convergence(tuple(levels), np.array(changes), rtol, rule)


def _flat(motion: Motion) -> bool:
    """Whether the inclination law is identically zero (every coefficient 0)."""
    c = motion.gamma.coefficients()
    return bool(np.all(c[[L_PHI0, L_RATE, L_DELTA, L_AMPLITUDE]] == 0.0))


def annulus_kinetic_energy(surface: Surface, motion: Motion, t: ArrayLike, sigma: float
                           ) -> tuple[Array, Array]:
    """K_m and P_inertia = dK_m/dt of the flat annulus (gamma = 0 at all times) in closed
    form, for any radial and angular phase laws (docs/model.md s.12.1):

        K_m = (sigma pi A^2 / 2) [phi_r'^2 (M/2 + S) + phi_a'^2 (M/2 - S)]
        M = R0 dR + dR^2 / 2,   S = dR sin(2 phi_r) / (4 k)

    Raises ValueError for an inclination law that is not identically zero.
    """
    if not _flat(motion):
        raise ValueError("the closed form holds on the flat annulus only (gamma = 0)")
    pr, pa = motion.phi_r(t), motion.phi_a(t)
    A, k, R0, dR = surface.A, surface.k, surface.R0, surface.dR
    M = R0 * dR + 0.5 * dR * dR
    S = dR * np.sin(2.0 * pr.value) / (4.0 * k)
    dS = dR * pr.d1 * np.cos(2.0 * pr.value) / (2.0 * k)
    c = 0.5 * sigma * math.pi * A * A
    K = c * (pr.d1**2 * (0.5 * M + S) + pa.d1**2 * (0.5 * M - S))
    P = c * (2.0 * pr.d1 * pr.d2 * (0.5 * M + S) + 2.0 * pa.d1 * pa.d2 * (0.5 * M - S)
             + (pr.d1**2 - pa.d1**2) * dS)
    return np.asarray(K, float), np.asarray(P, float)


def load_power(surface: Surface, motion: Motion, t: ArrayLike, R: ArrayLike, alpha: ArrayLike,
               N: ArrayLike, f: ArrayLike) -> Array:
    """P_surface = (N n + f) . c_t at the contact points (R, alpha) at times t: the power the
    membrane delivers to the sphere (docs/model.md s.5), n and c_t evaluated there."""
    frame = Frame(surface, motion, alpha, R, t)
    force = np.asarray(N, float)[..., None] * frame.normal + np.asarray(f, float)
    return np.einsum("...i,...i->...", force, frame.c_t)


# ------------------------------------------------------------------------ normal motion W
def normal_rate_bounds(surface: Surface, motion: Motion, t: ArrayLike) -> tuple[Array, Array]:
    """max over the surface of |W_t| and of |W_tt| at each time t, in closed form.

    W_t = A x^T diag(phi_r', -phi_a') y and W_tt = A x^T M y with x = (cos u, sin u),
    y = (cos v, sin v) and M = [[phi_r'', -2 phi_r' phi_a'], [-(phi_r'^2 + phi_a'^2),
    -phi_a'']]. Over the annulus u covers whole periods (k dR = 2 pi Kr) independently of
    v, so each maximum is A times the largest singular value: A max(|phi_r'|, |phi_a'|) and
    A sigma_max(M). W does not depend on gamma, so this holds on every surface of the family.
    """
    return _rate_bounds(surface.A, motion.phi_r(t), motion.phi_a(t))


def _rate_bounds(A: float, pr: LawValue, pa: LawValue) -> tuple[Array, Array]:
    """:func:`normal_rate_bounds` from the phases already evaluated."""
    w_t = A * np.maximum(np.abs(pr.d1), np.abs(pa.d1))
    m11, m12 = pr.d2, -2.0 * pr.d1 * pa.d1
    m21, m22 = -(pr.d1**2 + pa.d1**2), -pa.d2
    fro = m11**2 + m12**2 + m21**2 + m22**2
    det = m11 * m22 - m12 * m21
    smax = np.sqrt(0.5 * (fro + np.sqrt(np.maximum(fro * fro - 4.0 * det * det, 0.0))))
    return np.asarray(w_t, float), np.asarray(A * smax, float)


#: The uniform sampling of :func:`time_maximum` before its refinement.
TIME_SAMPLES = 20001


def time_maximum(fun: Callable[[Array], Array], t0: float, t1: float,
                 samples: int = TIME_SAMPLES) -> tuple[float, float]:
    """(t*, max) of a smooth scalar function of time on [t0, t1]: the best of a uniform
    sampling, refined by :func:`refine_maximum`."""
    t = np.linspace(t0, t1, samples)
    return refine_maximum(fun, t, np.asarray(fun(t), float))


def refine_maximum(fun: Callable[[Array], Array], t: Array, values: Array,
                   xtol: float = 1e-13) -> tuple[float, float]:
    """(t*, max) of a smooth function sampled as values at increasing times t: golden-section
    search between the neighbours of the best sample (fun takes an array of times)."""
    i = int(np.argmax(values))
    lo, hi = float(t[max(i - 1, 0)]), float(t[min(i + 1, t.size - 1)])
    g = 0.5 * (math.sqrt(5.0) - 1.0)

    def f(x: float) -> float:
        return float(np.asarray(fun(np.array([x])), float)[0])

    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    fa, fb = f(a), f(b)
    while hi - lo > xtol * max(1.0, abs(hi)):
        if fa < fb:
            lo, a, fa = a, b, fb
            b = lo + g * (hi - lo)
            fb = f(b)
        else:
            hi, b, fb = b, a, fa
            a = hi - g * (hi - lo)
            fa = f(a)
    best = max((float(values[i]), float(t[i])), (fa, a), (fb, b))
    return best[1], best[0]


def angular_law_bounds(surface: Surface, motion: Motion) -> dict[str, float]:
    """Closed forms of the angular law (phi_r constant) over the cycle: the stroke, max |W_t|
    and max |W_tt| at the worst point, for a phase law phi0 + rate t + delta s(t / T)
    (constant, linear or quintic kinds; NaN for others or when phi_r moves).

    With phi_r constant, W = A sin u cos v at fixed (alpha, R), so the worst point has
    |sin u| = 1 and: stroke = A (range of cos over the swept phase) = 2 A sin(min(w, pi)/2)
    for a sweep of width w; max |W_t| = A max |phi_a'|; max |W_tt| = A max sqrt(phi_a'^4 +
    phi_a''^2), whose square is a polynomial in t over the cycle, maximised at the real
    roots of its derivative.
    """
    nan = {"stroke": math.nan, "max_W_t": math.nan, "max_W_tt": math.nan}
    r, a = motion.phi_r, motion.phi_a
    if r.kind not in (LawKind.constant,) or r.rate != 0.0 or r.delta != 0.0 \
            or r.amplitude != 0.0:
        return nan
    if a.kind not in (LawKind.constant, LawKind.linear, LawKind.quintic) or a.amplitude != 0.0:
        return nan
    A, T, D, w0 = surface.A, a.T, a.delta, a.rate
    if w0 != 0.0:  # the sweep grows without bound: every phase is swept
        width = math.inf
    else:
        width = abs(D)
    stroke = 2.0 * A * math.sin(0.5 * min(width, math.pi))
    P = np.polynomial.Polynomial
    tau = P([0.0, 1.0])
    d1 = w0 + D / T * 30.0 * tau**2 * (1.0 - tau) ** 2
    d2 = D / T**2 * 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)
    sq = d1**4 + d2**2
    candidates = [0.0, 1.0]
    for p in (d1 * d1, sq):
        roots = p.deriv().roots()
        candidates += [float(x.real) for x in roots if abs(x.imag) < 1e-12 and 0 < x.real < 1]
    c = np.array(candidates)
    return {"stroke": stroke, "max_W_t": A * float(np.sqrt(np.max(d1(c) ** 2))),
            "max_W_tt": A * float(np.sqrt(np.max(sq(c))))}


#: The maxima of :class:`NormalExtrema` that :func:`normal_rate_maxima` can polish.
POLISHED = ("stroke", "max_W_t", "max_W_tt")

#: The Nelder-Mead polish's default stop: the simplex's values within this relative spread.
NM_FTOL = 1e-15


@dataclass(frozen=True)
class NormalExtrema:
    """Numeric extrema of the normal motion W over the surface and a set of times.

    stroke: max over points of (max_t W - min_t W); max_W_t, max_W_tt: max over points and
    times of |W_t|, |W_tt|; ``worst`` is the (alpha, R) of the largest |W_t| (the point whose
    spectrum sets the bandwidth), ``stroke_point`` that of the stroke.
    """

    stroke: float
    stroke_point: tuple[float, float]
    max_W_t: float
    max_W_tt: float
    worst: tuple[float, float]


def normal_rate_maxima(surface: Surface, motion: Motion, t: ArrayLike, n_alpha: int,
                       n_R: int, polish: bool | Collection[str] = True,
                       ftol: float = NM_FTOL) -> NormalExtrema:
    """Stroke, max |W_t|, max |W_tt| over an (alpha, R) grid (n_alpha x n_R, both edges of
    [0, dR] included) and the times t, then each maximum polished by a local search in
    (alpha, R, t) (Nelder-Mead from the best grid point, stopping at relative spread ftol;
    the stroke's search is in (alpha, R) with the extremes over t taken on the samples).
    Independent of the closed forms. ``polish``: True (every maximum), False (none) or the
    names of POLISHED to polish; a caller skips those it does not use (the searches are
    independent, so the others are unchanged)."""
    polished = _polished(polish)
    t = np.atleast_1d(np.asarray(t, float))
    alpha = 2.0 * math.pi * np.arange(n_alpha) / n_alpha
    R = np.linspace(0.0, surface.dR, n_R)
    hi = np.full((n_alpha, n_R), -np.inf)
    lo = np.full((n_alpha, n_R), np.inf)
    best_t = np.zeros((n_alpha, n_R))
    best_wt = np.full((n_alpha, n_R), -np.inf)
    best_tt = (-np.inf, 0.0, 0.0, 0.0)
    step = max(1, 100_000 // (n_alpha * n_R))
    for start in range(0, t.size, step):
        tt = t[start:start + step]
        w = _normal(surface, motion, alpha[None, :, None], R[None, None, :], tt[:, None, None])
        hi = np.maximum(hi, w.W.max(axis=0))
        lo = np.minimum(lo, w.W.min(axis=0))
        awt = np.abs(w.W_t)
        i = np.argmax(awt, axis=0)
        cand = np.take_along_axis(awt, i[None], axis=0)[0]
        better = cand > best_wt
        best_wt = np.where(better, cand, best_wt)
        best_t = np.where(better, tt[i], best_t)
        awtt = np.abs(w.W_tt)
        j = np.unravel_index(int(np.argmax(awtt)), awtt.shape)
        if awtt[j] > best_tt[0]:
            best_tt = (float(awtt[j]), float(tt[j[0]]), float(alpha[j[1]]), float(R[j[2]]))
    rng = hi - lo
    si = np.unravel_index(int(np.argmax(rng)), rng.shape)
    wi = np.unravel_index(int(np.argmax(best_wt)), best_wt.shape)
    stroke = float(rng[si])
    stroke_point = (float(alpha[si[0]]), float(R[si[1]]))
    max_wt = float(best_wt[wi])
    worst = (float(alpha[wi[0]]), float(R[wi[1]]))
    max_wtt = best_tt[0]
    t0, t1 = float(t[0]), float(t[-1])
    laws = None if surface.ribs is not None else _laws_at(motion, t, gamma=False)

    def at(x: Sequence[float], name: str) -> float:
        a_, r_, s_ = x
        if not (0.0 <= r_ <= surface.dR and t0 <= s_ <= t1):
            return 0.0
        return float(abs(getattr(_normal(surface, motion, a_, r_, s_), name)))

    def span(x: Sequence[float]) -> float:
        a_, r_ = x
        if not 0.0 <= r_ <= surface.dR:
            return 0.0
        w = _normal(surface, motion, a_, r_, t, laws).W
        return float(w.max() - w.min())

    if "max_W_t" in polished:
        x, max_wt = _nelder_mead(lambda x: at(x, "W_t"),
                                 [worst[0], worst[1], float(best_t[wi])], max_wt, ftol)
        worst = (float(x[0]), float(x[1]))
    if "max_W_tt" in polished:
        _, max_wtt = _nelder_mead(lambda x: at(x, "W_tt"),
                                  [best_tt[2], best_tt[3], best_tt[1]], max_wtt, ftol)
    if "stroke" in polished:
        x, stroke = _nelder_mead(span, list(stroke_point), stroke, ftol)
        stroke_point = (float(x[0]), float(x[1]))
    return NormalExtrema(stroke, stroke_point, max_wt, max_wtt, worst)


def _polished(polish: bool | Collection[str]) -> frozenset[str]:
    """The maxima of NormalExtrema that ``polish`` asks to polish (True: all, False: none)."""
    if polish is True or polish is False:
        return frozenset(POLISHED) if polish else frozenset()
    names = frozenset(polish)
    unknown = sorted(names - set(POLISHED))
    if unknown:
        raise ValueError(f"polish names {unknown} are not maxima of NormalExtrema; known: "
                         f"{', '.join(POLISHED)}")
    return names


def _nelder_mead(fun: Callable[[Sequence[float]], float], x0: list[float], f0: float,
                 ftol: float = NM_FTOL) -> tuple[list[float], float]:
    """Maximise fun from x0 (a plain Nelder-Mead, relative steps 1e-2, stopping when the
    simplex's values spread by at most ftol relative): the better of the search's result
    and the start."""
    n = len(x0)
    pts = [np.array(x0, float)]
    for i in range(n):
        p = np.array(x0, float)
        p[i] += 1e-2 * max(abs(p[i]), 1e-2)
        pts.append(p)
    vals = [-fun(p) for p in pts]
    for _ in range(400 * n):
        order = np.argsort(vals)
        pts = [pts[i] for i in order]
        vals = [vals[i] for i in order]
        if abs(vals[-1] - vals[0]) <= ftol * max(1.0, abs(vals[0])):
            break
        centre = np.mean(pts[:-1], axis=0)
        xr = centre + (centre - pts[-1])
        fr = -fun(xr)
        if fr < vals[0]:
            xe = centre + 2.0 * (centre - pts[-1])
            fe = -fun(xe)
            pts[-1], vals[-1] = (xe, fe) if fe < fr else (xr, fr)
        elif fr < vals[-2]:
            pts[-1], vals[-1] = xr, fr
        else:
            xc = centre + 0.5 * (pts[-1] - centre)
            fc = -fun(xc)
            if fc < vals[-1]:
                pts[-1], vals[-1] = xc, fc
            else:
                pts = [pts[0] + 0.5 * (p - pts[0]) for p in pts]
                vals = [-fun(p) for p in pts]
    i = int(np.argmin(vals))
    if -vals[i] > f0:
        return list(pts[i]), -vals[i]
    return x0, f0


def local_frequency(motion: Motion, t: ArrayLike) -> Array:
    """The highest local frequency of W at times t (Hz): W = (A/2)[sin(u + v) + sin(u - v)]
    at a fixed point turns at |phi_r' +- phi_a'|, so (|phi_r'| + |phi_a'|) / (2 pi)."""
    return _local_frequency(motion.phi_r(t), motion.phi_a(t))


def _local_frequency(pr: LawValue, pa: LawValue) -> Array:
    """:func:`local_frequency` from the phases already evaluated."""
    return np.asarray((np.abs(pr.d1) + np.abs(pa.d1)) / (2.0 * math.pi), float)


def energy_frequency(signal: ArrayLike, dt: float, fraction: float = 0.99, pad: int = 8
                     ) -> float:
    """The frequency (Hz) below which ``fraction`` of a sampled signal's energy lies.

    The signal is taken as zero outside its samples (a transient: the membrane is still
    before and after the cycle) and zero-padded to ``pad`` times its length, so the energy
    spectrum |X(f)|^2 is sampled every 1 / (pad x duration); the one-sided energy is
    accumulated bin by bin (Parseval) and the first bin reaching the fraction is returned.
    """
    x = np.asarray(signal, float)
    n = pad * x.size
    spec = np.abs(np.fft.rfft(x, n)) ** 2
    weight = np.full(spec.size, 2.0)
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    energy = np.cumsum(weight * spec)
    if energy[-1] <= 0.0:
        return 0.0
    i = int(np.searchsorted(energy, fraction * energy[-1]))
    return float(np.fft.rfftfreq(n, dt)[min(i, spec.size - 1)])


# ------------------------------------------------------------------ along a run, any phase
@dataclass(frozen=True, eq=False)
class SampledLaw:
    """A phase given by samples instead of a formula: increasing times t and, at each, the
    value and its first and second time derivatives (the controlled phi_a of a run:
    phi_a, phidot_a and u = phiddot_a, docs/model.md s.12.2).

    Called like a :class:`~creatio.model.laws.Law`, so that every formula of this module
    takes it in a :class:`~creatio.model.surface.Motion`. At a sample time it returns the
    sample exactly; between samples the value and the rate are cubic Hermite interpolants
    (value with rate, rate with acceleration) and the acceleration is linear, so that a
    maximum refined between samples sees a smooth phase; times outside [t[0], t[-1]] are
    clamped to the ends.
    """

    t: Array
    value: Array
    d1: Array
    d2: Array

    def __post_init__(self) -> None:
        arrays = [np.asarray(x, float) for x in (self.t, self.value, self.d1, self.d2)]
        if arrays[0].ndim != 1 or arrays[0].size == 0:
            raise ValueError("a sampled law needs a 1-D, non-empty array of times")
        if any(a.shape != arrays[0].shape for a in arrays[1:]):
            raise ValueError("a sampled law needs one value, rate and acceleration per time")
        if np.any(np.diff(arrays[0]) <= 0.0) or not np.all(np.isfinite(arrays)):
            raise ValueError("a sampled law needs finite samples at increasing times")
        for name, a in zip(("t", "value", "d1", "d2"), arrays, strict=True):
            object.__setattr__(self, name, a)

    def __call__(self, t: ArrayLike) -> LawValue:
        """Value, first and second derivative at times t (any shape)."""
        t = np.asarray(t, float)
        ts = self.t
        if ts.size == 1:
            return LawValue(self.value[0] + 0.0 * t, self.d1[0] + 0.0 * t, self.d2[0] + 0.0 * t)
        if t.ndim == 0 and math.isfinite(t):
            # one time (a local search's): np.clip's and np.searchsorted's results without
            # their array machinery (the call 2.5 times faster); the formulas below are shared
            x = t[()]
            x = x if x > ts[0] else ts[0]
            x = x if x < ts[-1] else ts[-1]
            i = min(max(int(ts.searchsorted(x, side="right")) - 1, 0), ts.size - 2)
        else:
            x = np.clip(t, ts[0], ts[-1])
            i = np.clip(np.searchsorted(ts, x, side="right") - 1, 0, ts.size - 2)
        h = ts[i + 1] - ts[i]
        s = (x - ts[i]) / h
        # cubic Hermite basis: exactly (1, 0, 0, 0) at s = 0 and (0, 0, 1, 0) at s = 1
        h00 = (1.0 + 2.0 * s) * (1.0 - s) ** 2
        h10 = s * (1.0 - s) ** 2
        h01 = s * s * (3.0 - 2.0 * s)
        h11 = s * s * (s - 1.0)
        v, d1, d2 = self.value, self.d1, self.d2
        value = h00 * v[i] + h10 * h * d1[i] + h01 * v[i + 1] + h11 * h * d1[i + 1]
        rate = h00 * d1[i] + h10 * h * d2[i] + h01 * d1[i + 1] + h11 * h * d2[i + 1]
        acc = (1.0 - s) * d2[i] + s * d2[i + 1]
        return LawValue(value, rate, acc)


def sampled_motion(motion: Motion, t: ArrayLike, phi_a: ArrayLike, phidot_a: ArrayLike,
                   phiddot_a: ArrayLike) -> Motion:
    """motion with its angular phase replaced by samples (a controlled run's phi_a, its rate
    and u); the radial phase and the inclination keep their laws."""
    return Motion(motion.phi_r, SampledLaw(t, phi_a, phidot_a, phiddot_a), motion.gamma)


#: The powers of docs/model.md s.12.1, in the order :meth:`ActuationDemand.powers` gives them.
POWERS = ("P_surface", "P_inertia", "P_gravity", "P_damping", "P_actuator")


@dataclass(frozen=True)
class ActuationDemand:
    """The figures of docs/model.md s.12.1 along one run: the powers at its sample times t,
    the membrane integrals (K_m and the rest), the largest K_m refined between samples, the
    normal motion's extrema over the grid, its closed-form maxima over the span, and the
    bandwidth (the largest local frequency, and the 99 %-energy frequency of W_t at the
    worst point, ``W_t_worst`` on the grid)."""

    t: Array
    P_surface: Array
    integrals: MembraneIntegrals
    P_actuator: Array
    K_m_max: float
    K_m_max_time: float
    extrema: NormalExtrema
    max_W_t_closed_form: float
    max_W_tt_closed_form: float
    grid: Array
    W_t_worst: Array
    bandwidth: float
    bandwidth99: float

    def powers(self) -> dict[str, Array]:
        """Each power of POWERS at the sample times (W)."""
        mi = self.integrals
        return {"P_surface": self.P_surface, "P_inertia": mi.inertia, "P_gravity": mi.gravity,
                "P_damping": mi.damping, "P_actuator": self.P_actuator}


def actuation_demand(surface: Surface, motion: Motion, t: ArrayLike, P_surface: ArrayLike,
                     rule: Quadrature, sigma: float, c_d: float, g: float, *,
                     grid: ArrayLike | None = None, sample_interval: float | None = None,
                     span: tuple[float, float] | None = None,
                     extrema: tuple[int, int] = (48, 33), energy_fraction: float = 0.99,
                     polish: bool | Collection[str] = True, xtol: float = 1e-13,
                     ftol: float = NM_FTOL) -> ActuationDemand:
    """What the actuators deliver along one run whose surface moves by ``motion`` (its laws,
    or a controlled phase by :func:`sampled_motion`), from the load power P_surface the run
    put into the sphere at its sample times t (:func:`load_power`).

    The membrane integrals by ``rule`` at t, P_actuator = P_surface + P_inertia + P_gravity
    + P_damping, the largest K_m refined between samples (:func:`refine_maximum` to ``xtol``
    s: a sampled phase is itself known to far less than the default); the normal
    motion's numeric extrema on ``grid`` (default t; ``extrema`` is the (alpha, R) start
    grid, ``polish`` and ``ftol`` the local search of :func:`normal_rate_maxima`), the
    closed-form maxima of |W_t| and |W_tt| and the largest local frequency over ``span``
    (default the grid's ends) by :func:`time_maximum`, and the energy frequency of W_t at
    the worst point on the grid, spaced ``sample_interval`` (default the grid's mean step).
    """
    t = np.atleast_1d(np.asarray(t, float))
    P_s = np.asarray(P_surface, float)
    grid_t = t if grid is None else np.atleast_1d(np.asarray(grid, float))
    if sample_interval is None:
        sample_interval = (float(grid_t[-1] - grid_t[0]) / (grid_t.size - 1)
                           if grid_t.size > 1 else 1.0)
    t0, t1 = span if span is not None else (float(grid_t[0]), float(grid_t[-1]))
    mi = membrane_integrals(surface, motion, t, rule, sigma, c_d, g)
    P_act = P_s + mi.inertia + mi.gravity + mi.damping

    def K_quad(x: Array) -> Array:
        return _kinetic_energy(surface, motion, x, rule, sigma)

    t_K, K_max = (refine_maximum(K_quad, t, mi.kinetic, xtol) if t.size
                  else (math.nan, math.nan))
    ex = normal_rate_maxima(surface, motion, grid_t, extrema[0], extrema[1], polish, ftol)
    # the three time maxima (time_maximum's) share the phases on their common sampling
    ts = np.linspace(t0, t1, TIME_SAMPLES)
    pr, pa = motion.phi_r(ts), motion.phi_a(ts)
    bounds = _rate_bounds(surface.A, pr, pa)
    _, wt_cf = refine_maximum(lambda x: normal_rate_bounds(surface, motion, x)[0], ts,
                              np.asarray(bounds[0], float))
    _, wtt_cf = refine_maximum(lambda x: normal_rate_bounds(surface, motion, x)[1], ts,
                               np.asarray(bounds[1], float))
    W_t_worst = _normal(surface, motion, ex.worst[0], ex.worst[1], grid_t).W_t
    _, bandwidth = refine_maximum(lambda x: local_frequency(motion, x), ts,
                                  np.asarray(_local_frequency(pr, pa), float))
    bandwidth99 = energy_frequency(W_t_worst, sample_interval, energy_fraction)
    return ActuationDemand(t, P_s, mi, P_act, K_max, t_K, ex, wt_cf, wtt_cf, grid_t,
                           np.asarray(W_t_worst, float), bandwidth, bandwidth99)


def time_integral(y: ArrayLike, t: ArrayLike) -> float:
    """int y dt over samples at times t by Simpson's rule (0 for fewer than two samples)."""
    from scipy.integrate import simpson

    t = np.asarray(t, float)
    return float(simpson(np.asarray(y, float), x=t)) if t.size > 1 else 0.0


def power_figures(y: ArrayLike, t: ArrayLike, duration: float) -> dict[str, float]:
    """A power history's figures (docs/model.md s.12.1): ``peak`` max |P| (the rating an
    actuator needs whether it drives or brakes), ``max``, ``min``, ``energy`` int P dt
    (Simpson) and ``mean`` energy / duration; NaN for an empty history."""
    y = np.asarray(y, float)
    energy = time_integral(y, t)
    if y.size == 0:
        return {"peak": math.nan, "max": math.nan, "min": math.nan, "energy": energy,
                "mean": energy / duration}
    return {"peak": float(np.max(np.abs(y))), "max": float(np.max(y)),
            "min": float(np.min(y)), "energy": energy, "mean": energy / duration}
