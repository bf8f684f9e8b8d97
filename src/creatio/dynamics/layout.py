"""The layouts of the compiled core, named once: state, parameters, laws, diagnostics, tables.

The compiled loops exchange plain arrays and tuples; every position in them is named here
and nowhere else, and every kernel reads these names (the law coefficient vector is
creatio.model.laws's L_*). Plain Python with no compiler, so a problem is laid out without
numba; numba reads the integer constants as compile-time constants, and the block positions
below are compiled where they are used (creatio.dynamics.sphere registers them).

State vector (docs/model.md s.4.7): [R, alpha, Rdot, alphadot], then the optional blocks in
this order, each present only in the specialisation that integrates it:

* rotation [omega (3, world), Q (4), cumulative spin];
* energy [surface work, friction dissipation (, confinement work on the structure path)];
* structure [theta, Theta] (the structure path of docs/model.md s.9-10);
* control [phi_a, phidot_a] (the controlled phase of docs/model.md s.12.2, fixed structure
  only): present when the law tuple carries the controller's coefficients as a fourth row
  (LAW_CONTROL, laid out by the C_* slots), which makes it a compile-time property of the
  types a specialisation is compiled for.

A new block is a flag, a size and a start computed from the blocks before it, like
:func:`structure_start` and :func:`control_start`; the blocks before it keep their positions.
"""

from __future__ import annotations

__all__ = [
    "COL_ALPHA", "COL_AZIMUTH", "COL_CAVITY_R", "COL_CELL_U", "COL_CELL_V", "COL_CONFINE",
    "COL_DISSIPATION", "COL_ENERGY", "COL_F", "COL_HZ_ORBITAL", "COL_HZ_SPIN",
    "COL_HZ_STRUCTURE", "COL_KINETIC", "COL_MARKER", "COL_N", "COL_OMEGA", "COL_POTENTIAL",
    "COL_Q", "COL_R", "COL_RESIDUAL", "COL_SLIP", "COL_SPEED", "COL_SPIN", "COL_SPIN_RATE",
    "COL_ALPHADOT", "COL_PHI_A", "COL_PHI_A_RATE", "COL_T", "COL_THETA", "COL_THETA_RATE",
    "COL_V", "COL_WORK", "COL_WORLD_AZIMUTH", "COL_X",
    "D_BK", "D_F", "D_GAMMA", "D_N", "D_PHI_A", "D_PHI_R", "D_SLIP", "D_V", "D_X", "E_AZ",
    "E_E0", "E_HZ0", "E_LEFT", "E_MAX_BK", "E_MAX_HZ_DRIFT", "E_MAX_IS_THETA", "E_MAX_N",
    "E_MAX_RES", "E_MAX_RHO", "E_MAX_SLIP", "E_MAX_THETA_RATE", "E_MAX_TRACK", "E_MIN_CLEAR",
    "E_MIN_N", "EN_CONFINE", "EN_DISSIPATION", "EN_WORK", "energy_size", "energy_start",
    "EV_ALPHA", "EV_CONTACT", "EV_HEIGHT", "EV_IMPACT", "EV_KIND", "EV_LOSS", "EV_R",
    "EV_SEPARATION", "EV_T", "EV_VN", "EV_VN_AFTER", "EV_X", "EVENT_KINDS", "F_DISSIPATION",
    "F_OMEGA", "F_Q", "F_SPIN", "F_V", "F_WORK", "F_X", "FL_IMPACT_CAP", "FL_RESTITUTION",
    "FL_RESUME_SPEED", "FL_START_HEIGHT", "LAW_A", "LAW_GAMMA", "LAW_R", "NCOL", "NDIAG", "NEV",
    "NEXT", "NF", "NFL", "NFX", "NLAWS", "NPAR", "NQ", "NROT", "NSTRUCT", "P_A", "P_B", "P_DR",
    "P_EPS", "P_G", "P_GX", "P_GY", "P_I", "P_INV_IS", "P_IS", "P_K", "P_KA", "P_M", "P_MCAV",
    "P_MU", "P_NCAV",
    "P_PRELOAD", "P_R0", "P_SKIN", "P_STOP_LEAVE", "SCALAR_KERNELS", "ST_RATE", "ST_THETA",
    "C_ALPHA0", "C_DELTA_MAX", "C_GOAL", "C_K_OMEGA", "C_K_THETA", "C_OMEGA_MAX", "C_OMEGA_N",
    "C_U_MAX", "C_ZETA", "CT_PHI", "CT_RATE", "LAW_CONTROL", "NCTL", "NCTLS", "control_start",
    "state_size", "structure_start", "X_FLIGHT_GAP", "X_FOOT_A", "X_FOOT_R", "X_MAX_GAP",
    "Y_ALPHA", "Y_ALPHADOT", "Y_OMEGA", "Y_Q", "Y_R", "Y_RDOT", "Y_SPIN",
]

# ------------------------------------------------------------------------- state vector
#: The contact point's coordinates and rates, always first.
Y_R, Y_ALPHA, Y_RDOT, Y_ALPHADOT = 0, 1, 2, 3
NQ = 4
#: The rotation block (absolute positions: it always starts at NQ): omega in world
#: components, the orientation quaternion Q (scalar first), the cumulative spin.
Y_OMEGA, Y_Q, Y_SPIN = 4, 7, 11
NROT = 8
#: The energy block, from its start: surface work, friction dissipation, and on the
#: structure path the confining force's work.
EN_WORK, EN_DISSIPATION, EN_CONFINE = 0, 1, 2
#: The structure block, from its start: the yaw theta and its rate Theta.
ST_THETA, ST_RATE = 0, 1
NSTRUCT = 2


def energy_start(rot: bool) -> int:
    """Where the energy block starts: after the rotation block when it is integrated."""
    return NQ + NROT if rot else NQ


def energy_size(free: bool) -> int:
    """Length of the energy block: the confining force's work joins it on the structure
    path."""
    return EN_CONFINE + 1 if free else EN_DISSIPATION + 1


def structure_start(rot: bool, en: bool) -> int:
    """Where the structure block starts (structure path only): after the energy block."""
    return energy_start(rot) + energy_size(True) if en else energy_start(rot)


def state_size(rot: bool, en: bool, free: bool) -> int:
    """Length of the state vector of a specialisation."""
    if free:
        return structure_start(rot, en) + NSTRUCT
    return energy_start(rot) + energy_size(False) if en else energy_start(rot)


#: The control block, from its start: the angular phase phi_a and its rate phidot_a.
CT_PHI, CT_RATE = 0, 1
NCTLS = 2


def control_start(rot: bool, en: bool) -> int:
    """Where the control block starts (fixed structure only): after every other block."""
    return state_size(rot, en, False)


#: The block positions, compiled where the kernels use them (constants once compiled).
SCALAR_KERNELS = (energy_start, energy_size, structure_start, state_size, control_start)

# -------------------------------------------------------------------------- flight state
#: The flight state of the hybrid loop (docs/model.md s.11.7), world frame: centre X,
#: velocity V, omega, Q, cumulative spin, surface work, friction dissipation. Its last
#: NROT + 2 entries are the contact state's rotation and energy blocks, in the same order.
F_X, F_V, F_OMEGA, F_Q, F_SPIN, F_WORK, F_DISSIPATION = 0, 3, 6, 9, 13, 14, 15
NF = 16
#: The flight settings vector: restitution e, the speed below which contact resumes after an
#: impact, the cap on impacts per second, and the start height (> 0: a dropped start).
FL_RESTITUTION, FL_RESUME_SPEED, FL_IMPACT_CAP, FL_START_HEIGHT = range(4)
NFL = 4

# --------------------------------------------------------------------- parameter vector
#: The surface and sphere, the cavity (n, m) the run starts in, the structure's inertia I_s
#: (inf: fixed) and its inverse, the normal preload P, and whether leaving the cavity stops
#: the run (1.0) or is only recorded (0.0). P_G is the pull along -z (gravity's vertical part,
#: plus the base confinement's P / m); P_GX, P_GY are gravity's horizontal components in the
#: structure's frame, nonzero only under a mounting tilt (docs/model.md s.4, "Gravity as a
#: vector"): at zero tilt the kernels never read them, so their arithmetic is unchanged.
(P_R0, P_DR, P_K, P_A, P_KA, P_M, P_B, P_G, P_MU, P_EPS, P_I, P_NCAV, P_MCAV, P_IS, P_INV_IS,
 P_PRELOAD, P_STOP_LEAVE, P_GX, P_GY) = range(19)
NPAR = 19
#: On a rib surface (docs/model.md s.14.4) the parameter tuple holds one more element after
#: the NPAR parameters: the skin's spline table (creatio.model.ribs.skin_table), which makes
#: the surface kind a compile-time property of the tuple's type (creatio.dynamics.surface).
P_SKIN = NPAR

# ------------------------------------------------------------------------- law matrix
#: Rows of the law matrix: the radial phase, the angular phase, the inclination (each a
#: coefficient vector of creatio.model.laws).
LAW_R, LAW_A, LAW_GAMMA = 0, 1, 2
NLAWS = 3
#: The controller's row of the law tuple (present only on the controlled path, where the
#: angular phase is the state's, docs/model.md s.12.2), laid out by the slots below: the
#: commanded travel theta_goal and the alpha it is measured from, the outer loop's gains
#: K_theta and K_omega, the speed limit Omega_max, the lead limit delta_max, the servo's
#: omega_n and zeta, and the acceleration limit u_max (inf: none).
LAW_CONTROL = 3
(C_GOAL, C_ALPHA0, C_K_THETA, C_K_OMEGA, C_OMEGA_MAX, C_DELTA_MAX, C_OMEGA_N, C_ZETA,
 C_U_MAX) = range(9)
NCTL = 9

# ------------------------------------------------------------------- diagnostics tuple
#: The tuple every right-hand side returns beside dy/dt: N, |v_s|, the centre X (3) and its
#: velocity V (3) and the friction f (3) in the rotating frame at alpha (V relative to the
#: structure on the structure path), phi_r, gamma, b kappa_max (0 unless asked for), phi_a.
(D_N, D_SLIP, D_X, D_V, D_F, D_PHI_R, D_GAMMA, D_BK, D_PHI_A) = (0, 1, 2, 5, 8, 11, 12, 13, 14)
NDIAG = 15

# ---------------------------------------------------------------------- history table
#: Columns of the history table the loops write (world frame unless noted).
COL_T = 0
COL_X = 1               # centre (3)
COL_R = 4
COL_ALPHA = 5
COL_V = 6               # centre velocity (3)
COL_SPEED = 9
COL_N = 10
COL_F = 11              # friction (3)
COL_SLIP = 14
COL_OMEGA = 15          # (3)
COL_SPIN_RATE = 18
COL_SPIN = 19
COL_Q = 20              # orientation, normalised (4)
COL_MARKER = 24         # body marker (3)
COL_AZIMUTH = 27
COL_KINETIC = 28
COL_POTENTIAL = 29
COL_ENERGY = 30
COL_WORK = 31
COL_DISSIPATION = 32
COL_RESIDUAL = 33
COL_CAVITY_R = 34
COL_CELL_U = 35         # phase offsets from the starting cavity's bottom (docs/model.md s.8.2)
COL_CELL_V = 36
COL_THETA = 37          # structure yaw and its rate (free structure only, else NaN)
COL_THETA_RATE = 38
COL_HZ_STRUCTURE = 39   # H_z parts: I_s Theta, m [X x V_abs] . z^, I omega_z (free only)
COL_HZ_ORBITAL = 40
COL_HZ_SPIN = 41
COL_CONFINE = 42        # W_confine, the normal preload's work (free path only)
COL_WORLD_AZIMUTH = 43  # centre azimuth in the world frame: relative azimuth + theta
COL_PHI_A = 44          # the angular phase (the law's, or the controlled state's)
COL_PHI_A_RATE = 45     # its rate (controlled path only, else NaN)
COL_ALPHADOT = 46       # the contact's angular rate (the controller's measurement)
NCOL = 47

# ---------------------------------------------------------------------- running extrema
#: Slots of the running-extrema array the loops share: the run's reported extrema first
#: (E_MIN_N .. E_MAX_BK, in this order), then state carried between steps (the energy
#: reference E0, the unwrapped azimuth), the first time outside the cavity's cell (NaN while
#: inside) and, on the structure path, H_z(0), the largest |H_z - H_z(0)|, |I_s Theta|,
#: |Theta| and horizontal radius of the centre plus b.
(E_MIN_N, E_MAX_N, E_MAX_SLIP, E_MAX_RES, E_MAX_TRACK, E_MIN_CLEAR, E_MAX_BK, E_E0, E_AZ,
 E_LEFT, E_HZ0, E_MAX_HZ_DRIFT, E_MAX_IS_THETA, E_MAX_THETA_RATE, E_MAX_RHO) = range(15)
NEXT = 15
#: The flight extrema of the hybrid loop: the largest gap of the run and of the current
#: flight, and the foot point (R, alpha) the next search starts from.
X_MAX_GAP, X_FLIGHT_GAP, X_FOOT_R, X_FOOT_A = range(4)
NFX = 4

# -------------------------------------------------------------------------- event table
#: Columns of the event table of a run with flight: time, kind, relative normal velocity
#: before (v_n-) and after (v_n+), energy lost, centre (3, world), foot point (R, alpha), and
#: for an impact the height (largest gap) of the flight it ends.
(EV_T, EV_KIND, EV_VN, EV_VN_AFTER, EV_LOSS, EV_X, EV_R, EV_ALPHA, EV_HEIGHT) = (
    0, 1, 2, 3, 4, 5, 8, 9, 10)
NEV = 11
#: Event kinds, as written into column EV_KIND, and their names.
EV_SEPARATION, EV_IMPACT, EV_CONTACT = 0, 1, 2
EVENT_KINDS = ("separation", "impact", "contact")
