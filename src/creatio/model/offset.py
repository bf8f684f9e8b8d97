"""Exact kinematics of the sphere centre X(q, t) = c(q, t) + b n(q, t) (docs/model.md s.1, s.4).

Everything is computed in the rotating cylindrical frame (e_rho, e_alpha, e_z) at the
current alpha, as scalar second-order jets in the three variables (R, alpha, t): a jet is a
10-tuple (value, _R, _a, _t, _RR, _Ra, _Rt, _aa, _at, _tt). A vector field
P e_rho + Q e_alpha + Z e_z is stored as the jets of its three frame components; its alpha
derivative is (P_a - Q) e_rho + (Q_a + P) e_alpha + Z_a e_z, while R and t act
componentwise. The normal needs c_R and c_alpha to second order, i.e. third derivatives
of W (never W_ttt), which are obtained exactly by forward-mode jet arithmetic; no finite
differences anywhere.

Plain scalar Python on purpose: the dynamics layer compiles these same functions into its
loops (every name in SCALAR_KERNELS), and planning code can evaluate them without a
compiler.
"""

from __future__ import annotations

import math

__all__ = ["INLINED_KERNELS", "SCALAR_KERNELS", "offset_jets", "offset_jets_of", "offset_jets_skin",
           "quintic_jet", "skin_jets"]


def jmul(x, y):
    """Product of two full jets."""
    x0 = x[0]
    y0 = y[0]
    return (
        x0 * y0,
        x[1] * y0 + x0 * y[1],
        x[2] * y0 + x0 * y[2],
        x[3] * y0 + x0 * y[3],
        x[4] * y0 + 2.0 * x[1] * y[1] + x0 * y[4],
        x[5] * y0 + x[1] * y[2] + x[2] * y[1] + x0 * y[5],
        x[6] * y0 + x[1] * y[3] + x[3] * y[1] + x0 * y[6],
        x[7] * y0 + 2.0 * x[2] * y[2] + x0 * y[7],
        x[8] * y0 + x[2] * y[3] + x[3] * y[2] + x0 * y[8],
        x[9] * y0 + 2.0 * x[3] * y[3] + x0 * y[9],
    )


def jsq(x):
    """Square of a full jet."""
    x0 = x[0]
    return (
        x0 * x0,
        2.0 * x0 * x[1],
        2.0 * x0 * x[2],
        2.0 * x0 * x[3],
        2.0 * (x0 * x[4] + x[1] * x[1]),
        2.0 * (x0 * x[5] + x[1] * x[2]),
        2.0 * (x0 * x[6] + x[1] * x[3]),
        2.0 * (x0 * x[7] + x[2] * x[2]),
        2.0 * (x0 * x[8] + x[2] * x[3]),
        2.0 * (x0 * x[9] + x[3] * x[3]),
    )


def jlin(a, x, b, y):
    """Linear combination a x + b y of two full jets."""
    return (
        a * x[0] + b * y[0],
        a * x[1] + b * y[1],
        a * x[2] + b * y[2],
        a * x[3] + b * y[3],
        a * x[4] + b * y[4],
        a * x[5] + b * y[5],
        a * x[6] + b * y[6],
        a * x[7] + b * y[7],
        a * x[8] + b * y[8],
        a * x[9] + b * y[9],
    )


def jscale(a, x):
    """Scalar multiple a x of a full jet."""
    return (
        a * x[0],
        a * x[1],
        a * x[2],
        a * x[3],
        a * x[4],
        a * x[5],
        a * x[6],
        a * x[7],
        a * x[8],
        a * x[9],
    )


def jcompose(x, f0, f1, f2):
    """f(x) for a scalar function with f(x0) = f0, f'(x0) = f1, f''(x0) = f2."""
    return (
        f0,
        f1 * x[1],
        f1 * x[2],
        f1 * x[3],
        f1 * x[4] + f2 * x[1] * x[1],
        f1 * x[5] + f2 * x[1] * x[2],
        f1 * x[6] + f2 * x[1] * x[3],
        f1 * x[7] + f2 * x[2] * x[2],
        f1 * x[8] + f2 * x[2] * x[3],
        f1 * x[9] + f2 * x[3] * x[3],
    )


def jmixed(s, f, F, h, H):
    """s F(R, t) H(alpha, t); F = (v, R, t, RR, Rt, tt), H = (v, a, t, aa, at, tt)."""
    f0, fR, ft, fRR, fRt, ftt = f * F[0], f * F[1], f * F[2], f * F[3], f * F[4], f * F[5]
    h0, ha, ht, haa, hat, htt = h * H[0], h * H[1], h * H[2], h * H[3], h * H[4], h * H[5]
    return (
        s * f0 * h0,
        s * fR * h0,
        s * f0 * ha,
        s * (ft * h0 + f0 * ht),
        s * fRR * h0,
        s * fR * ha,
        s * (fRt * h0 + fR * ht),
        s * f0 * haa,
        s * (ft * ha + f0 * hat),
        s * (ftt * h0 + 2.0 * ft * ht + f0 * htt),
    )


def jtmul(x, h0, h1, h2):
    """Full jet x times a function of t alone with value h0, h' = h1, h'' = h2."""
    return (
        x[0] * h0,
        x[1] * h0,
        x[2] * h0,
        x[3] * h0 + x[0] * h1,
        x[4] * h0,
        x[5] * h0,
        x[6] * h0 + x[1] * h1,
        x[7] * h0,
        x[8] * h0 + x[2] * h1,
        x[9] * h0 + 2.0 * x[3] * h1 + x[0] * h2,
    )


def offset_jets(
    R: float,
    a: float,
    R0: float,
    k: float,
    A: float,
    Ka: float,
    b: float,
    pr: float,
    pr1: float,
    pr2: float,
    pa: float,
    pa1: float,
    pa2: float,
    gm: float,
    g1: float,
    g2: float,
) -> tuple:
    """Jets of c, n and X = c + b n in the rotating frame at (R, alpha) on the ideal surface.

    Inputs are the surface constants and the law values (phi_r, phi_a, gamma with their
    first two time derivatives) at the current time. Returns (rho, z, n_rho, n_alpha, n_z,
    P, Q, Z): rho and z are the jets of c = rho e_rho + z e_z, n_* the components of the unit
    normal (values), P, Q, Z the jets of the components of X.
    """
    v = Ka * a + pa
    sv = math.sin(v)
    cv = math.cos(v)
    # (alpha, t) jets of sin v, cos v: W_alpha = -A Ka sin(u) sin(v)
    pa1s = pa1 * pa1
    kas = Ka * Ka
    jsv = (sv, Ka * cv, pa1 * cv, -kas * sv, -Ka * pa1 * sv, pa2 * cv - pa1s * sv)
    jcv = (cv, -Ka * sv, -pa1 * sv, -kas * cv, -Ka * pa1 * cv, -pa2 * sv - pa1s * cv)
    return offset_jets_of(R, R0, k, A, b, pr, pr1, pr2, jcv, -A * Ka, jsv, gm, g1, g2)


def quintic_jet(c0: float, c1: float, c2: float, c3: float, c4: float, c5: float, x: float,
                inv_h: float) -> tuple:
    """(S, S_a, S_aa, S_aaa) of S = sum_p c_p x^p at x = (alpha - alpha_j) / h, derivatives in
    alpha (each x derivative times 1 / h), by Horner."""
    h2 = inv_h * inv_h
    return (
        ((((c5 * x + c4) * x + c3) * x + c2) * x + c1) * x + c0,
        inv_h * ((((5.0 * c5 * x + 4.0 * c4) * x + 3.0 * c3) * x + 2.0 * c2) * x + c1),
        h2 * (((20.0 * c5 * x + 12.0 * c4) * x + 6.0 * c3) * x + 2.0 * c2),
        h2 * inv_h * ((60.0 * c5 * x + 24.0 * c4) * x + 6.0 * c3),
    )


def skin_jets(a: float, pa: float, pa1: float, pa2: float, table) -> tuple:
    """(alpha, t) jets of the rib skin H = cos(phi_a) S_c - sin(phi_a) S_s and of H_alpha,
    each (v, a, t, aa, at, tt), from the spline table of creatio.model.ribs.skin_table (row
    j: the power coefficients of S_c then S_s in x = (alpha - alpha_j) / h on interval j).
    With G = sin(phi_a) S_c + cos(phi_a) S_s: H_t = -phi_a' G, H_tt = -phi_a'' G - phi_a'^2 H.
    """
    n = table.shape[0]
    inv_h = n / (2.0 * math.pi)
    q = a * inv_h
    fj = math.floor(q)
    x = q - fj
    j = int(fj) % n
    # S and its first three alpha derivatives, of S_c (columns 0-5) and S_s (6-11)
    c = quintic_jet(table[j, 0], table[j, 1], table[j, 2], table[j, 3], table[j, 4],
                    table[j, 5], x, inv_h)
    s = quintic_jet(table[j, 6], table[j, 7], table[j, 8], table[j, 9], table[j, 10],
                    table[j, 11], x, inv_h)
    cp = math.cos(pa)
    sp = math.sin(pa)
    H0 = cp * c[0] - sp * s[0]
    H1 = cp * c[1] - sp * s[1]
    H2 = cp * c[2] - sp * s[2]
    H3 = cp * c[3] - sp * s[3]
    G0 = sp * c[0] + cp * s[0]
    G1 = sp * c[1] + cp * s[1]
    G2 = sp * c[2] + cp * s[2]
    pa1s = pa1 * pa1
    jH = (H0, H1, -pa1 * G0, H2, -pa1 * G1, -pa2 * G0 - pa1s * H0)
    jHa = (H1, H2, -pa1 * G1, H3, -pa1 * G2, -pa2 * G1 - pa1s * H1)
    return jH, jHa


def offset_jets_skin(
    R: float,
    a: float,
    R0: float,
    k: float,
    A: float,
    b: float,
    pr: float,
    pr1: float,
    pr2: float,
    pa: float,
    pa1: float,
    pa2: float,
    gm: float,
    g1: float,
    g2: float,
    table,
) -> tuple:
    """:func:`offset_jets` on a rib surface, W = A sin(u) H(alpha, t) with the spline skin H
    of the rib table (creatio.model.ribs, docs/model.md s.14.4)."""
    jH, jHa = skin_jets(a, pa, pa1, pa2, table)
    return offset_jets_of(R, R0, k, A, b, pr, pr1, pr2, jH, A, jHa, gm, g1, g2)


def offset_jets_of(
    R: float,
    R0: float,
    k: float,
    A: float,
    b: float,
    pr: float,
    pr1: float,
    pr2: float,
    jH: tuple,
    s_a: float,
    jHa: tuple,
    gm: float,
    g1: float,
    g2: float,
) -> tuple:
    """The offset jets of W = A sin(u) H(alpha, t), given the (alpha, t) jets of H (jH) and
    of W_alpha / (s_a sin u) (jHa, scaled by s_a), each (v, a, t, aa, at, tt): the part of
    :func:`offset_jets` every surface kind shares (returns the same tuple)."""
    u = k * R + pr
    su = math.sin(u)
    cu = math.cos(u)
    sg = math.sin(gm)
    cg = math.cos(gm)
    # (R, t) jets of sin u, cos u
    pr1s = pr1 * pr1
    ksq = k * k
    jsu = (su, k * cu, pr1 * cu, -ksq * su, -k * pr1 * su, pr2 * cu - pr1s * su)
    jcu = (cu, -k * su, -pr1 * su, -ksq * cu, -k * pr1 * cu, -pr2 * su - pr1s * cu)
    W = jmixed(A, 1.0, jsu, 1.0, jH)
    WR = jmixed(A * k, 1.0, jcu, 1.0, jH)
    Wa = jmixed(s_a, 1.0, jsu, 1.0, jHa)
    # t jets of cos(gamma), sin(gamma)
    cg1 = -g1 * sg
    cg2 = -g2 * sg - g1 * g1 * cg
    sg1 = g1 * cg
    sg2 = g2 * cg - g1 * g1 * sg
    # rho = R0 + R cos g - W sin g,  z = R sin g + W cos g
    Rcg = (R * cg + R0, cg, 0.0, R * cg1, 0.0, 0.0, cg1, 0.0, 0.0, R * cg2)
    Rsg = (R * sg, sg, 0.0, R * sg1, 0.0, 0.0, sg1, 0.0, 0.0, R * sg2)
    rho = jlin(1.0, Rcg, -1.0, jtmul(W, sg, sg1, sg2))
    z = jlin(1.0, Rsg, 1.0, jtmul(W, cg, cg1, cg2))
    # frame components of c_R = (rho_R, 0, z_R) and c_alpha = (rho_a, rho, z_a) as jets
    jcg = (cg, 0.0, 0.0, cg1, 0.0, 0.0, 0.0, 0.0, 0.0, cg2)
    jsg = (sg, 0.0, 0.0, sg1, 0.0, 0.0, 0.0, 0.0, 0.0, sg2)
    rho_R = jlin(1.0, jcg, -1.0, jtmul(WR, sg, sg1, sg2))
    z_R = jlin(1.0, jsg, 1.0, jtmul(WR, cg, cg1, cg2))
    rho_a = jtmul(Wa, -sg, -sg1, -sg2)
    z_a = jtmul(Wa, cg, cg1, cg2)
    # N = c_R x c_alpha = (-z_R rho, z_R rho_a - rho_R z_a, rho_R rho); N1 = -N_rho
    N1 = jmul(z_R, rho)
    N2 = jlin(1.0, jmul(z_R, rho_a), -1.0, jmul(rho_R, z_a))
    N3 = jmul(rho_R, rho)
    ss = jsq(N1)
    s2 = jsq(N2)
    s3 = jsq(N3)
    s = jlin(1.0, jlin(1.0, ss, 1.0, s2), 1.0, s3)
    inv = 1.0 / math.sqrt(s[0])
    inv3 = inv * inv * inv
    jinv = jcompose(s, inv, -0.5 * inv3, 0.75 * inv3 * inv * inv)
    n1 = jmul(N1, jinv)  # -n_rho
    n2 = jmul(N2, jinv)
    n3 = jmul(N3, jinv)
    P = jlin(1.0, rho, -b, n1)
    Q = jscale(b, n2)
    Z = jlin(1.0, z, b, n3)
    return rho, z, -n1[0], n2[0], n3[0], P, Q, Z


#: The scalar functions of this module, in dependency order, for the dynamics layer to compile.
SCALAR_KERNELS = (jmul, jsq, jlin, jscale, jcompose, jmixed, jtmul, offset_jets_of, offset_jets,
                  quintic_jet, skin_jets, offset_jets_skin)
#: Of those, the ones a compiled caller must inline (creatio.dynamics.jit): the offset jets
#: return 53 numbers, which a call would pass through memory.
INLINED_KERNELS = (offset_jets_of, offset_jets, offset_jets_skin)
