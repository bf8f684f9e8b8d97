"""The rigid sphere on the moving surface: the closed forms of docs/model.md s.4-6.

Scalar code with no NumPy, like creatio.model.offset: the dynamics layer compiles these
same functions into its right-hand side, and validation evaluates them without a compiler
(the a-priori normal reaction behind the friction stability limit).

Frames: the rotating cylindrical frame (e_rho, e_alpha, e_z) at the contact angle alpha; a
vector field's jets P, Q, Z are those of creatio.model.offset.offset_jets.
"""

from __future__ import annotations

import math

__all__ = [
    "SCALAR_KERNELS",
    "STABILITY_MARGIN",
    "acceleration_at_fixed_rates",
    "centre_tangents",
    "inertia",
    "max_curvature_times_b",
    "normal_estimate",
    "normal_reaction",
    "normal_reaction_tilted",
    "slip_relaxation_rate",
    "stable_step",
    "tilted_gravity",
]

#: Safety factor on the a-priori normal reaction of the friction stability estimate
#: (docs/model.md s.6): N_est = STABILITY_MARGIN x max(N at the initial state, m g).
STABILITY_MARGIN = 1.25


def inertia(m: float, b: float) -> float:
    """Moment of inertia of the homogeneous sphere, I = 2 m b^2 / 5."""
    return 0.4 * m * b * b


def centre_tangents(P, Q, Z):
    """X_R, X_alpha, X_t of the centre in the rotating frame, from the jets of X.

    The alpha derivative of P e_rho + Q e_alpha + Z e_z is (P_a - Q, Q_a + P, Z_a); R and
    t act componentwise. Returned flat: (X_R (3), X_alpha (3), X_t (3)).
    """
    return (
        P[1], Q[1], Z[1],
        P[2] - Q[0], Q[2] + P[0], Z[2],
        P[3], Q[3], Z[3],
    )  # fmt: skip


def acceleration_at_fixed_rates(P, Q, Z, Rd: float, ad: float):
    """a0 = X_tt + 2 X_tq qdot + X_qq qdot qdot in the rotating frame (qddot = 0)."""
    RdRd = Rd * Rd
    Rdad2 = 2.0 * Rd * ad
    adad = ad * ad
    a01 = (
        P[9]
        + 2.0 * (P[6] * Rd + (P[8] - Q[3]) * ad)
        + P[4] * RdRd
        + (P[5] - Q[1]) * Rdad2
        + (P[7] - 2.0 * Q[2] - P[0]) * adad
    )
    a02 = (
        Q[9]
        + 2.0 * (Q[6] * Rd + (Q[8] + P[3]) * ad)
        + Q[4] * RdRd
        + (Q[5] + P[1]) * Rdad2
        + (Q[7] + 2.0 * P[2] - Q[0]) * adad
    )
    a03 = Z[9] + 2.0 * (Z[6] * Rd + Z[8] * ad) + Z[4] * RdRd + Z[5] * Rdad2 + Z[7] * adad
    return a01, a02, a03


def normal_reaction(m: float, g: float, n1: float, n2: float, n3: float, a01: float,
                    a02: float, a03: float) -> float:
    """N = m n . (a0 - g_vec) with gravity g_vec = (0, 0, -g): exact because n . J = 0 and
    n . f = 0 (docs/model.md s.4)."""
    return m * (n1 * a01 + n2 * a02 + n3 * (a03 + g))


def normal_reaction_tilted(m: float, g1: float, g2: float, g: float, n1: float, n2: float,
                           n3: float, a01: float, a02: float, a03: float) -> float:
    """N = m n . (a0 - g_vec) with gravity g_vec = (g1, g2, -g) off the -z axis (a mounting
    tilt, docs/model.md s.4): :func:`normal_reaction` gains the horizontal parts."""
    return m * (n1 * (a01 - g1) + n2 * (a02 - g2) + n3 * (a03 + g))


def tilted_gravity(g: float, beta: float, psi: float) -> tuple[float, float, float]:
    """g_vec = g (sin beta cos psi, sin beta sin psi, -cos beta): gravity of magnitude g on a
    membrane whose plane is off level by beta toward the azimuth psi (docs/model.md s.4)."""
    s = math.sin(beta)
    return g * s * math.cos(psi), g * s * math.sin(psi), -g * math.cos(beta)


def max_curvature_times_b(rho, z, n1: float, n2: float, n3: float, b: float) -> float:
    """b times the largest principal curvature of c (n towards the sphere); the offset
    surface X = c + b n is regular while this stays below 1 (docs/model.md s.4)."""
    cR1, cR3 = rho[1], z[1]
    ca1, ca2, ca3 = rho[2], rho[0], z[2]
    e11 = cR1 * cR1 + cR3 * cR3
    e12 = cR1 * ca1 + cR3 * ca3
    e22 = ca1 * ca1 + ca2 * ca2 + ca3 * ca3
    h11 = rho[4] * n1 + z[4] * n3
    h12 = rho[5] * n1 + rho[1] * n2 + z[5] * n3
    h22 = (rho[7] - rho[0]) * n1 + 2.0 * rho[2] * n2 + z[7] * n3
    det1 = e11 * e22 - e12 * e12
    hm = 0.5 * (e11 * h22 + e22 * h11 - 2.0 * e12 * h12) / det1
    kg = (h11 * h22 - h12 * h12) / det1
    disc = hm * hm - kg
    if disc < 0.0:
        disc = 0.0
    return b * (hm + math.sqrt(disc))


def slip_relaxation_rate(mu: float, N: float, m: float, b: float, eps: float,
                         rho: float = 0.0, inv_Is: float = 0.0) -> float:
    """Rate at which slip relaxes under the regularised friction near zero slip (1/s).

    Near v_s = 0, f = -(mu N / eps) v_s feeds the slip through translation (f / m) and
    rotation ((b^2 / I) f), so lambda = mu N (1/m + b^2/I) / eps = 3.5 mu N / (m eps) for
    the solid sphere (docs/model.md s.6). On a free structure (docs/model.md s.9) the
    friction's reaction also turns the structure, which moves the membrane under the
    contact point at horizontal radius rho: the azimuthal slip gains rho^2 / I_s, so
    lambda = mu N (1/m + b^2/I + rho^2 / I_s) / eps (inv_Is = 1 / I_s; 0 when fixed).
    """
    return mu * (1.0 / m + b**2 / inertia(m, b) + rho * rho * inv_Is) / eps * N


def normal_estimate(n_start: float, m: float, g: float) -> float:
    """A-priori normal reaction of the stability estimate: 1.25 x max(N at start, m g)."""
    return STABILITY_MARGIN * max(n_start, m * g)


def stable_step(bound: float, rate: float) -> float:
    """Largest stable fixed step of a method with real stability interval `bound` for a
    mode decaying at `rate` (inf when nothing decays or the method is A-stable)."""
    if rate <= 0.0 or math.isinf(bound):
        return math.inf
    return bound / rate


def tangent_coordinates(xR1: float, xR2: float, xR3: float, xa1: float, xa2: float,
                        xa3: float, r1: float, r2: float, r3: float) -> tuple[float, float]:
    """(J^T J)^-1 J^T r for J = [X_R X_alpha]: the (R, alpha) components of the tangent
    combination closest to r, as the equations of motion project onto the surface
    (docs/model.md s.4)."""
    j11 = xR1 * xR1 + xR2 * xR2 + xR3 * xR3
    j12 = xR1 * xa1 + xR2 * xa2 + xR3 * xa3
    j22 = xa1 * xa1 + xa2 * xa2 + xa3 * xa3
    c1 = xR1 * r1 + xR2 * r2 + xR3 * r3
    c2 = xa1 * r1 + xa2 * r2 + xa3 * r3
    idet = 1.0 / (j11 * j22 - j12 * j12)
    return (j22 * c1 - j12 * c2) * idet, (j11 * c2 - j12 * c1) * idet


def tangential_part(u1: float, u2: float, u3: float, n1: float, n2: float,
                    n3: float) -> tuple[float, float, float, float]:
    """The part of u tangent to the unit normal n, and its squared length: the contact
    point's slip v_s from its velocity relative to the membrane (docs/model.md s.4)."""
    un = u1 * n1 + u2 * n2 + u3 * n3
    t1 = u1 - un * n1
    t2 = u2 - un * n2
    t3 = u3 - un * n3
    return t1, t2, t3, t1 * t1 + t2 * t2 + t3 * t3


def attitude_rates(q0: float, q1: float, q2: float, q3: float, wx: float, wy: float,
                   wz: float) -> tuple[float, float, float, float, float]:
    """dQ/dt = 1/2 (0, omega) * Q for the unit quaternion Q of the sphere's orientation and
    its world-frame angular velocity omega, then the spin rate |omega| (docs/model.md s.4)."""
    return (-0.5 * (wx * q1 + wy * q2 + wz * q3),
            0.5 * (q0 * wx + wy * q3 - wz * q2),
            0.5 * (q0 * wy + wz * q1 - wx * q3),
            0.5 * (q0 * wz + wx * q2 - wy * q1),
            math.sqrt(wx * wx + wy * wy + wz * wz))


#: The functions the dynamics layer compiles into its loops.
SCALAR_KERNELS = (inertia, centre_tangents, acceleration_at_fixed_rates, normal_reaction,
                  normal_reaction_tilted,
                  max_curvature_times_b, attitude_rates, tangential_part,
                  tangent_coordinates)
