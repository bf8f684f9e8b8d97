"""The corrugated surface c(alpha, R, t), its analytic derivatives, metric, Jacobian and normal.

Vectorised NumPy over arbitrary (broadcastable) shapes; vectors carry a trailing axis of 3.
Formulas (docs/model.md s.1, restated):

    k = 2 pi Kr / dR,  u = k R + phi_r(t),  v = Ka alpha + phi_a(t),  W = A sin u cos v
    rho = R0 + R cos(gamma) - W sin(gamma)
    c = (rho cos alpha, rho sin alpha, R sin(gamma) + W cos(gamma))

with the meridional pair e_g = cos(gamma) e_rho + sin(gamma) e_z and
e_n = -sin(gamma) e_rho + cos(gamma) e_z. The unit normal is n = (c_R x c_alpha) / J,
which points up (+z) on the flat annulus and inward on the cylinder.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from creatio.model.laws import Law, LawValue
from creatio.model.ribs import Ribs, check_rib_count, skin_jets

__all__ = ["Frame", "Motion", "Surface", "Wave", "acceleration_parts", "ideal_W", "ideal_W_t",
           "ideal_W_tt", "inverse", "velocity_parts", "wavenumber"]

Array = NDArray[np.float64]


def wavenumber(Kr: int, dR: float) -> float:
    """Radial wavenumber k = 2 pi Kr / dR (Kr corrugation cycles across the width)."""
    return 2.0 * math.pi * Kr / dR


@dataclass(frozen=True)
class Surface:
    """Static shape parameters: inner radius R0, width dR, amplitude A, cycle counts Kr, Ka;
    and ``ribs``: None for the ideal surface, else the ribs whose spline skin it is
    (creatio.model.ribs, docs/model.md s.14.4)."""

    R0: float
    dR: float
    A: float
    Kr: int
    Ka: int
    ribs: Ribs | None = None

    def __post_init__(self) -> None:
        if not self.R0 > 0.0:
            raise ValueError(f"R0 must be > 0, got {self.R0}")
        if not self.dR > 0.0:
            raise ValueError(f"dR must be > 0, got {self.dR}")
        if not 0.0 <= self.A < self.R0:
            raise ValueError(f"A must satisfy 0 <= A < R0 = {self.R0}, got {self.A}")
        for name in ("Kr", "Ka"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value}")
        if self.ribs is not None:
            check_rib_count(self.ribs.N, self.Ka)

    @cached_property
    def skin_table(self) -> Array | None:
        """The rib skin's spline table (creatio.model.ribs.skin_table), None when ideal."""
        return None if self.ribs is None else self.ribs.table(self.Ka)

    @property
    def k(self) -> float:
        """Radial wavenumber 2 pi Kr / dR."""
        return wavenumber(self.Kr, self.dR)

    @property
    def R1(self) -> float:
        """Outer radius R0 + dR."""
        return self.R0 + self.dR

    @property
    def j_lower_bound(self) -> float:
        """Analytic lower bound R0 - A of J over every inclination |gamma| <= pi/2."""
        return self.R0 - self.A


@dataclass(frozen=True)
class Motion:
    """The three time laws that move the surface: radial phase, angular phase, inclination."""

    phi_r: Law
    phi_a: Law
    gamma: Law

    def at(self, t: ArrayLike) -> tuple[LawValue, LawValue, LawValue]:
        """Evaluate (phi_r, phi_a, gamma) with derivatives at times t."""
        return self.phi_r(t), self.phi_a(t), self.gamma(t)


def ideal_W(A: float, su: ArrayLike, cv: ArrayLike) -> Array:
    """W = A sin u cos v on the ideal surface (u = k R + phi_r, v = Ka alpha + phi_a)."""
    return A * su * cv


def ideal_W_t(A: float, r1: ArrayLike, a1: ArrayLike, su: ArrayLike, cu: ArrayLike,
              sv: ArrayLike, cv: ArrayLike) -> Array:
    """W_t = A (phi_r' cos u cos v - phi_a' sin u sin v) on the ideal surface."""
    return A * (r1 * cu * cv - a1 * su * sv)


def ideal_W_tt(A: float, r1: ArrayLike, r2: ArrayLike, a1: ArrayLike, a2: ArrayLike,
               su: ArrayLike, cu: ArrayLike, sv: ArrayLike, cv: ArrayLike) -> Array:
    """W_tt on the ideal surface, from the phases' first and second derivatives."""
    return A * (r2 * cu * cv - a2 * su * sv - (r1**2 + a1**2) * su * cv - 2.0 * r1 * a1 * cu * sv)


def velocity_parts(W: ArrayLike, W_t: ArrayLike, R: ArrayLike, dg: ArrayLike
                   ) -> tuple[Array, Array]:
    """The material velocity's coefficients on (e_n, e_g): c_t = (W_t + R gamma') e_n
    - W gamma' e_g."""
    return W_t + R * dg, -W * dg


def acceleration_parts(W: ArrayLike, W_t: ArrayLike, W_tt: ArrayLike, R: ArrayLike,
                       dg: ArrayLike, ddg: ArrayLike) -> tuple[Array, Array]:
    """The material acceleration's coefficients on (e_n, e_g): c_tt = (W_tt + R g'' - W g'^2)
    e_n - (2 W_t g' + W g'' + R g'^2) e_g."""
    a = W_tt + R * ddg - W * dg**2
    b = 2.0 * W_t * dg + W * ddg + R * dg**2
    return a, -b


class Wave:
    """W and its partial derivatives up to second order at (alpha, R, t) for one surface motion.

    Attribute names: W, W_R, W_a, W_t, W_RR, W_aa, W_Ra, W_Rt, W_at, W_tt; plus the phases'
    values, the inclination's (g, dg, ddg) and the angles' sines and cosines. Evaluating once
    and sharing it keeps every derived quantity consistent and cheap.
    """

    def __init__(
        self, surface: Surface, motion: Motion, alpha: ArrayLike, R: ArrayLike, t: ArrayLike
    ) -> None:
        alpha, R, t = np.asarray(alpha, float), np.asarray(R, float), np.asarray(t, float)
        # the laws at the times as given (often far fewer than the broadcast points), then
        # broadcast: elementwise the same numbers
        pr, pa, gm = motion.at(t)
        (alpha, R, t, pr_v, pr_1, pr_2, pa_v, pa_1, pa_2, g_v, g_1, g_2, sg, cg) = (
            np.broadcast_arrays(alpha, R, t, pr.value, pr.d1, pr.d2, pa.value, pa.d1, pa.d2,
                                gm.value, gm.d1, gm.d2, np.sin(gm.value), np.cos(gm.value)))
        A, k, Ka = surface.A, surface.k, surface.Ka
        self.surface, self.alpha, self.R, self.t = surface, alpha, R, t
        u = k * R + pr_v
        v = Ka * alpha + pa_v
        su, cu, sv, cv = np.sin(u), np.cos(u), np.sin(v), np.cos(v)
        r1, r2, a1, a2 = pr_1, pr_2, pa_1, pa_2
        if surface.ribs is None:
            self.W = ideal_W(A, su, cv)
            self.W_R = A * k * cu * cv
            self.W_a = -A * Ka * su * sv
            self.W_t = ideal_W_t(A, r1, a1, su, cu, sv, cv)
            self.W_RR = -(k**2) * self.W
            self.W_aa = -(Ka**2) * self.W
            self.W_Ra = -A * k * Ka * cu * sv
            self.W_Rt = A * k * (-r1 * su * cv - a1 * cu * sv)
            self.W_at = -A * Ka * (r1 * cu * sv + a1 * su * cv)
            self.W_tt = ideal_W_tt(A, r1, r2, a1, a2, su, cu, sv, cv)
        else:
            # the rib skin: W = A sin(u) H(alpha, t) (creatio.model.ribs)
            H, Ha, Ht, Haa, Hat, Htt, _, _, _ = skin_jets(surface.skin_table, alpha, pa_v, a1,
                                                          a2)
            self.W = A * su * H
            self.W_R = A * k * cu * H
            self.W_a = A * su * Ha
            self.W_t = A * (r1 * cu * H + su * Ht)
            self.W_RR = -(k**2) * self.W
            self.W_aa = A * su * Haa
            self.W_Ra = A * k * cu * Ha
            self.W_Rt = A * k * (-r1 * su * H + cu * Ht)
            self.W_at = A * (r1 * cu * Ha + su * Hat)
            self.W_tt = A * (r2 * cu * H - r1**2 * su * H + 2.0 * r1 * cu * Ht + su * Htt)
        self.g, self.dg, self.ddg = g_v, g_1, g_2
        self.sg, self.cg = sg, cg
        self.sa, self.ca = np.sin(alpha), np.cos(alpha)


class Frame:
    """Surface point, first and second derivatives, metric and normal at sampled (alpha, R, t).

    Every vector is returned in world coordinates with shape (..., 3).
    """

    def __init__(
        self, surface: Surface, motion: Motion, alpha: ArrayLike, R: ArrayLike, t: ArrayLike
    ) -> None:
        self.w = w = Wave(surface, motion, alpha, R, t)
        self.e_rho = _stack(w.ca, w.sa, 0.0 * w.ca)
        self.e_alpha = _stack(-w.sa, w.ca, 0.0 * w.ca)
        self.e_z = _stack(0.0 * w.ca, 0.0 * w.ca, 1.0 + 0.0 * w.ca)
        self.e_g = _lin(w.cg, self.e_rho, w.sg, self.e_z)
        self.e_n = _lin(-w.sg, self.e_rho, w.cg, self.e_z)
        self.rho = surface.R0 + w.R * w.cg - w.W * w.sg

    # --- position and first derivatives -------------------------------------------------
    @property
    def position(self) -> Array:
        """c = rho e_rho + (R sin gamma + W cos gamma) e_z."""
        w = self.w
        return _lin(self.rho, self.e_rho, w.R * w.sg + w.W * w.cg, self.e_z)

    @property
    def c_R(self) -> Array:
        """dc/dR = e_g + W_R e_n."""
        return self.e_g + self.w.W_R[..., None] * self.e_n

    @property
    def c_alpha(self) -> Array:
        """dc/dalpha = rho e_alpha + W_alpha e_n."""
        return _lin(self.rho, self.e_alpha, self.w.W_a, self.e_n)

    @property
    def c_t(self) -> Array:
        """dc/dt at fixed (alpha, R) = (W_t + R gamma') e_n - W gamma' e_g (material velocity)."""
        w = self.w
        a, b = velocity_parts(w.W, w.W_t, w.R, w.dg)
        return _lin(a, self.e_n, b, self.e_g)

    # --- second derivatives --------------------------------------------------------------
    @property
    def c_RR(self) -> Array:
        """d2c/dR2 = W_RR e_n."""
        return self.w.W_RR[..., None] * self.e_n

    @property
    def c_Ra(self) -> Array:
        """d2c/dR dalpha = (cos gamma - W_R sin gamma) e_alpha + W_Ra e_n."""
        w = self.w
        return _lin(w.cg - w.W_R * w.sg, self.e_alpha, w.W_Ra, self.e_n)

    @property
    def c_aa(self) -> Array:
        """d2c/dalpha2 = -rho e_rho - 2 W_alpha sin(gamma) e_alpha + W_aa e_n."""
        w = self.w
        return (
            _lin(-self.rho, self.e_rho, -2.0 * w.W_a * w.sg, self.e_alpha)
            + w.W_aa[..., None] * self.e_n
        )

    @property
    def c_Rt(self) -> Array:
        """d2c/dR dt = (W_Rt + gamma') e_n - gamma' W_R e_g."""
        w = self.w
        return _lin(w.W_Rt + w.dg, self.e_n, -w.dg * w.W_R, self.e_g)

    @property
    def c_at(self) -> Array:
        """d2c/dalpha dt = [-W_t sin g - g' (R sin g + W cos g)] e_alpha + W_at e_n - g' W_a e_g."""
        w = self.w
        coef = -w.W_t * w.sg - w.dg * (w.R * w.sg + w.W * w.cg)
        return _lin(coef, self.e_alpha, w.W_at, self.e_n) - (w.dg * w.W_a)[..., None] * self.e_g

    @property
    def c_tt(self) -> Array:
        """d2c/dt2 = (W_tt + R g'' - W g'^2) e_n - (2 W_t g' + W g'' + R g'^2) e_g."""
        w = self.w
        a, b = acceleration_parts(w.W, w.W_t, w.W_tt, w.R, w.dg, w.ddg)
        return _lin(a, self.e_n, b, self.e_g)

    # --- metric, Jacobian, normal --------------------------------------------------------
    def metric(self) -> tuple[Array, Array, Array]:
        """First fundamental form (E, F, G) in the (R, alpha) coordinates."""
        w = self.w
        return 1.0 + w.W_R**2, w.W_R * w.W_a, self.rho**2 + w.W_a**2

    @property
    def J(self) -> Array:
        """Area Jacobian from the closed-form identity J^2 = rho^2 (1 + W_R^2) + W_alpha^2."""
        w = self.w
        return np.sqrt(self.rho**2 * (1.0 + w.W_R**2) + w.W_a**2)

    @property
    def normal(self) -> Array:
        """Unit normal n = [rho (e_n - W_R e_g) - W_alpha e_alpha] / J (c_R x c_alpha order)."""
        w = self.w
        num = _lin(self.rho, self.e_n, -self.rho * w.W_R, self.e_g) - w.W_a[..., None] * (
            self.e_alpha
        )
        return num / self.J[..., None]


def inverse(
    surface: Surface, motion: Motion, x: ArrayLike, t: ArrayLike
) -> tuple[Array, Array, Array]:
    """Recover (alpha, R, W) of a point x = c(alpha, R, t); exact while rho > 0.

    alpha is the azimuth of x (in [0, 2 pi)), and from (rho, z):
    R = (rho - R0) cos(gamma) + z sin(gamma),  W = -(rho - R0) sin(gamma) + z cos(gamma).
    """
    x = np.asarray(x, float)
    gamma = motion.gamma(np.asarray(t, float)).value
    rho = np.hypot(x[..., 0], x[..., 1])
    alpha = np.mod(np.arctan2(x[..., 1], x[..., 0]), 2.0 * np.pi)
    sg, cg = np.sin(gamma), np.cos(gamma)
    R = (rho - surface.R0) * cg + x[..., 2] * sg
    W = -(rho - surface.R0) * sg + x[..., 2] * cg
    return alpha, R, W


def _stack(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> Array:
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1)


def _lin(a: Array, u: Array, b: Array, v: Array) -> Array:
    """a u + b v for scalar fields a, b and vector fields u, v."""
    return np.asarray(a)[..., None] * u + np.asarray(b)[..., None] * v
