"""Separation, flight and impact of the sphere: the closed forms of docs/model.md s.11.

Scalar code with no NumPy, like creatio.model.offset and creatio.model.sphere: the dynamics
layer compiles these same functions into its hybrid loop (every name in SCALAR_KERNELS).

* :func:`foot_point` finds the point q* of the moving surface nearest the sphere centre X
  (the foot of the perpendicular from X) by damped Newton (Levenberg-Marquardt) on the
  squared distance, and returns the gap d = (X - c(q*, t)) . n - b with the normal and the
  membrane velocity there.
* :func:`impact` applies the impact law: normal restitution and a Coulomb-capped tangential
  impulse at the contact point.

Vectors in and out are world-frame Cartesian components.
"""

from __future__ import annotations

import math

from creatio.model.offset import offset_jets
from creatio.model.sphere import tangential_part

__all__ = ["FOOT_TOL", "SCALAR_KERNELS", "foot_point", "impact"]

#: Tangential residual |(X - c) . c_i| / |c_i| (m) at which the foot point is accepted.
FOOT_TOL = 1e-13

#: Newton iterations after which the foot point is declared not found.
FOOT_MAX_ITER = 80


def _foot_terms(X1, X2, X3, R, a, R0, k, A, Ka, b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2):
    """Distance terms at (R, alpha): phi = |X - c|^2 / 2, F_i = (X - c) . c_i, the Hessian
    H = c_i . c_j - (X - c) . c_ij of phi, the metric diagonal E, G, the rotating-frame
    offset (d_rho, d_alpha, d_z), the normal components and c_t in that frame."""
    rho, z, nr, na, nz, P, Q, Z = offset_jets(
        R, a, R0, k, A, Ka, b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2
    )
    ca = math.cos(a)
    sa = math.sin(a)
    xr = X1 * ca + X2 * sa
    xa = -X1 * sa + X2 * ca
    dr = xr - rho[0]
    dz = X3 - z[0]
    # c_R = (rho_R, 0, z_R), c_alpha = (rho_a, rho, z_a) in the frame at alpha
    F1 = dr * rho[1] + dz * z[1]
    F2 = dr * rho[2] + xa * rho[0] + dz * z[2]
    E = rho[1] * rho[1] + z[1] * z[1]
    G = rho[2] * rho[2] + rho[0] * rho[0] + z[2] * z[2]
    # dF/dq, with d x_rho / d alpha = x_alpha and d x_alpha / d alpha = -x_rho
    d11 = -E + dr * rho[4] + dz * z[4]
    d12 = (xa - rho[2]) * rho[1] + dr * rho[5] - z[2] * z[1] + dz * z[5]
    d22 = ((xa - rho[2]) * rho[2] + dr * rho[7] - xr * rho[0] + xa * rho[2] - z[2] * z[2]
           + dz * z[7])
    phi = 0.5 * (dr * dr + xa * xa + dz * dz)
    return phi, F1, F2, -d11, -d12, -d22, E, G, dr, xa, dz, nr, na, nz, rho[3], z[3], rho[0]


def foot_point(X1, X2, X3, R, a, R0, k, A, Ka, b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2):
    """The foot point of centre X on the surface at the time of the law values, from the
    guess (R, alpha).

    Returns (found, R*, alpha*, gap, n (3, world), c_t (3, world)): gap = (X - c) . n - b.
    Levenberg-Marquardt on phi = |X - c|^2 / 2 keeps every step descending, so the
    iteration does not jump across a cavity wall where the plain Newton Hessian is
    indefinite; found is False after FOOT_MAX_ITER iterations or a non-finite value.
    """
    lam = 0.0
    t = _foot_terms(X1, X2, X3, R, a, R0, k, A, Ka, b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2)
    found = False
    for _ in range(FOOT_MAX_ITER):
        phi, F1, F2, H11, H12, H22, E, G = t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7]
        if not (math.isfinite(phi) and math.isfinite(F1) and math.isfinite(F2)):
            break
        if math.sqrt(F1 * F1 / E + F2 * F2 / G) <= FOOT_TOL:
            found = True
            break
        moved = False
        for _try in range(40):
            a11 = H11 + lam * E
            a22 = H22 + lam * G
            det = a11 * a22 - H12 * H12
            if a11 > 0.0 and det > 0.0:
                dRq = (a22 * F1 - H12 * F2) / det
                daq = (a11 * F2 - H12 * F1) / det
                tn = _foot_terms(X1, X2, X3, R + dRq, a + daq, R0, k, A, Ka, b, pr, pr1, pr2,
                                 pa, pa1, pa2, gm, g1, g2)
                # descend on phi; near the foot its decrease (|F|^2 / H) falls below the
                # rounding of phi, so a step that shrinks the residual is taken as well
                res_old = F1 * F1 / E + F2 * F2 / G
                res_new = tn[1] * tn[1] / tn[6] + tn[2] * tn[2] / tn[7]
                if tn[0] <= phi * (1.0 + 1e-12) or res_new < res_old:
                    R += dRq
                    a += daq
                    t = tn
                    lam = 0.0 if lam < 1e-6 else 0.25 * lam
                    moved = True
                    break
            lam = 1e-3 if lam == 0.0 else 4.0 * lam
        if not moved:
            # no descending step: converged to rounding if the residual is small
            found = math.sqrt(F1 * F1 / E + F2 * F2 / G) <= 1e3 * FOOT_TOL
            break
    nr, na, nz = t[11], t[12], t[13]
    ca = math.cos(a)
    sa = math.sin(a)
    gap = t[8] * nr + t[9] * na + t[10] * nz - b
    n1 = nr * ca - na * sa
    n2 = nr * sa + na * ca
    ct1 = t[14] * ca
    ct2 = t[14] * sa
    return found, R, a, gap, n1, n2, nz, ct1, ct2, t[15]


def impact(V1, V2, V3, w1, w2, w3, n1, n2, n3, ct1, ct2, ct3, m, inertia, b, e, mu):
    """The impact law of docs/model.md s.11 at the contact point -b n.

    v_n- = (V - c_t) . n < 0 becomes v_n+ = -e v_n-; the tangential impulse opposes the
    slip v_s- of the contact point, j_t = min(m_eff |v_s-|, mu j_n) with
    m_eff = 1 / (1/m + b^2/I) and j_n = m (1 + e) |v_n-|. Returns (V+ (3), omega+ (3),
    v_n-, v_n+, j_n, j_t).
    """
    u1 = V1 - ct1
    u2 = V2 - ct2
    u3 = V3 - ct3
    vn = u1 * n1 + u2 * n2 + u3 * n3
    # contact point velocity relative to the membrane: V + omega x (-b n) - c_t
    s1 = u1 - b * (w2 * n3 - w3 * n2)
    s2 = u2 - b * (w3 * n1 - w1 * n3)
    s3 = u3 - b * (w1 * n2 - w2 * n1)
    s1, s2, s3, slip2 = tangential_part(s1, s2, s3, n1, n2, n3)
    slip = math.sqrt(slip2)
    jn = m * (1.0 + e) * abs(vn)
    meff = 1.0 / (1.0 / m + b * b / inertia)
    jt = min(meff * slip, mu * jn)
    t1 = 0.0
    t2 = 0.0
    t3 = 0.0
    if slip > 0.0 and jt > 0.0:
        t1 = -s1 / slip
        t2 = -s2 / slip
        t3 = -s3 / slip
    # impulse J = j_n n + j_t t on the sphere at -b n
    J1 = jn * n1 + jt * t1
    J2 = jn * n2 + jt * t2
    J3 = jn * n3 + jt * t3
    V1n = V1 + J1 / m
    V2n = V2 + J2 / m
    V3n = V3 + J3 / m
    # angular impulse (-b n) x (j_t t)
    c = -b * jt / inertia
    w1n = w1 + c * (n2 * t3 - n3 * t2)
    w2n = w2 + c * (n3 * t1 - n1 * t3)
    w3n = w3 + c * (n1 * t2 - n2 * t1)
    vnp = (V1n - ct1) * n1 + (V2n - ct2) * n2 + (V3n - ct3) * n3
    return V1n, V2n, V3n, w1n, w2n, w3n, vn, vnp, jn, jt


#: The scalar functions of this module, in dependency order, for the dynamics layer to compile.
SCALAR_KERNELS = (_foot_terms, foot_point, impact)
