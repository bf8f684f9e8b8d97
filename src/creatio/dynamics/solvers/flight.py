"""The hybrid loop: contact and flight phases with located events (docs/model.md s.11).

A separate compiled loop, so that runs with flight disabled compile and execute the one
driver (creatio.dynamics.solvers.driver) exactly as before; around each step it runs the
driver's controller (creatio.dynamics.solvers.driver.accepted_step: budget, progress lines,
step-size floors, accept or reject) with its own try at a step of either phase (:func:`_try`),
and adds the phases and their events between steps. It runs any explicit tableau of
the registry, at a fixed step (RK4) or under error control (dopri5, dop853), with rotation
and energy bookkeeping always on and the fixed structure; Radau and the structure path have
no flight.

* Contact: the state and right-hand side of creatio.dynamics.sphere (s.4-6).
* Flight: [X (3), V (3), omega (3), Q (4), cumulative spin, surface work, friction
  dissipation] in the world frame; X'' = g, omega constant, Q integrated.
* Events are located inside the step where their function changes sign, by re-integration
  from the step start with a shorter step (Illinois regula falsi, bisection when the bracket
  stalls) to a bracket of EVENT_TOL; the event state is the far end of the bracket, so a
  separation has N <= 0 and an impact a gap <= 0, and an event is never moved to a step end.
  Separation: N reaches 0. Impact: the gap to the surface reaches 0 while approaching.
  The apex of each flight (the gap's rate v_n reaches 0) is located the same way for the
  flight's height, without changing the run.
* The event table has one row per event (EV_* columns); impact losses enter the energy
  balance through the energy reference: E0 is lowered by each loss, so the residual the
  loop reports is E - E0 - W_surface + D_friction + sum of losses.

Fixed step: the loop keeps the grid t_i = i dt; after an event the rest of the step is a
shorter step to the next grid time.
"""

from __future__ import annotations

import math

import numpy as np
from numba.extending import overload

from creatio.dynamics import status as st
from creatio.dynamics.jit import ensure_compiled, njit
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
    COL_DISSIPATION,
    COL_ENERGY,
    COL_F,
    COL_KINETIC,
    COL_N,
    COL_PHI_A,
    COL_PHI_A_RATE,
    COL_POTENTIAL,
    COL_R,
    COL_RESIDUAL,
    COL_SLIP,
    COL_SPEED,
    COL_T,
    COL_V,
    COL_WORK,
    COL_X,
    CT_PHI,
    CT_RATE,
    D_N,
    D_V,
    D_X,
    E_AZ,
    E_E0,
    E_MAX_RES,
    E_MIN_CLEAR,
    EV_ALPHA,
    EV_CONTACT,
    EV_HEIGHT,
    EV_IMPACT,
    EV_KIND,
    EV_LOSS,
    EV_R,
    EV_SEPARATION,
    EV_T,
    EV_VN,
    EV_VN_AFTER,
    EV_X,
    F_DISSIPATION,
    F_OMEGA,
    F_Q,
    F_SPIN,
    F_V,
    F_WORK,
    F_X,
    FL_IMPACT_CAP,
    FL_RESTITUTION,
    FL_RESUME_SPEED,
    FL_START_HEIGHT,
    LAW_A,
    LAW_CONTROL,
    LAW_GAMMA,
    LAW_R,
    NF,
    NFX,
    NROT,
    P_A,
    P_B,
    P_DR,
    P_G,
    P_I,
    P_K,
    P_KA,
    P_M,
    P_MCAV,
    P_MU,
    P_NCAV,
    P_R0,
    X_FLIGHT_GAP,
    X_FOOT_A,
    X_FOOT_R,
    X_MAX_GAP,
    Y_ALPHA,
    Y_ALPHADOT,
    Y_OMEGA,
    Y_R,
    Y_RDOT,
    energy_start,
    state_size,
)
from creatio.dynamics.solvers.driver import accepted_step, gave_up, landed, plan, target
from creatio.dynamics.solvers.explicit import (
    ACCEPTED,
    ERROR_REJECTED,
    error_norm,
    stages,
    step_factor,
)
from creatio.dynamics.sphere import (
    _controlled,
    new_extrema,
    observe,
    pack_run,
    rhs,
    unit_quaternion,
    world_centre,
    write_attitude,
)
from creatio.dynamics.surface import phases
from creatio.model.cavity import cavity_cell_offsets, cavity_radius
from creatio.model.control import servo
from creatio.model.flight import foot_point, impact
from creatio.model.laws import law_eval
from creatio.model.offset import offset_jets
from creatio.model.sphere import attitude_rates, centre_tangents, tangent_coordinates

__all__ = ["CONTACT", "ENTRIES", "EVENT_TOL", "FLIGHT", "run_flight"]

#: Phases of the hybrid loop.
CONTACT, FLIGHT = 0, 1

#: Width of the bracket (s) an event time is located to.
EVENT_TOL = 1e-11
#: Events in a row that may each advance the clock by no more than STALL_TIME before the run
#: ends STEP_FAILED: a state that flips between contact and flight without time passing
#: (rounding-dominated phases, say) would otherwise loop for ever.
MAX_STALLED_EVENTS = 1000
STALL_TIME = 1e-9

#: Size of the contact state (rotation and energy always on, fixed structure); its rotation
#: and energy blocks are carried into the flight state (creatio.dynamics.layout F_*) as they are.
NC = state_size(True, True, False)
#: How many entries the contact and flight states share: the rotation and energy blocks.
NCARRY = NROT + 2
assert energy_start(True) == Y_OMEGA + NROT and F_OMEGA + NCARRY == NF


@njit(cache=True)
def _flight_rhs(y, dy, g):
    """dy/dt of the flight state: X' = V, V' = (0, 0, -g), omega constant, Q and the spin
    integrated, the work and dissipation constant."""
    dy[F_X] = y[F_V]
    dy[F_X + 1] = y[F_V + 1]
    dy[F_X + 2] = y[F_V + 2]
    dy[F_V] = 0.0
    dy[F_V + 1] = 0.0
    dy[F_V + 2] = -g
    dy[F_OMEGA] = 0.0
    dy[F_OMEGA + 1] = 0.0
    dy[F_OMEGA + 2] = 0.0
    dy[F_Q], dy[F_Q + 1], dy[F_Q + 2], dy[F_Q + 3], dy[F_SPIN] = attitude_rates(
        y[F_Q], y[F_Q + 1], y[F_Q + 2], y[F_Q + 3], y[F_OMEGA], y[F_OMEGA + 1],
        y[F_OMEGA + 2])
    dy[F_WORK] = 0.0
    dy[F_DISSIPATION] = 0.0


@njit(cache=True)
def _contact_rates(R, a, V1, V2, V3, pp, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2):
    """(Rdot, alphadot) of the contact coordinates at (R, alpha) for a centre velocity V:
    (J^T J) qdot = J^T (V - X_t), which drops the residual normal velocity (one projection
    for the state at impact and the controller's measurement in flight)."""
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_KA], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1,
        g2)
    xR1, xR2, xR3, xa1, xa2, xa3, xt1, xt2, xt3 = centre_tangents(P, Q, Z)
    ca = math.cos(a)
    sa = math.sin(a)
    u1 = V1 * ca + V2 * sa - xt1
    u2 = -V1 * sa + V2 * ca - xt2
    u3 = V3 - xt3
    return tangent_coordinates(xR1, xR2, xR3, xa1, xa2, xa3, u1, u2, u3)


@njit(cache=True)
def _flight_servo(t, y, pp, lc):
    """(u, alpha, alphadot) of the controller in flight (docs/model.md s.12.2). It measures
    what it measures in contact, continued: the angle of the centre's foot point on the
    surface (the contact point at separation and at impact) and the alpha rate of the
    contact coordinates that the centre's velocity would have there (the least-squares
    projection with which contact resumes, :func:`_to_contact`), so u does not jump at either
    event. The foot point starts from the centre's azimuth on the branch of the starting
    cell's cavity; where it is not found, the centre's azimuth and its rate stand in."""
    c = lc[LAW_CONTROL]
    Ka = pp[P_KA]
    pa = y[NF + CT_PHI]
    pa1 = y[NF + CT_RATE]
    X1 = y[F_X]
    X2 = y[F_X + 1]
    rho2 = X1 * X1 + X2 * X2
    raw = math.atan2(X2, X1)
    ref = (math.pi - pa + 2.0 * math.pi * pp[P_MCAV]) / Ka  # the cell's cavity angle
    a = raw + 2.0 * math.pi * np.rint((ref - raw) / (2.0 * math.pi))
    ad = (X1 * y[F_V + 1] - X2 * y[F_V]) / rho2
    pr, pr1, pr2, _, _, _, gm, g1, g2 = phases(t, lc)
    found, Rs, As, gap, n1, n2, n3, c1, c2, c3 = foot_point(
        X1, X2, y[F_X + 2], math.sqrt(rho2) - pp[P_R0], a, pp[P_R0], pp[P_K], pp[P_A], Ka,
        pp[P_B], pr, pr1, pr2, pa, pa1, 0.0, gm, g1, g2)
    if found:
        # pa2 enters only the second time derivatives of the jets, which are not used here
        a = As
        ad = _contact_rates(Rs, As, y[F_V], y[F_V + 1], y[F_V + 2], pp, pr, pr1, pr2, pa,
                            pa1, 0.0, gm, g1, g2)[1]
    u, _, _, _ = servo(a, ad, pa, pa1, Ka, c[C_GOAL], c[C_ALPHA0], c[C_K_THETA], c[C_K_OMEGA],
                       c[C_OMEGA_MAX], c[C_DELTA_MAX], c[C_OMEGA_N], c[C_ZETA], c[C_U_MAX])
    return u, a, ad


def _flight_control(t, y, dy, pp, lc):
    """Write the control block's rates (phidot_a, u) of a flight state into dy on the
    controlled path; nothing otherwise (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


@overload(_flight_control, inline="always")
def _flight_control_of(t, y, dy, pp, lc):
    if not _controlled(lc):
        return lambda t, y, dy, pp, lc: None

    def controlled(t, y, dy, pp, lc):
        u, _, _ = _flight_servo(t, y, pp, lc)
        dy[NF + CT_PHI] = y[NF + CT_RATE]
        dy[NF + CT_RATE] = u
    return controlled


def _flight_phases(t, y, pp, lc):
    """The phases at t of a flight state (creatio.dynamics.surface.phases; on the controlled
    path phi_a, its rate and u from the state's control block; compiled code only)."""
    raise NotImplementedError("called only from compiled code")


@overload(_flight_phases, inline="always")
def _flight_phases_of(t, y, pp, lc):
    if not _controlled(lc):
        return lambda t, y, pp, lc: phases(t, lc)

    def controlled(t, y, pp, lc):
        pr, pr1, pr2, _, _, _, gm, g1, g2 = phases(t, lc)
        u, _, _ = _flight_servo(t, y, pp, lc)
        return pr, pr1, pr2, y[NF + CT_PHI], y[NF + CT_RATE], u, gm, g1, g2
    return controlled


def _flight_phase_a(t, y, pp, lc):
    """(phi_a, its rate, the measured alpha rate) of a flight state for its history row:
    the law's phi_a and NaN, NaN; on the controlled path the state's phase and rate and the
    controller's measured rate (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


@overload(_flight_phase_a, inline="always")
def _flight_phase_a_of(t, y, pp, lc):
    if not _controlled(lc):
        return lambda t, y, pp, lc: (law_eval(lc[LAW_A], t)[0], math.nan, math.nan)

    def controlled(t, y, pp, lc):
        _, _, ad = _flight_servo(t, y, pp, lc)
        return y[NF + CT_PHI], y[NF + CT_RATE], ad
    return controlled


@njit(cache=True, inline="always")
def _f(phase, t, y, dy, pp, lc, rot, en, diag):
    """The right-hand side of the phase, in the signature the explicit stepper calls
    (creatio.dynamics.solvers.explicit.stages): contact, creatio.dynamics.sphere.rhs (the
    hybrid loop always integrates rotation and energy, rot = en = True); flight, X'' = g
    (and the control block's rates on the controlled path)."""
    if phase == CONTACT:
        rhs(t, y, dy, pp, lc, rot, en, diag)
    else:
        _flight_rhs(y, dy, pp[P_G])
        _flight_control(t, y, dy, pp, lc)


@njit(cache=True)
def _step(phase, t, h, t_next, y, ynew, K, work, kst, tab, pp, lc, estimate, rtol, atol):
    """One explicit Runge-Kutta step of size h from (t, y) into ynew: the driver's stepper
    (creatio.dynamics.solvers.explicit.stages), so a contact step is the driver's step bit
    for bit; with estimate, the scaled error norm of the step (0 otherwise)."""
    n = y.size
    _f(phase, t, y, kst, pp, lc, True, True, False)
    for j in range(n):
        K[0, j] = kst[j]
    stages(_f, phase, tab.c, tab.a_ptr, tab.a_idx, tab.a_val, tab.b_idx, tab.b_val,
           tab.b_divisor, t, h, t_next, y, ynew, K, work, kst, pp, lc, True, True)
    if not estimate:
        return 0.0
    _f(phase, t_next, ynew, kst, pp, lc, True, True, False)
    s = tab.c.size
    for j in range(n):
        K[s, j] = kst[j]
    return error_norm(K, y, ynew, h, tab.e, tab.e3, tab.estimator, rtol, atol)


@njit(inline="always")
def _try(sargs, t, t_next, h, rejected):
    """One try at a step of the phase (the try_step of creatio.dynamics.solvers.driver
    .accepted_step): a fixed step is taken as it is; an adaptive one is judged by scipy's
    controller on its error estimate (creatio.dynamics.solvers.explicit.step_factor)."""
    phase, y, yn, K, work, kst, tab, pp, lc, rtol, atol, fixed = sargs
    err = _step(phase, t, h, t_next, y, yn, K, work, kst, tab, pp, lc, not fixed, rtol, atol)
    s = tab.c.size
    if fixed:
        return ACCEPTED, 1.0, s, 0, 0, 0, False
    ok, factor = step_factor(err, tab.error_order, rejected)
    return ACCEPTED if ok else ERROR_REJECTED, factor, s + 1, 0, 0, 0, False


@njit(cache=True)
def _foot(t, y, pp, lc, R, a):
    """Foot point of the flight state's centre at t from the guess (R, alpha): (found, R,
    alpha, gap, v_n, n (3), c_t (3))."""
    pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2 = _flight_phases(t, y, pp, lc)
    found, Rs, As, gap, n1, n2, n3, c1, c2, c3 = foot_point(
        y[F_X], y[F_X + 1], y[F_X + 2], R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_KA], pp[P_B],
        pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2)
    vn = (y[F_V] - c1) * n1 + (y[F_V + 1] - c2) * n2 + (y[F_V + 2] - c3) * n3
    return found, Rs, As, gap, vn, n1, n2, n3, c1, c2, c3


@njit(cache=True)
def _event_value(which, t, y, pp, lc, R, a):
    """The event function at (t, y): 0 the normal reaction N (contact), 1 the gap, 2 the
    relative normal velocity v_n (flight); NaN where the foot point is not found."""
    if which == 0:
        dy = np.empty(y.size)
        return rhs(t, y, dy, pp, lc, True, True, False)[D_N]
    found, Rs, As, gap, vn, n1, n2, n3, c1, c2, c3 = _foot(t, y, pp, lc, R, a)
    if not found:
        return math.nan
    return gap if which == 1 else vn


@njit(cache=True)
def _locate(which, phase, t, h, fa, fb, y, yt, K, work, kst, tab, pp, lc, R, a):
    """Locate the sign change (fa > 0 at t, fb <= 0 at t + h) of event function `which`
    inside the step by re-integration from (t, y); leaves the state at the far end of the
    final bracket in yt and returns its offset tau in (0, h] (h only if the bracket never
    left the step end)."""
    lo = 0.0
    hi = h
    flo = fa
    fhi = fb
    side = 0
    width0 = h
    it = 0
    while hi - lo > EVENT_TOL and it < 200:
        it += 1
        bisect = not (flo > 0.0 and fhi <= 0.0)
        if it % 3 == 0:
            # the bracket must halve every three tries, else bisect (regula falsi can stall)
            bisect = bisect or hi - lo > 0.5 * width0
            width0 = hi - lo
        cc = 0.5 * (lo + hi) if bisect else (lo * fhi - hi * flo) / (fhi - flo)
        if not (cc > lo and cc < hi):
            cc = 0.5 * (lo + hi)
        _step(phase, t, cc, t + cc, y, yt, K, work, kst, tab, pp, lc, False, 1.0, 1.0)
        fc = _event_value(which, t + cc, yt, pp, lc, R, a)
        if fc > 0.0:
            lo = cc
            flo = fc
            if side == 1:
                fhi *= 0.5
            side = 1
        else:
            hi = cc
            fhi = fc
            if side == -1:
                flo *= 0.5
            side = -1
    _step(phase, t, hi, t + hi, y, yt, K, work, kst, tab, pp, lc, False, 1.0, 1.0)
    return hi, it + 1


@njit(cache=True)
def _to_flight(t, yc, yf, pp, lc):
    """The flight state of contact state yc (centre and velocity turned to the world frame;
    spin, orientation, the sums and the control block carried)."""
    dy = np.empty(yc.size)
    d = rhs(t, yc, dy, pp, lc, True, True, False)
    a = yc[Y_ALPHA]
    yf[F_X], yf[F_X + 1], yf[F_X + 2] = world_centre(d, a)
    ca = math.cos(a)
    sa = math.sin(a)
    yf[F_V] = d[D_V] * ca - d[D_V + 1] * sa
    yf[F_V + 1] = d[D_V] * sa + d[D_V + 1] * ca
    yf[F_V + 2] = d[D_V + 2]
    for j in range(NCARRY):
        yf[F_OMEGA + j] = yc[Y_OMEGA + j]
    for j in range(yc.size - NC):  # the control block, last in both states
        yf[NF + j] = yc[NC + j]


@njit(cache=True)
def _to_contact(t, yf, yc, pp, lc, R, a):
    """The contact state at foot point (R, alpha) nearest flight state yf: qdot from
    (J^T J) qdot = J^T (V - X_t), which drops the residual normal velocity."""
    pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2 = _flight_phases(t, yf, pp, lc)
    yc[Y_R] = R
    yc[Y_ALPHA] = a
    yc[Y_RDOT], yc[Y_ALPHADOT] = _contact_rates(R, a, yf[F_V], yf[F_V + 1], yf[F_V + 2], pp,
                                                pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2)
    for j in range(NCARRY):
        yc[Y_OMEGA + j] = yf[F_OMEGA + j]
    for j in range(yc.size - NC):
        yc[NC + j] = yf[NF + j]


@njit(cache=True)
def _energy(m, inertia, g, V1, V2, V3, w1, w2, w3, X3):
    """Mechanical energy m |V|^2 / 2 + I |omega|^2 / 2 + m g X3."""
    return (0.5 * m * (V1 * V1 + V2 * V2 + V3 * V3)
            + 0.5 * inertia * (w1 * w1 + w2 * w2 + w3 * w3) + m * g * X3)


@njit(cache=True)
def _contact_energy(t, yc, pp, lc):
    """Mechanical energy and world centre of a contact state."""
    dy = np.empty(yc.size)
    d = rhs(t, yc, dy, pp, lc, True, True, False)
    E = _energy(pp[P_M], pp[P_I], pp[P_G], d[D_V], d[D_V + 1], d[D_V + 2], yc[Y_OMEGA],
                yc[Y_OMEGA + 1], yc[Y_OMEGA + 2], d[D_X + 2])
    X1, X2, X3 = world_centre(d, yc[Y_ALPHA])
    return E, X1, X2, X3, d[D_N]


@njit(cache=True)
def _record(ev, nev, t, kind, vn, vn_after, loss, X1, X2, X3, R, a, height):
    """Write one event row (when the table has room); returns the new count."""
    if nev < ev.shape[0]:
        ev[nev, EV_T] = t
        ev[nev, EV_KIND] = kind
        ev[nev, EV_VN] = vn
        ev[nev, EV_VN_AFTER] = vn_after
        ev[nev, EV_LOSS] = loss
        ev[nev, EV_X] = X1
        ev[nev, EV_X + 1] = X2
        ev[nev, EV_X + 2] = X3
        ev[nev, EV_R] = R
        ev[nev, EV_ALPHA] = a
        ev[nev, EV_HEIGHT] = height
    return nev + 1


@njit(cache=True)
def _observe_flight(first, t, y, fx, gap, pp, lc, ext, out, row, final, sample):
    """Diagnostics of a flight state: energy residual, edge clearance, azimuth and the
    flight's height; a history row on the output grid (N = 0, no friction, slip NaN, R and
    alpha of the foot point). Returns (status, rows written)."""
    R0 = pp[P_R0]
    dR = pp[P_DR]
    m = pp[P_M]
    b = pp[P_B]
    g = pp[P_G]
    k = pp[P_K]
    inertia = pp[P_I]
    X1 = y[F_X]
    X2 = y[F_X + 1]
    X3 = y[F_X + 2]
    V1 = y[F_V]
    V2 = y[F_V + 1]
    V3 = y[F_V + 2]
    wx = y[F_OMEGA]
    wy = y[F_OMEGA + 1]
    wz = y[F_OMEGA + 2]
    kin = 0.5 * m * (V1 * V1 + V2 * V2 + V3 * V3) + 0.5 * inertia * (wx * wx + wy * wy + wz * wz)
    pot = m * g * X3
    energy = kin + pot
    if first:
        ext[E_E0] = energy
    res = energy - ext[E_E0] - y[F_WORK] + y[F_DISSIPATION]
    if abs(res) > ext[E_MAX_RES]:
        ext[E_MAX_RES] = abs(res)
    if gap > fx[X_FLIGHT_GAP]:
        fx[X_FLIGHT_GAP] = gap
    if gap > fx[X_MAX_GAP]:
        fx[X_MAX_GAP] = gap
    gm = law_eval(lc[LAW_GAMMA], t)[0]
    sx = (math.sqrt(X1 * X1 + X2 * X2) - R0) * math.cos(gm) + X3 * math.sin(gm)
    clear = min(sx - b, dR - sx - b)
    if clear < ext[E_MIN_CLEAR]:
        ext[E_MIN_CLEAR] = clear
    raw = math.atan2(X2, X1)
    if first:
        az = raw
    else:
        az = raw + 2.0 * math.pi * np.rint((ext[E_AZ] - raw) / (2.0 * math.pi))
    ext[E_AZ] = az
    R = fx[X_FOOT_R]
    a = fx[X_FOOT_A]
    total = X1 + X2 + X3 + energy
    for j in range(y.size):
        total += y[j]
    status = st.OK
    if not math.isfinite(total):
        status = st.NON_FINITE
    elif R < 0.0 or R > dR:
        status = st.LEFT_ANNULUS
    elif clear < 0.0:
        status = st.EDGE_CROSSED
    if not (status != st.OK or final or sample):
        return status, 0
    pr = law_eval(lc[LAW_R], t)[0]
    pa, pa_rate, ad = _flight_phase_a(t, y, pp, lc)
    ncav = pp[P_NCAV]
    du, dv = cavity_cell_offsets(R, a, pr, pa, k, pp[P_KA], ncav, pp[P_MCAV])
    out[row, COL_T] = t
    out[row, COL_X] = X1
    out[row, COL_X + 1] = X2
    out[row, COL_X + 2] = X3
    out[row, COL_R] = R
    out[row, COL_ALPHA] = a
    out[row, COL_V] = V1
    out[row, COL_V + 1] = V2
    out[row, COL_V + 2] = V3
    out[row, COL_SPEED] = math.sqrt(V1 * V1 + V2 * V2 + V3 * V3)
    out[row, COL_N] = 0.0
    out[row, COL_F] = 0.0
    out[row, COL_F + 1] = 0.0
    out[row, COL_F + 2] = 0.0
    out[row, COL_SLIP] = math.nan
    q0, q1, q2, q3 = unit_quaternion(y[F_Q], y[F_Q + 1], y[F_Q + 2], y[F_Q + 3])
    write_attitude(out, row, wx, wy, wz, q0, q1, q2, q3, y[F_SPIN])
    out[row, COL_AZIMUTH] = az
    out[row, COL_KINETIC] = kin
    out[row, COL_POTENTIAL] = pot
    out[row, COL_ENERGY] = energy
    out[row, COL_WORK] = y[F_WORK]
    out[row, COL_DISSIPATION] = y[F_DISSIPATION]
    out[row, COL_RESIDUAL] = res
    out[row, COL_CAVITY_R] = cavity_radius(pr, k, ncav)
    out[row, COL_CELL_U] = du
    out[row, COL_CELL_V] = dv
    out[row, COL_PHI_A] = pa
    out[row, COL_PHI_A_RATE] = pa_rate
    out[row, COL_ALPHADOT] = ad
    return status, 1


@njit(cache=True)
def _drop(height, yc, yf, fx, pp, lc):
    """A dropped start: the flight state of the centre `height` along n above its contact
    position in yc, at rest, and its foot point."""
    _to_flight(0.0, yc, yf, pp, lc)
    found, Rs, As, gap, vn, n1, n2, n3, c1, c2, c3 = _foot(0.0, yf, pp, lc, yc[Y_R],
                                                            yc[Y_ALPHA])
    yf[F_X] += height * n1
    yf[F_X + 1] += height * n2
    yf[F_X + 2] += height * n3
    fx[X_FOOT_R] = Rs
    fx[X_FOOT_A] = As


@njit(cache=True)
def _separate(t, yc, yf, fx, ev, nev, pp, lc):
    """A separation at t: the flight state of contact state yc, its foot point, the event row
    nev; False when the foot point is not found (nothing recorded)."""
    _to_flight(t, yc, yf, pp, lc)
    found, Rs, As, gap, vn, n1, n2, n3, c1, c2, c3 = _foot(t, yf, pp, lc, yc[Y_R], yc[Y_ALPHA])
    if not found:
        return False
    fx[X_FOOT_R] = Rs
    fx[X_FOOT_A] = As
    fx[X_FLIGHT_GAP] = 0.0
    _record(ev, nev, t, EV_SEPARATION, vn, vn, 0.0, yf[F_X], yf[F_X + 1], yf[F_X + 2], Rs, As,
            math.nan)
    return True


@njit(cache=True)
def _impact(t, yf, yc, fx, ext, ev, nev, forced, fl, pp, lc, Rs, As, n1, n2, n3, c1, c2, c3):
    """An impact at t at the foot point (Rs, As) with normal n and membrane velocity c: the
    impact law (creatio.model.flight.impact) on the flight state, its loss taken off the
    energy reference, the event row; contact resumes (into yc, with its own event row) when
    e = 0, the rebound is slower than the resumption speed, or the impact cap forces it.
    Returns (whether contact resumed, the event count)."""
    m = pp[P_M]
    g = pp[P_G]
    inertia = pp[P_I]
    V1, V2, V3 = yf[F_V], yf[F_V + 1], yf[F_V + 2]
    w1, w2, w3 = yf[F_OMEGA], yf[F_OMEGA + 1], yf[F_OMEGA + 2]
    E0 = _energy(m, inertia, g, V1, V2, V3, w1, w2, w3, yf[F_X + 2])
    V1, V2, V3, w1, w2, w3, vm, vp, jn_, jt_ = impact(
        V1, V2, V3, w1, w2, w3, n1, n2, n3, c1, c2, c3, m, inertia, pp[P_B],
        fl[FL_RESTITUTION], pp[P_MU])
    yf[F_V] = V1
    yf[F_V + 1] = V2
    yf[F_V + 2] = V3
    yf[F_OMEGA] = w1
    yf[F_OMEGA + 1] = w2
    yf[F_OMEGA + 2] = w3
    E1 = _energy(m, inertia, g, V1, V2, V3, w1, w2, w3, yf[F_X + 2])
    ext[E_E0] -= E0 - E1
    nev = _record(ev, nev, t, EV_IMPACT, vm, vp, E0 - E1, yf[F_X], yf[F_X + 1], yf[F_X + 2],
                  Rs, As, fx[X_FLIGHT_GAP])
    if fl[FL_RESTITUTION] == 0.0 or abs(vp) < fl[FL_RESUME_SPEED] or forced:
        _to_contact(t, yf, yc, pp, lc, Rs, As)
        Ec, X1, X2, X3, N = _contact_energy(t, yc, pp, lc)
        ext[E_E0] -= E1 - Ec
        nev = _record(ev, nev, t, EV_CONTACT, vp, 0.0, E1 - Ec, X1, X2, X3, Rs, As, math.nan)
        return True, nev
    fx[X_FLIGHT_GAP] = 0.0
    return False, nev


@njit(cache=True)
def _drive_flight(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                  max_evals, progress, tab, out, fl, ev, ctl):
    """Integrate the hybrid contact/flight model from t = 0 to t_end (see the module).

    fl = (restitution e, resumption speed, impacts per second cap, start height: > 0 starts
    in flight that far above the initial contact position); ev the event table
    (rows beyond its size are counted, not written). Returns the driver's tuple (status,
    steps, rows, rhs_evals, extrema, rejected, jacobians, lu, stop_time) plus the event
    count, the flight extrema and the final phase. The step-retry loop (the evaluation budget
    max_evals, the progress lines every `progress` seconds, the step-size floors) is the
    driver's. ctl: the controlled path (docs/model.md s.12.2; p carries the controller's row,
    y0 the control block last, which both phases' states carry).
    """
    pp, lc = pack_run(ctl, p, lawc)
    nc = y0.size
    nf = NF + nc - NC
    cap = fl[FL_IMPACT_CAP]
    icap = max(1, int(cap))
    ring = np.full(icap, -math.inf)
    n_imp = 0
    s = tab.c.size
    yc = y0.copy()
    yf = np.zeros(nf)
    clock = np.zeros(2)
    top_wrote = 0
    yt_c = np.empty(nc)
    yt_f = np.empty(nf)
    Kc = np.empty((s + 1, nc))
    Kf = np.empty((s + 1, nf))
    wc = np.empty(nc)
    wf = np.empty(nf)
    kc = np.empty(nc)
    kf = np.empty(nf)
    ya = np.empty(nf)
    dy = np.empty(nc)
    ext = new_extrema(True)
    fx = np.zeros(NFX)
    nev = np.int64(0)
    evals = np.int64(0)
    # rejected steps, Jacobians, LU, Newton iterations, tries, tries below the sustained floor
    tally = (evals, evals, evals, evals, evals, evals)
    rows = np.int64(0)
    steps = np.int64(0)
    stalled = 0
    h_small = t_end / max_evals
    status = st.OK
    t = 0.0
    phase = CONTACT
    n_int, h, final = plan(fixed, False, t_end, interval, h0, n_steps)
    jn = 1
    kg = 0
    on_grid = True
    sample = True
    first = True
    transition = True  # the state may need an event at once (the start, after an event)
    height = fl[FL_START_HEIGHT]
    if height > 0.0:
        _drop(height, yc, yf, fx, pp, lc)
        phase = FLIGHT
    while True:
        top_wrote = 0
        # instantaneous transitions at the current state
        while transition and status == st.OK:
            transition = False
            if phase == CONTACT:
                Ec, X1, X2, X3, N = _contact_energy(t, yc, pp, lc)
                if N <= 0.0:
                    if not _separate(t, yc, yf, fx, ev, nev, pp, lc):
                        status = st.FOOT_POINT_FAILED
                        break
                    nev += 1
                    phase = FLIGHT
            else:
                found, Rs, As, gap, vn, n1, n2, n3, c1, c2, c3 = _foot(
                    t, yf, pp, lc, fx[X_FOOT_R], fx[X_FOOT_A])
                if not found:
                    status = st.FOOT_POINT_FAILED
                    break
                fx[X_FOOT_R] = Rs
                fx[X_FOOT_A] = As
                if gap <= 0.0 and vn < 0.0:
                    forced = t - ring[n_imp % icap] < 1.0
                    ring[n_imp % icap] = t
                    n_imp += 1
                    resumed, nev = _impact(t, yf, yc, fx, ext, ev, nev, forced, fl, pp, lc, Rs,
                                           As, n1, n2, n3, c1, c2, c3)
                    if resumed:
                        phase = CONTACT
                        transition = True
        if status != st.OK:
            break
        # observe the state (extrema, stops, history row)
        if phase == CONTACT:
            d = rhs(t, yc, dy, pp, lc, True, True, True)
            evals += 1
            status, wrote = observe(first, t, yc, d, pp, ext, out, rows, final, sample, True,
                                    True, False)
        else:
            found, Rs, As, gap, vn, n1, n2, n3, c1, c2, c3 = _foot(
                t, yf, pp, lc, fx[X_FOOT_R], fx[X_FOOT_A])
            fx[X_FOOT_R] = Rs
            fx[X_FOOT_A] = As
            if not found:
                status = st.FOOT_POINT_FAILED
                break
            status, wrote = _observe_flight(first, t, yf, fx, gap, pp, lc, ext, out, rows,
                                            final, sample)
        first = False
        rows += wrote
        top_wrote = wrote
        if status != st.OK or final:
            break
        # one step towards the next grid (fixed) or output (adaptive) time: after an event,
        # a fixed step is the rest of its grid step; an adaptive one lands on t_target exactly
        t_target = target(fixed, False, kg, h0, jn, n_int, interval, t_end)
        y = yc if phase == CONTACT else yf
        yn = yt_c if phase == CONTACT else yt_f
        K = Kc if phase == CONTACT else Kf
        work = wc if phase == CONTACT else wf
        kst = kc if phase == CONTACT else kf
        status, m_split, h_use, t_next, h, _, evals, tally = accepted_step(
            _try, (phase, y, yn, K, work, kst, tab, pp, lc, rtol, atol, fixed), t, t_target,
            t_end, h, h0 if on_grid else t_target - t, fixed, False, True, False, evals, tally,
            steps, max_evals, h_small, progress, clock)
        if status != st.OK:
            break
        steps += 1
        # events inside the step
        tau = -1.0
        if phase == CONTACT:
            N1 = _event_value(0, t_next, yn, pp, lc, 0.0, 0.0)
            evals += 1
            if N1 <= 0.0:
                N0 = _event_value(0, t, y, pp, lc, 0.0, 0.0)
                tau, n_re = _locate(0, phase, t, h_use, N0, N1, y, yn, K, work, kst, tab, pp,
                                    lc, 0.0, 0.0)
                evals += n_re * (s + 1) + 1
        else:
            Rg = fx[X_FOOT_R]
            Ag = fx[X_FOOT_A]
            found, Rs, As, gap1, vn1, n1, n2, n3, c1, c2, c3 = _foot(t_next, yn, pp, lc, Rg, Ag)
            if not found:
                status = st.FOOT_POINT_FAILED
                break
            vn0 = _event_value(2, t, y, pp, lc, Rg, Ag)
            if vn0 > 0.0 and vn1 <= 0.0:
                # the flight's apex: located for the height only, the run goes on unchanged
                _locate(2, phase, t, h_use, vn0, vn1, y, ya, K, work, kst, tab, pp, lc, Rg, Ag)
                ga = _event_value(1, t, ya, pp, lc, Rg, Ag)
                if ga > fx[X_FLIGHT_GAP]:
                    fx[X_FLIGHT_GAP] = ga
                if ga > fx[X_MAX_GAP]:
                    fx[X_MAX_GAP] = ga
            if gap1 <= 0.0 and vn1 < 0.0:
                g0 = _event_value(1, t, y, pp, lc, Rg, Ag)
                tau, n_re = _locate(1, phase, t, h_use, g0, gap1, y, yn, K, work, kst, tab,
                                    pp, lc, Rg, Ag)
                evals += n_re * s
            else:
                fx[X_FOOT_R] = Rs
                fx[X_FOOT_A] = As
        for j in range(y.size):
            y[j] = yn[j]
        transition = tau >= 0.0
        if transition and tau < h_use:
            # an event inside the step: the rest of the step follows from the event state
            stalled = stalled + 1 if tau <= STALL_TIME else 0
            if stalled > MAX_STALLED_EVENTS:
                status = st.STEP_FAILED
                break
            t = t + tau
            on_grid = False
            sample = False
            final = False
            continue
        if fixed:
            kg += 1
            on_grid = True
        t, jn, final, sample = landed(fixed, False, kg, n_steps, stride, m_split, t_next,
                                      t_target, t_end, jn)
    if gave_up(status) and top_wrote == 0:
        # record the state where the run gave up, so the stop is visible in the histories
        # (unless that state's row was just written)
        if phase == CONTACT:
            d = rhs(t, yc, dy, pp, lc, True, True, True)
            _, wrote = observe(first, t, yc, d, pp, ext, out, rows, True, True, True, True,
                               False)
        else:
            _, wrote = _observe_flight(first, t, yf, fx, 0.0, pp, lc, ext, out, rows,
                                       True, True)
        rows += wrote
    return status, steps, rows, evals, ext, tally[0], 0, 0, t, nev, fx, phase


def _entry(ctl: bool):
    """The compiled entry point of the hybrid loop, prescribed or controlled (ctl frozen as a
    constant, so each compiles only its own path; numba's cache files it by its name)."""
    def entry(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_evals,
              progress, tab, out, fl, ev):
        return _drive_flight(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                             fixed, max_evals, progress, tab, out, fl, ev, ctl)

    entry.__name__ = entry.__qualname__ = "_hybrid_control" if ctl else "_hybrid"
    return njit(cache=True)(entry)


#: The hybrid loop's entry points: prescribed (False) and controlled (True) phase.
ENTRIES = {ctl: _entry(ctl) for ctl in (False, True)}


def run_flight(method, p: np.ndarray, lawc: np.ndarray, y0: np.ndarray, out: np.ndarray,
               ev: np.ndarray, fl: np.ndarray, *, t_end: float, interval: float, h0: float,
               n_steps: int, stride: int, rtol: float, atol: float, fixed: bool,
               max_evals: int, progress: float, control: bool = False) -> tuple:
    """Run an explicit `method` through the hybrid loop (control: the controlled phase of
    docs/model.md s.12.2); see _drive_flight for the result."""
    fn = ENTRIES[bool(control)]
    call = (p, lawc, y0, float(t_end), float(interval), float(h0), int(n_steps), int(stride),
            float(rtol), float(atol), bool(fixed), int(max_evals), float(progress),
            method.driver_tableau, out, fl, ev)
    ensure_compiled(fn, call, f"the {method.name} flight loop")
    return fn(*call)
