"""Compiled right-hand side of the structure path (docs/model.md s.9-10), for every integrator.

A structure free to yaw about z (inverse inertia 1 / I_s, 0 when fixed) and the normal
preload P of the microgravity studies. Everything is in the structure's rotating
cylindrical frame at the contact angle alpha (as in creatio.dynamics.sphere.rhs), except the
sphere's angular velocity omega, which stays in world components as in s.4.6: it is turned
into the rotating frame by the angle theta + alpha where the slip needs it, and the torque
is turned back by the same angle (docs/model.md s.9.2, project choice). The 4 x 4 system in
(qddot, theta'', N) is solved by creatio.model.structure.free_structure_solve.

State: the layout of creatio.dynamics.layout, with the energy block [surface work, friction
dissipation, confinement work] and the structure block [theta, Theta] last. The diagnostics
tuple is that of creatio.dynamics.sphere.rhs, with V the centre's velocity relative to the
structure. The rotation and energy blocks' rates are :func:`rotation_energy_rates`, the one
tail of both right-hand sides (the fixed structure's turns omega by alpha, this one by
theta + alpha), written here because creatio.dynamics.sphere imports this module.
"""

from __future__ import annotations

import math

import numpy as np
from numba.extending import overload

from creatio.dynamics.jit import INLINED, inlined, njit
from creatio.dynamics.layout import (
    EN_CONFINE,
    EN_DISSIPATION,
    EN_WORK,
    P_B,
    P_EPS,
    P_G,
    P_I,
    P_INV_IS,
    P_M,
    P_MU,
    P_PRELOAD,
    ST_RATE,
    ST_THETA,
    Y_ALPHA,
    Y_ALPHADOT,
    Y_OMEGA,
    Y_Q,
    Y_R,
    Y_RDOT,
    Y_SPIN,
    energy_start,
    structure_start,
)
from creatio.dynamics.surface import surface
from creatio.model.sphere import (
    acceleration_at_fixed_rates,
    attitude_rates,
    centre_tangents,
    max_curvature_times_b,
    tangent_coordinates,
    tangential_part,
)
from creatio.model.structure import confinement_power, free_structure_solve

__all__ = ["rhs_structure", "rhs_structure_on", "rotation_energy_rates"]


def rhs_structure(t, y, dy, pp, lc, rot, en, diag):
    """Write dy/dt into dy on the structure path; return the diagnostics tuple of
    creatio.dynamics.sphere.rhs (N, |v_s|, X, V_rel, f, phi_r, gamma, b kappa, phi_a).

    The parameters pp include the structure's inverse inertia 1 / I_s (0: fixed) and the
    normal preload P (compiled code only).
    """
    raise NotImplementedError("called only from compiled code")


@overload(rhs_structure, jit_options=INLINED)
def _rhs_structure_any_diag(t, y, dy, pp, lc, rot, en, diag):
    """:func:`rhs_structure` with diag a run-time flag, as creatio.dynamics.sphere.rhs: one
    compilation per specialisation serves the evaluations with and without diagnostics."""
    return lambda t, y, dy, pp, lc, rot, en, diag: _rhs_structure(t, y, dy, pp, lc, rot, en,
                                                                  bool(diag))


# allocates nothing: compiled without reference counting (a call takes no reference to its
# arrays, which costs atomic operations every step otherwise); a call, never inlined
@njit(cache=True, _nrt=False, forceinline=False)
def _rhs_structure(t, y, dy, pp, lc, rot, en, diag):
    """:func:`rhs_structure`, compiled once per (rot, en)."""
    return rhs_structure_on(surface(t, y[Y_R], y[Y_ALPHA], pp, lc), y, dy, pp, rot, en, diag)


@inlined
def rhs_structure_on(sf: tuple, y: np.ndarray, dy: np.ndarray, pp: tuple, rot: bool,
                     en: bool, diag: bool) -> tuple:
    """:func:`rhs_structure` on the surface sf = creatio.dynamics.surface.surface at y's
    (t, R, alpha), so that states sharing (t, R, alpha) share its evaluation."""
    m = pp[P_M]
    b = pp[P_B]
    g = pp[P_G]
    mu = pp[P_MU]
    eps = pp[P_EPS]
    inv_is = pp[P_INV_IS]
    P = pp[P_PRELOAD]
    pr, pa, gm, rho, z, n1, n2, n3, P_, Q, Z = sf
    a = y[Y_ALPHA]
    Rd = y[Y_RDOT]
    ad = y[Y_ALPHADOT]
    iy = structure_start(rot, en)
    th = y[iy + ST_THETA]
    Th = y[iy + ST_RATE]
    xR1, xR2, xR3, xa1, xa2, xa3, xt1, xt2, xt3 = centre_tangents(P_, Q, Z)
    a01, a02, a03 = acceleration_at_fixed_rates(P_, Q, Z, Rd, ad)
    X1 = P_[0]
    X2 = Q[0]
    V1 = xt1 + xR1 * Rd + xa1 * ad
    V2 = xt2 + xR2 * Rd + xa2 * ad
    V3 = xt3 + xR3 * Rd + xa3 * ad
    ct1 = rho[3]
    ct3 = z[3]
    # slip: V_rel + Theta z^ x (b n) + omega x (-b n) - c_t, tangential part
    u1 = V1 - ct1 - Th * b * n2
    u2 = V2 + Th * b * n1
    u3 = V3 - ct3
    ca = 0.0
    sa = 0.0
    if rot:
        ca = math.cos(th + a)
        sa = math.sin(th + a)
        wx = y[Y_OMEGA]
        wy = y[Y_OMEGA + 1]
        w3 = y[Y_OMEGA + 2]
        w1 = wx * ca + wy * sa
        w2 = wy * ca - wx * sa
        u1 -= b * (w2 * n3 - w3 * n2)
        u2 -= b * (w3 * n1 - w1 * n3)
        u3 -= b * (w1 * n2 - w2 * n1)
    vs1, vs2, vs3, slip2 = tangential_part(u1, u2, u3, n1, n2, n3)
    ph = 0.0
    if mu > 0.0:
        ph = -mu / math.sqrt(slip2 + eps * eps)
    phi1 = ph * vs1
    phi2 = ph * vs2
    phi3 = ph * vs3
    # b = g - a0 - 2 Theta z^ x V_rel - Theta^2 z^ x (z^ x X) (per unit mass, without the
    # preload, whose -P/m n enters n . b only: J^T n = 0)
    b1 = -a01 + 2.0 * Th * V2 + Th * Th * X1
    b2 = -a02 - 2.0 * Th * V1 + Th * Th * X2
    b3 = -g - a03
    bn = n1 * b1 + n2 * b2 + n3 * b3 - P / m
    thdd, N = free_structure_solve(m, inv_is, P, n1, n2, n3, phi1, phi2, X1, X2, rho[0], bn)
    f1 = N * phi1
    f2 = N * phi2
    f3 = N * phi3
    # (J^T J) qddot = J^T (b - theta'' z^ x X + f / m)
    r1 = b1 + thdd * X2 + f1 / m
    r2 = b2 - thdd * X1 + f2 / m
    r3 = b3 + f3 / m
    dy[Y_R] = Rd
    dy[Y_ALPHA] = ad
    dy[Y_RDOT], dy[Y_ALPHADOT] = tangent_coordinates(xR1, xR2, xR3, xa1, xa2, xa3, r1, r2, r3)
    # omega turned from the rotating frame to the world by theta + a
    rotation_energy_rates(dy, y, pp, rot, en, N, n1, n2, n3, f1, f2, f3, vs1, vs2, vs3, ct1,
                          ct3, ca, sa)
    if en:
        dy[energy_start(rot) + EN_CONFINE] = confinement_power(P, n1, n3, ct1, ct3)
    dy[iy + ST_THETA] = Th
    dy[iy + ST_RATE] = thdd
    bk = 0.0
    if diag:
        bk = max_curvature_times_b(rho, z, n1, n2, n3, b)
    return N, math.sqrt(slip2), X1, X2, Z[0], V1, V2, V3, f1, f2, f3, pr, gm, bk, pa


@inlined
def rotation_energy_rates(dy: np.ndarray, y: np.ndarray, pp: tuple, rot: bool, en: bool,
                          N: float, n1: float, n2: float, n3: float, f1: float, f2: float,
                          f3: float, vs1: float, vs2: float, vs3: float, ct1: float,
                          ct3: float, ca: float, sa: float) -> None:
    """Write the rotation block's rates (I domega/dt = (-b n) x f, turned from the rotating
    frame to the world by the angle of cosine ca and sine sa; the attitude and the spin) and
    the energy block's (surface work, friction dissipation) into dy: the one tail of both
    right-hand sides (creatio.dynamics.sphere.rhs_on at alpha, :func:`rhs_structure_on` at
    theta + alpha), from the normal n, the reaction N, the friction f, the slip v_s and the
    membrane velocity c_t (rho and z components) at the contact."""
    if rot:
        s = -pp[P_B] / pp[P_I]
        d1 = s * (n2 * f3 - n3 * f2)
        d2 = s * (n3 * f1 - n1 * f3)
        dy[Y_OMEGA] = d1 * ca - d2 * sa
        dy[Y_OMEGA + 1] = d1 * sa + d2 * ca
        dy[Y_OMEGA + 2] = s * (n1 * f2 - n2 * f1)
        # dQ/dt = 1/2 (0, omega) * Q, world-frame omega; the spin integrates |omega|
        dy[Y_Q], dy[Y_Q + 1], dy[Y_Q + 2], dy[Y_Q + 3], dy[Y_SPIN] = attitude_rates(
            y[Y_Q], y[Y_Q + 1], y[Y_Q + 2], y[Y_Q + 3], y[Y_OMEGA], y[Y_OMEGA + 1],
            y[Y_OMEGA + 2])
    if en:
        ie = energy_start(rot)
        dy[ie + EN_WORK] = (N * n1 + f1) * ct1 + (N * n3 + f3) * ct3
        dy[ie + EN_DISSIPATION] = -(f1 * vs1 + f2 * vs2 + f3 * vs3)
