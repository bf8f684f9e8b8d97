"""Pattern motion, cavity (feature) trajectories and helical pitch (docs/model.md s.3).

The pattern (a line of constant Ka alpha + phi_a) turns at alpha_p' = -phi_a' / Ka: that is
the motion of the pattern, not of a body on it. A cavity is one branch of minima of W
(sin u = 1, cos v = -1):

    R_c = (pi/2 - phi_r + 2 pi n) / k,   alpha_c = (pi - phi_a + 2 pi m) / Ka
    rho_c = R0 + R_c cos(gamma) + A sin(gamma),   z_c = R_c sin(gamma) - A cos(gamma)
    C(t) = rho_c e_rho(alpha_c) + z_c e_z

Its velocity and acceleration below hold for a time-varying gamma as well; with gamma
constant they reduce to the notebook's formulas.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from creatio.model.surface import Motion, Surface

__all__ = [
    "SCALAR_KERNELS",
    "Cavity",
    "bottom_curvatures",
    "cavity",
    "cavity_angle",
    "cavity_angle_branch",
    "cavity_branch",
    "cavity_cell_offsets",
    "cavity_radius",
    "in_cavity_cell",
    "classify_inclination",
    "helical_pitch",
    "pattern_angle",
]

Array = NDArray[np.float64]


def pattern_angle(
    surface: Surface, motion: Motion, t: ArrayLike, alpha0: float = 0.0
) -> tuple[Array, Array, Array]:
    """Pattern angle alpha_p = alpha0 - (phi_a(t) - phi_a(0)) / Ka, its rate and acceleration."""
    pa = motion.phi_a(t)
    pa0 = motion.phi_a(0.0).value
    Ka = surface.Ka
    return alpha0 - (pa.value - pa0) / Ka, -pa.d1 / Ka, -pa.d2 / Ka


def cavity_radius(phi_r, k, n):
    """Radial coordinate of cavity branch n: R_c = (pi/2 - phi_r + 2 pi n) / k (scalar or
    array; the dynamics layer compiles it into its diagnostics)."""
    return (0.5 * math.pi - phi_r + 2.0 * math.pi * n) / k


def cavity_angle(phi_a, Ka, m):
    """Angular coordinate of cavity branch m: alpha_c = (pi - phi_a + 2 pi m) / Ka."""
    return (math.pi - phi_a + 2.0 * math.pi * m) / Ka


def cavity_branch(R: float, phi_r: float, k: float) -> int:
    """The branch n whose cavity radius R_c(phi_r) lies nearest the radial coordinate R."""
    return round((k * R - 0.5 * math.pi + phi_r) / (2.0 * math.pi))


def cavity_angle_branch(alpha: float, phi_a: float, Ka: float) -> int:
    """The branch m whose cavity angle alpha_c(phi_a) lies nearest the angle alpha (alpha
    continuous, not reduced modulo 2 pi)."""
    return round((Ka * alpha - math.pi + phi_a) / (2.0 * math.pi))


def cavity_cell_offsets(R, alpha, phi_r, phi_a, k, Ka, n, m):
    """Phase offsets (du, dv) of the point (R, alpha) from the bottom of cavity (n, m)
    (docs/model.md s.8.2):

        du = k R + phi_r - (pi/2 + 2 pi n),   dv = Ka alpha + phi_a - (pi + 2 pi m)

    The cavity's cell, the rectangle around its bottom where W < 0 (bounded by the zero
    lines of W through the saddles), is |du| < pi/2 and |dv| < pi/2. Scalar or array; the
    dynamics layer compiles it into its per-step diagnostics.
    """
    du = k * R + phi_r - (0.5 * math.pi + 2.0 * math.pi * n)
    dv = Ka * alpha + phi_a - (math.pi + 2.0 * math.pi * m)
    return du, dv


def in_cavity_cell(du, dv):
    """Whether phase offsets (du, dv) of :func:`cavity_cell_offsets` lie inside the cell
    (|du| < pi/2 and |dv| < pi/2): the sphere is carried while its contact point is."""
    return abs(du) < 0.5 * math.pi and abs(dv) < 0.5 * math.pi


def bottom_curvatures(A: float, k: float, Ka: float, rho_c: float, gamma: float
                      ) -> tuple[float, float]:
    """Principal curvatures (kappa_R, kappa_alpha) of the surface at a cavity bottom
    (W = -A, grad W = 0), with the normal towards the sphere (docs/model.md s.6.4):

        kappa_R = A k^2,   kappa_alpha = (A Ka^2 + rho_c sin(gamma)) / rho_c^2

    rho_c = R0 + R_c cos(gamma) + A sin(gamma) is the bottom's distance from the axis. A
    sphere of radius b sits in the cavity only if b max(kappa) < 1 (necessary, not
    sufficient: the curvature peaks off the bottom; the integrator checks the general
    principal curvature, creatio.model.sphere.max_curvature_times_b, at every step).
    """
    return A * k * k, (A * Ka**2 + rho_c * math.sin(gamma)) / rho_c**2


@dataclass(frozen=True)
class Cavity:
    """A cavity branch evaluated at times t: coordinates, centre C and its time derivatives."""

    R: Array
    alpha: Array
    dR: Array
    dalpha: Array
    position: Array
    velocity: Array
    acceleration: Array


def cavity(surface: Surface, motion: Motion, t: ArrayLike, n: int = 0, m: int = 0) -> Cavity:
    """Evaluate cavity branch (n, m): R_c, alpha_c, C(t), C'(t), C''(t) in closed form."""
    if surface.A <= 0.0:
        raise ValueError("cavities exist only for A > 0")
    t = np.asarray(t, float)
    pr, pa, gm = motion.at(t)
    k, Ka, A = surface.k, surface.Ka, surface.A
    Rc = cavity_radius(pr.value, k, n)
    Rc1, Rc2 = -pr.d1 / k, -pr.d2 / k
    ac = cavity_angle(pa.value, Ka, m)
    ac1, ac2 = -pa.d1 / Ka, -pa.d2 / Ka
    g, g1, g2 = gm.value, gm.d1, gm.d2
    sg, cg = np.sin(g), np.cos(g)
    rho = surface.R0 + Rc * cg + A * sg
    z = Rc * sg - A * cg
    # d/dgamma of (rho, z) along the branch: (-R_c sin g + A cos g, R_c cos g + A sin g) = (p, q)
    p, q = -Rc * sg + A * cg, Rc * cg + A * sg
    rho1 = Rc1 * cg + p * g1
    z1 = Rc1 * sg + q * g1
    rho2 = Rc2 * cg - 2.0 * Rc1 * sg * g1 - q * g1**2 + p * g2
    z2 = Rc2 * sg + 2.0 * Rc1 * cg * g1 + p * g1**2 + q * g2
    e_rho = np.stack([np.cos(ac), np.sin(ac), 0.0 * ac], axis=-1)
    e_alpha = np.stack([-np.sin(ac), np.cos(ac), 0.0 * ac], axis=-1)
    e_z = np.stack([0.0 * ac, 0.0 * ac, 1.0 + 0.0 * ac], axis=-1)

    def comb(a: Array, b: Array, c: Array) -> Array:
        return a[..., None] * e_rho + b[..., None] * e_alpha + c[..., None] * e_z

    zero = 0.0 * rho
    return Cavity(
        R=Rc + zero,
        alpha=ac + zero,
        dR=Rc1 + zero,
        dalpha=ac1 + zero,
        position=comb(rho, zero, z),
        velocity=comb(rho1, rho * ac1, z1),
        acceleration=comb(rho2 - rho * ac1**2, 2.0 * rho1 * ac1 + rho * ac2, z2),
    )


def helical_pitch(surface: Surface, Wr: float, Wa: float, gamma: float) -> tuple[float, ...]:
    """Pitch (p_R, p_z, p_rho) per positive 2 pi turn of alpha_c for linear phases.

    p_R = dR (Ka / Kr)(Wr / Wa), p_z = p_R sin(gamma), p_rho = p_R cos(gamma); Wa = 0 means
    motion along a meridian, where the pitch is undefined.
    """
    if Wa == 0.0:
        raise ValueError("pitch is undefined for Wa = 0 (motion along a meridian)")
    pR = surface.dR * (surface.Ka / surface.Kr) * (Wr / Wa)
    return pR, pR * np.sin(gamma), pR * np.cos(gamma)


def classify_inclination(gamma: float, tol: float = 1e-12) -> str:
    """Name the surface family of an inclination: annulus (0), cylinder (pi/2), or cone."""
    if abs(gamma) <= tol:
        return "annulus"
    if abs(abs(gamma) - 0.5 * np.pi) <= tol:
        return "cylinder"
    return "cone"


#: The functions the dynamics layer compiles into its loops.
SCALAR_KERNELS = (cavity_radius, cavity_cell_offsets, in_cavity_cell)
