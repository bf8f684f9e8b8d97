"""The free-floating structure and the confining force: closed forms of docs/model.md s.9-10.

Scalar code with no NumPy, like creatio.model.sphere: the dynamics layer compiles these
functions into its right-hand side and diagnostics, and the studies and tests evaluate them
without a compiler.

Frames: the structure's rotating cylindrical frame (e_rho, e_alpha, e_z) at the contact
angle alpha, so the contact point is c = (rho_c, 0, z_c) and z^ x v = (-v_2, v_1, 0).
The structure's inertia enters as its inverse 1 / I_s, which is 0 for a fixed structure
(I_s = infinity): every term it multiplies then vanishes exactly.
"""

from __future__ import annotations

import math

__all__ = [
    "CONFINEMENTS",
    "SCALAR_KERNELS",
    "angular_momentum_parts",
    "confinement_power",
    "free_structure_solve",
    "inverse_inertia",
    "point_mass_rotation",
]

#: The confinement models of docs/model.md s.10 (none: gravity alone).
CONFINEMENTS = ("none", "normal", "base")


def inverse_inertia(I_s: float) -> float:
    """1 / I_s, exactly 0 for a fixed structure (I_s = infinity)."""
    return 0.0 if math.isinf(I_s) else 1.0 / I_s


def free_structure_solve(m: float, inv_Is: float, P: float, n1: float, n2: float, n3: float,
                         phi1: float, phi2: float, X1: float, X2: float, rho_c: float,
                         bn: float) -> tuple[float, float]:
    """(theta'', N): the structure's angular acceleration and the normal reaction solving
    the 4 x 4 system of docs/model.md s.9.2 (with the normal preload P of s.10.2).

    The unknowns (qddot, theta'', N) solve

        m J qddot + m theta'' (z^ x X) - N (n + phi) = m b
        I_s theta'' + N [c x (n + phi)] . z^ - P [c x n] . z^ = 0

    with b = g - a0 - 2 Theta z^ x V_rel - Theta^2 z^ x (z^ x X) - (P / m) n and bn = n . b.
    Because n . J = 0 and n . phi = 0, the normal component of the first equation and the
    second form a 2 x 2 system in (theta'', N) alone, solved here by elimination:

        s_n = n . (z^ x X),  tau = rho_c (n_2 + phi_2),  tau_n = rho_c n_2
        theta'' = inv_Is (m bn tau + P tau_n) / (1 + inv_Is m s_n tau)
        N = m theta'' s_n - m bn

    ([c x v] . z^ = rho_c v_2 since c = (rho_c, 0, z_c)); the tangential part then gives
    (J^T J) qddot = J^T (b - theta'' z^ x X + N phi / m). inv_Is = 0 gives theta'' = 0 and
    N = -m bn, the fixed structure of s.4 (with the preload: N = m n . (a0 - g) + P).
    """
    s_n = n2 * X1 - n1 * X2
    tau = rho_c * (n2 + phi2)
    tau_n = rho_c * n2
    thdd = inv_Is * (m * bn * tau + P * tau_n) / (1.0 + inv_Is * m * s_n * tau)
    N = m * thdd * s_n - m * bn
    return thdd, N


def angular_momentum_parts(I_s: float, Theta: float, m: float, X1: float, X2: float, V1: float,
                           V2: float, inertia: float, wz: float) -> tuple[float, float, float]:
    """The three parts of H_z (docs/model.md s.9.3): structure I_s Theta, sphere orbital
    m [X x V_abs] . z^ with V_abs = V_rel + Theta z^ x X, sphere spin I omega_z.

    X and V_rel in any frame turned about z (the z components are frame-invariant):
    m [X x V_abs] . z^ = m (X1 V2 - X2 V1 + Theta (X1^2 + X2^2)).
    """
    orbital = m * (X1 * V2 - X2 * V1 + Theta * (X1 * X1 + X2 * X2))
    return I_s * Theta, orbital, inertia * wz


def confinement_power(P: float, n1: float, n3: float, ct1: float, ct3: float) -> float:
    """Power of the normal preload on sphere and structure together (docs/model.md s.10.3):
    P_c = -P n . V_rel = -P n . c_t, with c_t = (ct1, 0, ct3) in the rotating frame (the
    membrane point of fixed coordinates moves in its meridian plane)."""
    return -P * (n1 * ct1 + n3 * ct3)


def point_mass_rotation(m: float, rho: float, I_s: float, dalpha: float) -> float:
    """Structure turn of a point mass m carried through a relative turn dalpha at constant
    horizontal radius rho (docs/model.md s.9.5): -m rho^2 / (I_s + m rho^2) dalpha
    (from H_z = I_s Theta + m rho^2 (Theta + alpha') = 0)."""
    if math.isinf(I_s):
        return 0.0
    return -m * rho * rho / (I_s + m * rho * rho) * dalpha


#: The functions the dynamics layer compiles into its loops.
SCALAR_KERNELS = (free_structure_solve, angular_momentum_parts, confinement_power)
