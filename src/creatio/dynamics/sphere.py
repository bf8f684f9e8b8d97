"""Compiled right-hand side and per-step diagnostics of the sphere dynamics (docs/model.md s.4-10).

One right-hand side serves every integrator. The first evaluation of a step (``diag``)
also yields every diagnostic (normal reaction, slip, energy, stop conditions, extrema,
curvature), so extrema are taken over all integration steps at no extra cost. Rotation and
energy bookkeeping are compile-time specialisations (literal flags), so switching them off
removes their work instead of branching around it. The formulas themselves are those of
creatio.model (offset jets, contact closed forms, cavity radius and cell), compiled here; the
rotation and energy blocks' rates are one tail shared with the structure path
(creatio.dynamics.structure.rotation_energy_rates).

The structure path (a structure free to yaw, or the normal preload: docs/model.md s.9-10) is
a third literal flag, ``free``: :func:`rhs_of` resolves it at compile time to this module's
:func:`rhs` (the fixed structure of EN-02) or to creatio.dynamics.structure.rhs_structure,
so a run compiles, and executes, only the right-hand side it uses.

Every position in the state, the parameters, the diagnostics, the extrema and the history
table is named in creatio.dynamics.layout.
"""

from __future__ import annotations

import math

import numpy as np
from numba.core import types
from numba.extending import overload, register_jitable
from numba.np.unsafe.ndarray import to_fixed_tuple

from creatio.dynamics import layout
from creatio.dynamics import status as st
from creatio.dynamics.jit import INLINED, inlined, njit
from creatio.dynamics.layout import (
    C_ALPHA0,
    C_DELTA_MAX,
    C_GOAL,
    C_K_OMEGA,
    C_K_THETA,
    C_OMEGA_MAX,
    C_OMEGA_N,
    C_U_MAX,
    C_ZETA,
    COL_ALPHA,
    COL_ALPHADOT,
    COL_AZIMUTH,
    COL_CAVITY_R,
    COL_CELL_U,
    COL_CELL_V,
    COL_CONFINE,
    COL_DISSIPATION,
    COL_ENERGY,
    COL_F,
    COL_HZ_ORBITAL,
    COL_HZ_SPIN,
    COL_HZ_STRUCTURE,
    COL_KINETIC,
    COL_MARKER,
    COL_N,
    COL_OMEGA,
    COL_PHI_A,
    COL_PHI_A_RATE,
    COL_POTENTIAL,
    COL_Q,
    COL_R,
    COL_RESIDUAL,
    COL_SLIP,
    COL_SPEED,
    COL_SPIN,
    COL_SPIN_RATE,
    COL_T,
    COL_THETA,
    COL_THETA_RATE,
    COL_V,
    COL_WORK,
    COL_WORLD_AZIMUTH,
    COL_X,
    CT_PHI,
    CT_RATE,
    D_BK,
    D_N,
    D_SLIP,
    D_X,
    E_AZ,
    E_E0,
    E_HZ0,
    E_LEFT,
    E_MAX_BK,
    E_MAX_HZ_DRIFT,
    E_MAX_IS_THETA,
    E_MAX_N,
    E_MAX_RES,
    E_MAX_RHO,
    E_MAX_SLIP,
    E_MAX_THETA_RATE,
    E_MAX_TRACK,
    E_MIN_CLEAR,
    E_MIN_N,
    EN_CONFINE,
    EN_DISSIPATION,
    EN_WORK,
    LAW_A,
    LAW_CONTROL,
    LAW_GAMMA,
    LAW_R,
    NCTL,
    NCTLS,
    NDIAG,
    NEXT,
    NLAWS,
    NPAR,
    P_B,
    P_DR,
    P_EPS,
    P_G,
    P_GX,
    P_GY,
    P_I,
    P_INV_IS,
    P_IS,
    P_K,
    P_KA,
    P_M,
    P_MCAV,
    P_MU,
    P_NCAV,
    P_R0,
    P_STOP_LEAVE,
    ST_RATE,
    ST_THETA,
    Y_ALPHA,
    Y_ALPHADOT,
    Y_OMEGA,
    Y_Q,
    Y_R,
    Y_RDOT,
    Y_SPIN,
    control_start,
    energy_start,
    state_size,
    structure_start,
)
from creatio.dynamics.structure import rhs_structure, rotation_energy_rates
from creatio.dynamics.surface import surface, surface_with_phase, with_skin
from creatio.model.cavity import cavity_cell_offsets, cavity_radius, in_cavity_cell
from creatio.model.control import servo
from creatio.model.laws import NLAW
from creatio.model.sphere import (
    acceleration_at_fixed_rates,
    centre_tangents,
    max_curvature_times_b,
    normal_reaction,
    normal_reaction_tilted,
    tangent_coordinates,
    tangential_part,
)
from creatio.model.structure import angular_momentum_parts

# The layout's block positions are compiled into the kernels that read them (creatio.dynamics
# .jit registers the model's scalar formulas the same way); LLVM inlines them and folds the
# literal flags, so a position costs nothing at run time.
for _fn in layout.SCALAR_KERNELS:
    register_jitable(forceinline=False)(_fn)


def rhs(t, y, dy, pp, lc, rot, en, diag):
    """Write dy/dt into dy; return the diagnostics tuple (creatio.dynamics.layout D_*: N,
    |v_s|, X, V, f in the rotating frame, phi_r, gamma, b kappa, phi_a).

    pp is the parameter tuple (layout P_*), lc the laws' coefficient vectors (layout LAW_*);
    b kappa (the largest principal curvature times b) is computed only when diag is True
    (compiled code only).
    """
    raise NotImplementedError("called only from compiled code")


@overload(rhs, jit_options=INLINED)
def _rhs_any_diag(t, y, dy, pp, lc, rot, en, diag):
    """:func:`rhs` with diag a run-time flag, whatever its caller passes: a literal diag
    made numba compile the whole right-hand side twice per specialisation (5-7 s cold), for
    a branch around one formula that costs nothing to test."""
    return lambda t, y, dy, pp, lc, rot, en, diag: _rhs(t, y, dy, pp, lc, rot, en, bool(diag))


# allocates nothing: compiled without reference counting (a call takes no reference to its
# arrays, which costs atomic operations every step otherwise); forceinline=False said, so it
# stays one call and never inherits the flag of the inlined rhs wrapper that compiles it
@njit(cache=True, _nrt=False, forceinline=False)
def _rhs(t, y, dy, pp, lc, rot, en, diag):
    """:func:`rhs`, compiled once per (rot, en, law tuple type)."""
    sf, u = surface_state(t, y, pp, lc, rot, en)
    d = rhs_on(sf, y, dy, pp, rot, en, diag)
    control_rates(dy, y, u, lc, rot, en)
    return d


def surface_state(t, y, pp, lc, rot, en):
    """(surface, u): the surface under the contact at (t, y) and the controlled phase's
    acceleration u (0 where the phase is a law of time; compiled code only)."""
    raise NotImplementedError("called only from compiled code")


def control_rates(dy, y, u, lc, rot, en):
    """Write the control block's rates (phidot_a, u) into dy on the controlled path; nothing
    otherwise (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


def _controlled(lc) -> bool:
    """Whether the law tuple's type carries the controller's row (creatio.dynamics.layout
    LAW_CONTROL): the controlled path is then compiled, a compile-time property."""
    return isinstance(lc, types.BaseTuple) and len(lc) > NLAWS


@overload(surface_state, jit_options=INLINED)
def _surface_state(t, y, pp, lc, rot, en):
    """The laws' surface (as it always was), or on the controlled path the surface at the
    state's phase and the servo's u (creatio.model.control.servo)."""
    if not _controlled(lc):
        def impl(t, y, pp, lc, rot, en):
            return surface(t, y[Y_R], y[Y_ALPHA], pp, lc), 0.0
        return impl

    def controlled(t, y, pp, lc, rot, en):
        ic = control_start(rot, en)
        c = lc[LAW_CONTROL]
        pa = y[ic + CT_PHI]
        pa1 = y[ic + CT_RATE]
        u, _, _, _ = servo(y[Y_ALPHA], y[Y_ALPHADOT], pa, pa1, pp[P_KA], c[C_GOAL],
                           c[C_ALPHA0], c[C_K_THETA], c[C_K_OMEGA], c[C_OMEGA_MAX],
                           c[C_DELTA_MAX], c[C_OMEGA_N], c[C_ZETA], c[C_U_MAX])
        return surface_with_phase(t, y[Y_R], y[Y_ALPHA], pp, lc, pa, pa1, u), u
    return controlled


def control_columns(lc):
    """How many state columns the control block adds to the feedback (the Jacobian's
    differenced columns, creatio.dynamics.solvers.radau5.jacobian): NCTLS on the controlled
    path, 0 otherwise (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


@overload(control_columns, inline="always")
def _control_columns(lc):
    """NCTLS where the law tuple carries the controller's row, else 0 (a compile-time
    property of lc's type)."""
    if not _controlled(lc):
        return lambda lc: 0
    return lambda lc: NCTLS


@overload(control_rates, inline="always")
def _control_rates(dy, y, u, lc, rot, en):
    """phi_a' = phidot_a, phidot_a' = u on the controlled path; nothing otherwise."""
    if not _controlled(lc):
        return lambda dy, y, u, lc, rot, en: None

    def controlled(dy, y, u, lc, rot, en):
        ic = control_start(rot, en)
        dy[ic + CT_PHI] = y[ic + CT_RATE]
        dy[ic + CT_RATE] = u
    return controlled


@inlined
def rhs_on(sf: tuple, y: np.ndarray, dy: np.ndarray, pp: tuple, rot: bool, en: bool,
           diag: bool) -> tuple:
    """:func:`rhs` on the surface sf = creatio.dynamics.surface.surface at y's (t, R, alpha),
    so that states sharing (t, R, alpha) share its evaluation."""
    m = pp[P_M]
    b = pp[P_B]
    g = pp[P_G]
    mu = pp[P_MU]
    eps = pp[P_EPS]
    pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z = sf
    a = y[Y_ALPHA]
    Rd = y[Y_RDOT]
    ad = y[Y_ALPHADOT]
    xR1, xR2, xR3, xa1, xa2, xa3, xt1, xt2, xt3 = centre_tangents(P, Q, Z)
    a01, a02, a03 = acceleration_at_fixed_rates(P, Q, Z, Rd, ad)
    g1, g2, tilt = horizontal_gravity(pp, a)
    if tilt:
        N = normal_reaction_tilted(m, g1, g2, g, n1, n2, n3, a01, a02, a03)
    else:
        N = normal_reaction(m, g, n1, n2, n3, a01, a02, a03)
    V1 = xt1 + xR1 * Rd + xa1 * ad
    V2 = xt2 + xR2 * Rd + xa2 * ad
    V3 = xt3 + xR3 * Rd + xa3 * ad
    ct1 = rho[3]
    ct3 = z[3]
    # relative velocity of the sphere's contact point and the membrane, tangential part
    u1 = V1 - ct1
    u2 = V2
    u3 = V3 - ct3
    ca = 0.0
    sa = 0.0
    w1 = 0.0
    w2 = 0.0
    w3 = 0.0
    if rot:
        ca = math.cos(a)
        sa = math.sin(a)
        wx = y[Y_OMEGA]
        wy = y[Y_OMEGA + 1]
        w3 = y[Y_OMEGA + 2]
        w1 = wx * ca + wy * sa
        w2 = wy * ca - wx * sa
        u1 -= b * (w2 * n3 - w3 * n2)
        u2 -= b * (w3 * n1 - w1 * n3)
        u3 -= b * (w1 * n2 - w2 * n1)
    vs1, vs2, vs3, slip2 = tangential_part(u1, u2, u3, n1, n2, n3)
    fc = 0.0
    if mu > 0.0:
        fc = -mu * N / math.sqrt(slip2 + eps * eps)
    f1 = fc * vs1
    f2 = fc * vs2
    f3 = fc * vs3
    # (J^T J) qddot = J^T (g + f/m - a0)
    r1 = f1 / m - a01
    r2 = f2 / m - a02
    r3 = f3 / m - g - a03
    if tilt:
        r1 += g1
        r2 += g2
    dy[Y_R] = Rd
    dy[Y_ALPHA] = ad
    dy[Y_RDOT], dy[Y_ALPHADOT] = tangent_coordinates(xR1, xR2, xR3, xa1, xa2, xa3, r1, r2, r3)
    # omega turned from the rotating frame at alpha back to the world
    rotation_energy_rates(dy, y, pp, rot, en, N, n1, n2, n3, f1, f2, f3, vs1, vs2, vs3, ct1,
                          ct3, ca, sa)
    bk = 0.0
    if diag:
        bk = max_curvature_times_b(rho, z, n1, n2, n3, b)
    return N, math.sqrt(slip2), P[0], Q[0], Z[0], V1, V2, V3, f1, f2, f3, pr, gm, bk, pa


@njit(cache=True, inline="always")
def horizontal_gravity(pp, a):
    """(g1, g2, tilted): gravity's horizontal part (layout P_GX, P_GY) turned into the
    rotating frame at alpha, and whether there is one (a mounting tilt, docs/model.md s.4);
    without tilt the callers keep their level-membrane arithmetic, bit for bit."""
    gx = pp[P_GX]
    gy = pp[P_GY]
    if gx == 0.0 and gy == 0.0:
        return 0.0, 0.0, False
    ca = math.cos(a)
    sa = math.sin(a)
    return gx * ca + gy * sa, gy * ca - gx * sa, True


def rhs_of(free, t, y, dy, pp, lc, rot, en, diag):
    """The right-hand side of the fixed structure (:func:`rhs`) or of the structure path
    (creatio.dynamics.structure.rhs_structure), chosen by the literal flag free at compile
    time (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


@overload(rhs_of, prefer_literal=True, inline="always")
def _rhs_of(free, t, y, dy, pp, lc, rot, en, diag):
    """Resolve rhs_of on the literal free: the fixed structure never types the structure path."""
    if not isinstance(free, types.BooleanLiteral):
        return None
    if free.literal_value:
        def impl(free, t, y, dy, pp, lc, rot, en, diag):
            return rhs_structure(t, y, dy, pp, lc, rot, en, diag)
    else:
        def impl(free, t, y, dy, pp, lc, rot, en, diag):
            return rhs(t, y, dy, pp, lc, rot, en, diag)
    return impl


@njit(cache=True)
def store(d, buf):
    """Copy the diagnostics tuple of rhs into buf (an array carries them between steps more
    cheaply than a tuple held in registers across the loop)."""
    for i in range(NDIAG):
        buf[i] = d[i]


@njit(cache=True)
def load(buf):
    """The diagnostics tuple stored by :func:`store`."""
    return to_fixed_tuple(buf, NDIAG)


@njit(cache=True)
def pack_controlled(p, lawc):
    """:func:`pack` of the controlled path: the parameter vector p holds the controller's row
    (layout C_*) after its NPAR parameters, and the law tuple gains it as LAW_CONTROL."""
    lc = (to_fixed_tuple(lawc[LAW_R], NLAW), to_fixed_tuple(lawc[LAW_A], NLAW),
          to_fixed_tuple(lawc[LAW_GAMMA], NLAW), to_fixed_tuple(p[NPAR:], NCTL))
    return to_fixed_tuple(p[:NPAR], NPAR), lc


def pack_run(ctl, p, lawc):
    """The parameter and law tuples of a run's loop: :func:`pack`, or :func:`pack_controlled`
    on the controlled path (compiled code only; resolved at compile time on the literal
    ctl)."""
    raise NotImplementedError("called only from compiled code")


@overload(pack_run, prefer_literal=True, inline="always")
def _pack_run(ctl, p, lawc):
    """pack, or pack_controlled on the controlled path (the law tuple then carries the
    controller's row, which selects that path in the right-hand side)."""
    if not isinstance(ctl, types.BooleanLiteral):
        return None
    if isinstance(p, types.BaseTuple):  # a rib surface: (parameter vector, skin table)
        if ctl.literal_value:
            return lambda ctl, p, lawc: with_skin(pack_controlled(p[0], lawc), p[1])
        return lambda ctl, p, lawc: with_skin(pack(p[0], lawc), p[1])
    if ctl.literal_value:
        return lambda ctl, p, lawc: pack_controlled(p, lawc)
    return lambda ctl, p, lawc: pack(p, lawc)


@njit(cache=True)
def pack(p, lawc):
    """The parameter and law tuples the kernels read, from the plain arrays (unpacked once,
    outside the loop): pp the parameter vector (layout P_*), lc the three laws' coefficient
    vectors (layout LAW_*, each laid out by creatio.model.laws L_*)."""
    lc = (to_fixed_tuple(lawc[LAW_R], NLAW), to_fixed_tuple(lawc[LAW_A], NLAW),
          to_fixed_tuple(lawc[LAW_GAMMA], NLAW))
    return to_fixed_tuple(p, NPAR), lc


@register_jitable(forceinline=False)
def new_extrema(en):
    """Running extrema before the first step (max residual is NaN without energy); plain
    numpy, so the driver's caller allocates them in Python."""
    ext = np.zeros(NEXT)
    ext[E_MIN_N] = math.inf
    ext[E_MAX_N] = -math.inf
    ext[E_MAX_RES] = 0.0 if en else math.nan
    ext[E_MIN_CLEAR] = math.inf
    ext[E_MAX_BK] = -math.inf
    ext[E_LEFT] = math.nan
    return ext


# allocates nothing: compiled without reference counting (a call takes no reference to its
# arrays, which costs atomic operations every step otherwise)
@njit(cache=True, _nrt=False)
def observe(first, t, y, d, pp, ext, out, row, final, sample, rot, en, free):
    """Diagnostics of one step start: update extrema, test the stop conditions, write a row.

    d is the diagnostic tuple of rhs at (t, y). A row is written when the step is on the
    output grid (sample), is the last one (final) or stops the run. Every run records the
    first time its contact point is outside the starting cavity's cell (docs/model.md s.8.2);
    the structure path (free) also tracks theta, H_z and the energy of s.9-10. Returns
    (status, rows written).
    """
    N, slip, X1, X2, X3, V1, V2, V3, f1, f2, f3, pr, gm, bk, pa = d
    R0 = pp[P_R0]
    dR = pp[P_DR]
    k = pp[P_K]
    m = pp[P_M]
    b = pp[P_B]
    g = pp[P_G]
    inertia = pp[P_I]
    ncav = pp[P_NCAV]
    ie = energy_start(rot)
    two_pi = 2.0 * math.pi
    R = y[Y_R]
    a = y[Y_ALPHA]
    # centre's coordinate along the generator e_g (docs/model.md s.1 inverse map); at
    # gamma = 0 it is rho - R0, so clear = min(rho - b - R0, R1 - rho - b)
    sx = (math.sqrt(X1 * X1 + X2 * X2) - R0) * math.cos(gm) + X3 * math.sin(gm)
    clear = min(sx - b, dR - sx - b)
    rc = cavity_radius(pr, k, ncav)
    track = abs(R - rc)
    du, dv = cavity_cell_offsets(R, a, pr, pa, k, pp[P_KA], ncav, pp[P_MCAV])
    inside = in_cavity_cell(du, dv)
    if not inside and math.isnan(ext[E_LEFT]):
        ext[E_LEFT] = t
    theta = 0.0
    Th = 0.0
    h_s = 0.0
    h_o = 0.0
    h_w = 0.0
    if free:
        # structure path (docs/model.md s.9): V is relative to the structure, V_abs adds
        # Theta z^ x X; H_z is frame-invariant; I_s = inf (fixed) makes its part NaN
        iy = structure_start(rot, en)
        theta = y[iy + ST_THETA]
        Th = y[iy + ST_RATE]
        wz = y[Y_OMEGA + 2] if rot else 0.0
        h_s, h_o, h_w = angular_momentum_parts(pp[P_IS], Th, m, X1, X2, V1, V2, inertia, wz)
        hz = h_s + h_o + h_w
        if first:
            ext[E_HZ0] = hz
        if abs(hz - ext[E_HZ0]) > ext[E_MAX_HZ_DRIFT]:
            ext[E_MAX_HZ_DRIFT] = abs(hz - ext[E_HZ0])
        if abs(h_s) > ext[E_MAX_IS_THETA]:
            ext[E_MAX_IS_THETA] = abs(h_s)
        if abs(Th) > ext[E_MAX_THETA_RATE]:
            ext[E_MAX_THETA_RATE] = abs(Th)
        rx = math.sqrt(X1 * X1 + X2 * X2) + b
        if rx > ext[E_MAX_RHO]:
            ext[E_MAX_RHO] = rx
    kin = math.nan
    pot = math.nan
    energy = math.nan
    res = math.nan
    if en:
        if free:
            Va1 = V1 - Th * X2
            Va2 = V2 + Th * X1
            kin = 0.5 * m * (Va1 * Va1 + Va2 * Va2 + V3 * V3)
            if pp[P_INV_IS] > 0.0:
                kin += 0.5 * Th * Th / pp[P_INV_IS]
        else:
            kin = 0.5 * m * (V1 * V1 + V2 * V2 + V3 * V3)
        if rot:
            kin += 0.5 * inertia * (y[Y_OMEGA] * y[Y_OMEGA] + y[Y_OMEGA + 1] * y[Y_OMEGA + 1]
                                    + y[Y_OMEGA + 2] * y[Y_OMEGA + 2])
        pot = m * g * X3
        g1, g2, tilt = horizontal_gravity(pp, a)
        if tilt:
            pot -= m * (g1 * X1 + g2 * X2)
        energy = kin + pot
        if first:
            ext[E_E0] = energy
        res = energy - ext[E_E0] - y[ie + EN_WORK] + y[ie + EN_DISSIPATION]
        if free:
            res -= y[ie + EN_CONFINE]
        if abs(res) > ext[E_MAX_RES]:
            ext[E_MAX_RES] = abs(res)
    raw = a + math.atan2(X2, X1)
    if first:
        az = math.atan2(math.sin(raw), math.cos(raw))
    else:
        az = raw + two_pi * np.rint((ext[E_AZ] - raw) / two_pi)
    ext[E_AZ] = az
    if N < ext[E_MIN_N]:
        ext[E_MIN_N] = N
    if N > ext[E_MAX_N]:
        ext[E_MAX_N] = N
    if slip > ext[E_MAX_SLIP]:
        ext[E_MAX_SLIP] = slip
    if track > ext[E_MAX_TRACK]:
        ext[E_MAX_TRACK] = track
    if clear < ext[E_MIN_CLEAR]:
        ext[E_MIN_CLEAR] = clear
    if bk > ext[E_MAX_BK]:
        ext[E_MAX_BK] = bk
    total = N + slip + X1 + X2 + X3 + bk
    for j in range(y.size):
        total += y[j]
    status = st.OK
    if not math.isfinite(total):
        status = st.NON_FINITE
    elif N <= 0.0:
        status = st.CONTACT_LOST
    elif R < 0.0 or R > dR:
        status = st.LEFT_ANNULUS
    elif clear < 0.0:
        status = st.EDGE_CROSSED
    elif bk >= 1.0:
        status = st.OFFSET_SINGULAR
    elif not inside and pp[P_STOP_LEAVE] > 0.0:
        status = st.LEFT_CAVITY
    if not (status != st.OK or final or sample):
        return status, 0
    ca = math.cos(a)
    sa = math.sin(a)
    out[row, COL_T] = t
    out[row, COL_X] = X1 * ca - X2 * sa
    out[row, COL_X + 1] = X1 * sa + X2 * ca
    out[row, COL_X + 2] = X3
    out[row, COL_R] = R
    out[row, COL_ALPHA] = a
    out[row, COL_V] = V1 * ca - V2 * sa
    out[row, COL_V + 1] = V1 * sa + V2 * ca
    out[row, COL_V + 2] = V3
    out[row, COL_SPEED] = math.sqrt(V1 * V1 + V2 * V2 + V3 * V3)
    out[row, COL_N] = N
    out[row, COL_F] = f1 * ca - f2 * sa
    out[row, COL_F + 1] = f1 * sa + f2 * ca
    out[row, COL_F + 2] = f3
    out[row, COL_SLIP] = slip
    if rot:
        wx = y[Y_OMEGA]
        wy = y[Y_OMEGA + 1]
        wz = y[Y_OMEGA + 2]
        q0, q1, q2, q3 = unit_quaternion(y[Y_Q], y[Y_Q + 1], y[Y_Q + 2], y[Y_Q + 3])
        spin = y[Y_SPIN]
    else:
        wx = 0.0
        wy = 0.0
        wz = 0.0
        q0 = 1.0
        q1 = 0.0
        q2 = 0.0
        q3 = 0.0
        spin = 0.0
    write_attitude(out, row, wx, wy, wz, q0, q1, q2, q3, spin)
    out[row, COL_AZIMUTH] = az
    out[row, COL_KINETIC] = kin
    out[row, COL_POTENTIAL] = pot
    out[row, COL_ENERGY] = energy
    out[row, COL_WORK] = y[ie + EN_WORK] if en else math.nan
    out[row, COL_DISSIPATION] = y[ie + EN_DISSIPATION] if en else math.nan
    out[row, COL_RESIDUAL] = res
    out[row, COL_CAVITY_R] = rc
    out[row, COL_CELL_U] = du
    out[row, COL_CELL_V] = dv
    if free:
        out[row, COL_THETA] = theta
        out[row, COL_THETA_RATE] = Th
        out[row, COL_HZ_STRUCTURE] = h_s
        out[row, COL_HZ_ORBITAL] = h_o
        out[row, COL_HZ_SPIN] = h_w
        out[row, COL_CONFINE] = y[ie + EN_CONFINE] if en else math.nan
        out[row, COL_WORLD_AZIMUTH] = az + theta
    out[row, COL_PHI_A] = pa
    out[row, COL_ALPHADOT] = y[Y_ALPHADOT]
    # the controlled phase's rate, where the state carries it (docs/model.md s.12.2)
    ic = state_size(rot, en, free)
    out[row, COL_PHI_A_RATE] = y[ic + CT_RATE] if y.size > ic else math.nan
    return status, 1


@njit(cache=True, inline="always")
def unit_quaternion(q0, q1, q2, q3):
    """Q normalised for reporting (docs/model.md s.4.6: never inside the right-hand side)."""
    qn = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return q0 * qn, q1 * qn, q2 * qn, q3 * qn


@njit(cache=True, inline="always")
def write_attitude(out, row, wx, wy, wz, q0, q1, q2, q3, spin):
    """The history row's rotation columns: omega, |omega|, the spin, the unit quaternion and
    the image of the body marker (0, 0, 1)."""
    out[row, COL_OMEGA] = wx
    out[row, COL_OMEGA + 1] = wy
    out[row, COL_OMEGA + 2] = wz
    out[row, COL_SPIN_RATE] = math.sqrt(wx * wx + wy * wy + wz * wz)
    out[row, COL_SPIN] = spin
    out[row, COL_Q] = q0
    out[row, COL_Q + 1] = q1
    out[row, COL_Q + 2] = q2
    out[row, COL_Q + 3] = q3
    out[row, COL_MARKER] = 2.0 * (q1 * q3 + q0 * q2)
    out[row, COL_MARKER + 1] = 2.0 * (q2 * q3 - q0 * q1)
    out[row, COL_MARKER + 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3


@njit(cache=True)
def evaluate(
    p: np.ndarray, lawc: np.ndarray, y: np.ndarray, t: float
) -> tuple[np.ndarray, float, float, float]:
    """One right-hand-side evaluation of a full (rotation + energy) state at time t.

    Returns (dy/dt, N, |v_s|, b kappa); used for a-priori estimates and tests.
    """
    pp, lc = pack(p, lawc)
    dy = np.empty(y.size)
    d = rhs(t, y, dy, pp, lc, True, True, True)
    return dy, d[D_N], d[D_SLIP], d[D_BK]


@njit(cache=True)
def evaluate_structure(p, lawc, y, t):
    """:func:`evaluate` on the structure path: a full (rotation + energy) state with theta,
    Theta last; returns (dy/dt, N, |v_s|, b kappa)."""
    pp, lc = pack(p, lawc)
    dy = np.empty(y.size)
    d = rhs_structure(t, y, dy, pp, lc, True, True, True)
    return dy, d[D_N], d[D_SLIP], d[D_BK]


@njit(cache=True)
def derivative(p, lawc, t, y, rot, en):
    """dy/dt of one state (the right-hand side every integrator uses), as a new array."""
    pp, lc = pack(p, lawc)
    dy = np.empty(y.size)
    rhs(t, y, dy, pp, lc, rot, en, False)
    return dy


@njit(cache=True, inline="always")
def world_centre(d, a):
    """The centre of diagnostics d turned from the rotating frame at alpha to the world."""
    ca = math.cos(a)
    sa = math.sin(a)
    return d[D_X] * ca - d[D_X + 1] * sa, d[D_X] * sa + d[D_X + 1] * ca, d[D_X + 2]


@njit(cache=True)
def centre_positions(p, lawc, t, states, rot, en):
    """World-frame sphere centres X (n, 3) of states (n, size) at times t (n,).

    The same formula the loops write into the histories (rotating-frame X turned by alpha),
    so an error measured from states equals the one measured from a loop's histories.
    """
    pp, lc = pack(p, lawc)
    n = t.size
    X = np.empty((n, 3))
    dy = np.empty(states.shape[1])
    for i in range(n):
        y = states[i]
        d = rhs(t[i], y, dy, pp, lc, rot, en, False)
        X[i, 0], X[i, 1], X[i, 2] = world_centre(d, y[Y_ALPHA])
    return X
