"""A sphere run as plain numbers, its result, and its stability limit (docs/model.md s.4-10).

Nothing here compiles: a SphereProblem is built, checked and its friction stability limit
estimated without numba (validation and workflow planning use it), and creatio.dynamics
.simulate hands it to the compiled driver. The same problem describes the fixed structure of
EN-02 (s.4), an equilibrium start on the inclined family (s.8), a structure free to yaw
(s.9) and a confining force (s.10).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from creatio.dynamics import solvers
from creatio.dynamics.layout import (
    NCOL,
    NEV,
    NPAR,
    P_A,
    P_B,
    P_DR,
    P_EPS,
    P_G,
    P_I,
    P_INV_IS,
    P_IS,
    P_K,
    P_KA,
    P_M,
    P_MCAV,
    P_MU,
    P_NCAV,
    P_PRELOAD,
    P_R0,
    P_STOP_LEAVE,
    Y_ALPHA,
    Y_ALPHADOT,
    Y_OMEGA,
    Y_Q,
    Y_R,
    Y_RDOT,
    state_size,
)
from creatio.model import sphere as contact
from creatio.model.cavity import cavity_angle_branch, cavity_branch
from creatio.model.equilibrium import Equilibrium, static_equilibrium
from creatio.model.laws import Law
from creatio.model.numerics import steps_in
from creatio.model.offset import offset_jets
from creatio.model.structure import CONFINEMENTS, inverse_inertia
from creatio.model.surface import wavenumber

__all__ = [
    "MAX_IMPACT_CAP",
    "MAX_STEPS",
    "SimulationResult",
    "SphereProblem",
    "UnstableStepError",
    "normal_reaction_at_start",
    "stability_limit",
]

#: Accepted steps after which an adaptive run gives up (status step_failed).
MAX_STEPS = 20_000_000
#: Largest cap on impacts per second: the event table is sized 3 x cap x t_end rows.
MAX_IMPACT_CAP = 10_000.0

class UnstableStepError(ValueError):
    """dt lies beyond the RK4 stability limit of the regularised friction (docs/model.md s.6)."""


def _check_law(name: str, law: Law) -> None:
    if not isinstance(law, Law):
        raise ValueError(f"{name} must be a creatio.model.laws.Law, got {law!r}")
    if not all(math.isfinite(c) for c in law.coefficients()):
        raise ValueError(f"{name} has non-finite coefficients: {law}")


def _multiple(name: str, value: float, dt: float) -> int:
    """Integer n with value = n dt within a relative 1e-9, else ValueError naming both."""
    n = steps_in(value, dt)
    if n is None:
        raise ValueError(f"{name} = {value} s is not an integer multiple of dt = {dt} s")
    return n


@dataclass(frozen=True)
class SphereProblem:
    """One sphere on the moving corrugated surface: geometry, laws, sphere, initial state, solver.

    Laws are creatio.model.laws.Law; angles in radians, SI units; gravity is (0, 0, -g).

    method: "rk4" (fixed step dt) or one of the adaptive methods "dopri5", "dop853",
    "radau5", which control the local error to rtol/atol (dt is then the first step; with
    fixed_step they take the constant step dt instead, without error control).
    ``dense_output``: steps are not cut to land on the output grid (a fixed dt need not divide
    output_interval or t_end; the last step lands on t_end) and the rows on the grid are the
    method's dense output, each with one more right-hand-side evaluation for its diagnostics.

    Beyond the notebook (docs/model.md s.8-10): ``equilibrium_start`` starts at rest at the
    static equilibrium nearest the bottom of the cavity nearest (R_init, alpha_init) instead
    of at (R_init, alpha_init) (status no_equilibrium and no run when there is none);
    ``structure_inertia`` is I_s about z (inf: the fixed structure of EN-02); confinement
    ``normal`` presses the sphere along -n and ``base`` pulls it along -z, each with force
    ``confining_force`` P (``base`` is gravity of strength g + P / m); a run with a finite I_s
    or the normal preload takes the structure path of the core (theta, Theta and the
    preload's work in the state). ``stop_on_leaving_cavity`` turns leaving the starting
    cavity's cell from a recorded time into a stop (status left_cavity).

    ``flight`` (docs/model.md s.11) continues a run through separations and impacts
    instead of stopping it with contact_lost: restitution e in [0, 1], contact resumes
    after an impact leaving at less than ``resume_speed`` (m/s) or when more than
    ``impact_cap`` impacts fall within one second. Flight needs an explicit method, the
    fixed structure, rotation and energy bookkeeping (rotation defaults to on with it).
    """

    R0: float
    dR: float
    A: float
    Kr: int
    Ka: int
    law_r: Law
    law_a: Law
    law_gamma: Law
    m: float
    b: float
    g: float
    mu: float
    eps: float
    R_init: float
    alpha_init: float
    Rdot_init: float = 0.0
    alphadot_init: float = 0.0
    omega_init: tuple[float, float, float] = (0.0, 0.0, 0.0)
    t_end: float = 120.0
    dt: float = 0.002
    output_interval: float = 0.1
    rotation: bool | None = None
    energy: bool = True
    allow_unstable: bool = False
    method: str = "rk4"
    rtol: float = 1e-10
    atol: float = 1e-12
    fixed_step: bool = False
    dense_output: bool = False
    structure_inertia: float = math.inf
    confinement: str = "none"
    confining_force: float = 0.0
    equilibrium_start: bool = False
    stop_on_leaving_cavity: bool = False
    flight: bool = False
    restitution: float = 0.0
    resume_speed: float = 1e-4
    impact_cap: float = 100.0
    start_height: float = 0.0

    @property
    def adaptive(self) -> bool:
        """Whether the step is chosen by error control (adaptive method, not fixed_step)."""
        return solvers.get(self.method).adaptive and not self.fixed_step

    def __post_init__(self) -> None:
        for name in ("R0", "dR", "m", "b", "eps", "dt", "output_interval", "t_end"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        for name in ("A", "g", "mu"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        for name in ("Kr", "Ka"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value}")
        for name in ("law_r", "law_a", "law_gamma"):
            _check_law(name, getattr(self, name))
        omega = tuple(float(w) for w in self.omega_init)
        if len(omega) != 3:
            raise ValueError(f"omega_init needs 3 components, got {self.omega_init}")
        object.__setattr__(self, "omega_init", omega)
        solvers.get(self.method)
        for name in ("rtol", "atol"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not self.adaptive and not self.dense_output:
            _multiple("output_interval", self.output_interval, self.dt)
            _multiple("t_end", self.t_end, self.dt)
        if self.rotation is False and (self.mu > 0.0 or any(omega)):
            raise ValueError(
                "rotation=False needs mu = 0 and omega_init = 0: friction or an initial spin "
                f"couples rotation to the trajectory (mu = {self.mu}, omega_init = {omega})"
            )
        if not (self.structure_inertia > 0.0 and not math.isnan(self.structure_inertia)):
            raise ValueError(f"structure_inertia must be > 0 (inf: fixed), got "
                             f"{self.structure_inertia}")
        if self.confinement not in CONFINEMENTS:
            raise ValueError(f"confinement must be one of {', '.join(CONFINEMENTS)}, got "
                             f"{self.confinement!r}")
        P = self.confining_force
        if not (math.isfinite(P) and P >= 0.0):
            raise ValueError(f"confining_force must be finite and >= 0, got {P}")
        if self.confinement == "none" and P != 0.0:
            raise ValueError(f"confining_force = {P} N needs a confinement (normal or base)")
        self._check_flight()
        if self.equilibrium_start and not self.vertical_pull > 0.0:
            raise ValueError("equilibrium_start needs a pull along -z (g > 0 or a base "
                             "confinement with P > 0): the equilibrium minimises the height")

    def _check_flight(self) -> None:
        """Refuse flight settings out of range, or flight where the hybrid loop does not run."""
        e = self.restitution
        if not (math.isfinite(e) and 0.0 <= e <= 1.0):
            raise ValueError(f"restitution must be in [0, 1], got {e}")
        if not (math.isfinite(self.resume_speed) and self.resume_speed >= 0.0):
            raise ValueError(f"resume_speed must be finite and >= 0, got {self.resume_speed}")
        if not (math.isfinite(self.impact_cap) and 1.0 <= self.impact_cap <= MAX_IMPACT_CAP):
            raise ValueError(f"impact_cap must be between 1 and {MAX_IMPACT_CAP:g} per second, "
                             f"got {self.impact_cap}")
        if not (math.isfinite(self.start_height) and self.start_height >= 0.0):
            raise ValueError(f"start_height must be finite and >= 0, got {self.start_height}")
        if not self.flight:
            if self.start_height > 0.0:
                raise ValueError(f"start_height = {self.start_height} m needs flight")
            return
        if self.dense_output:
            raise ValueError("flight takes its own steps to every event: dense_output is not "
                             "available with it")
        if solvers.get(self.method).stepper != solvers.EXPLICIT:
            raise ValueError(f"flight needs an explicit method (rk4, dopri5, dop853), got "
                             f"{self.method!r}")
        if self.structure_free:
            raise ValueError("flight needs the fixed structure without a normal preload")
        if self.rotation is False or not self.energy:
            raise ValueError("flight needs rotation and energy bookkeeping (rotation: None "
                             "or True, energy: True)")

    @property
    def structure_free(self) -> bool:
        """Whether the run takes the structure path (docs/model.md s.9-10): a structure free to
        yaw (finite I_s) or the normal preload, which needs that path's bookkeeping even on a
        fixed structure (I_s = inf there, so theta stays 0 exactly)."""
        return math.isfinite(self.structure_inertia) or self.confinement == "normal"

    @property
    def vertical_pull(self) -> float:
        """Acceleration of the pull along -z: gravity g, plus P / m for the base confinement
        (docs/model.md s.10: a pull toward the base acts as gravity of strength P / m)."""
        if self.confinement == "base":
            return self.g + self.confining_force / self.m
        return self.g

    @property
    def preload(self) -> float:
        """The normal preload P (N) along -n; 0 unless confinement is normal."""
        return self.confining_force if self.confinement == "normal" else 0.0

    @functools.cached_property
    def equilibrium(self) -> Equilibrium | None:
        """The static equilibrium of docs/model.md s.8.1 (None unless equilibrium_start)."""
        if not self.equilibrium_start:
            return None
        n, m = self.cavity_cell()
        return static_equilibrium(self.R0, self.k, self.A, float(self.Ka), self.b,
                                  self.law_r.scalar(0.0)[0], self.law_a.scalar(0.0)[0],
                                  self.law_gamma.scalar(0.0)[0], n, m)

    @property
    def start(self) -> tuple[float, float]:
        """(R, alpha) the run starts at: the equilibrium when asked for and acceptable, else
        (R_init, alpha_init)."""
        eq = self.equilibrium
        if eq is not None and eq.acceptable:
            return eq.R, eq.alpha
        return self.R_init, self.alpha_init

    @property
    def rotation_integrated(self) -> bool:
        """Whether the spin and orientation are integrated (auto: mu > 0 or a nonzero spin)."""
        if self.rotation is None:
            return self.flight or self.mu > 0.0 or any(w != 0.0 for w in self.omega_init)
        return bool(self.rotation)

    @property
    def inertia(self) -> float:
        """Moment of inertia of the homogeneous sphere, I = 2 m b^2 / 5."""
        return contact.inertia(self.m, self.b)

    @property
    def k(self) -> float:
        """Radial wavenumber k = 2 pi Kr / dR."""
        return wavenumber(self.Kr, self.dR)

    def cavity_branch(self) -> int:
        """Branch n of the cavity R_c = (pi/2 - phi_r + 2 pi n) / k nearest R_init at t = 0."""
        return cavity_branch(self.R_init, self.law_r.scalar(0.0)[0], self.k)

    def cavity_cell(self) -> tuple[int, int]:
        """The cavity (n, m) nearest (R_init, alpha_init) at t = 0: the one whose cell the
        "carried" check follows (docs/model.md s.8.2) and whose bottom an equilibrium
        start begins from."""
        m = cavity_angle_branch(self.alpha_init, self.law_a.scalar(0.0)[0], float(self.Ka))
        return self.cavity_branch(), m

    def parameter_vector(self) -> NDArray[np.float64]:
        """Plain parameter array in the layout the compiled core expects."""
        p = np.empty(NPAR)
        p[P_R0] = self.R0
        p[P_DR] = self.dR
        p[P_K] = self.k
        p[P_A] = self.A
        p[P_KA] = float(self.Ka)
        p[P_M] = self.m
        p[P_B] = self.b
        p[P_G] = self.vertical_pull
        p[P_MU] = self.mu
        p[P_EPS] = self.eps
        p[P_I] = self.inertia
        n, m = self.cavity_cell()
        p[P_NCAV] = float(n)
        p[P_MCAV] = float(m)
        p[P_IS] = self.structure_inertia
        p[P_INV_IS] = inverse_inertia(self.structure_inertia)
        p[P_PRELOAD] = self.preload
        p[P_STOP_LEAVE] = 1.0 if self.stop_on_leaving_cavity else 0.0
        return p

    def law_matrix(self) -> NDArray[np.float64]:
        """The three laws (r, alpha, gamma) as a (3, NLAW) coefficient array (rows LAW_R,
        LAW_A, LAW_GAMMA of creatio.dynamics.layout)."""
        return np.array([law.coefficients() for law in (self.law_r, self.law_a, self.law_gamma)])

    def driver_arguments(self) -> tuple[tuple, dict]:
        """(positional, keyword) arguments of creatio.dynamics.solvers.driver.run: the method,
        parameters, laws, initial state, a preallocated history table, and the step plan.

        Fixed-step runs take n_steps = t_end / dt steps with a history row every
        output_interval / dt; adaptive ones, and dense output, write a row per output time.
        """
        rot, en = self.rotation_integrated, bool(self.energy)
        if self.adaptive or self.dense_output:
            n_steps, stride = math.ceil(self.t_end / self.output_interval * (1 - 1e-12)), 1
        else:
            n_steps = _multiple("t_end", self.t_end, self.dt)
            stride = _multiple("output_interval", self.output_interval, self.dt)
        out = np.empty((n_steps // stride + 3, NCOL))
        args = (solvers.get(self.method), self.parameter_vector(), self.law_matrix(),
                self.initial_state(rot, en), out)
        kwargs = {
            "t_end": self.t_end, "interval": self.output_interval, "h0": self.dt,
            "n_steps": 0 if self.adaptive else n_steps, "stride": stride,
            "rtol": self.rtol, "atol": self.atol, "fixed": not self.adaptive,
            "max_steps": MAX_STEPS, "rotation": rot, "energy": en,
            "free": self.structure_free, "dense": self.dense_output,
        }
        return args, kwargs

    def flight_arguments(self) -> tuple[np.ndarray, np.ndarray]:
        """The hybrid loop's extra arguments: an empty event table sized for the impact cap
        over the run, and (restitution, resumption speed, impact cap, start height)."""
        rows = int(3 * self.impact_cap * self.t_end) + 64
        return (np.full((rows, NEV), math.nan),
                np.array([self.restitution, self.resume_speed, self.impact_cap,
                          self.start_height]))

    def compiled_call(self):
        """A zero-argument call of the compiled run with every argument prepared, for
        timing the core alone; returns the driver's result tuple."""
        from creatio.dynamics.solvers.driver import run

        args, kwargs = self.driver_arguments()
        return lambda: run(*args, **kwargs)

    def initial_state(self, rotation: bool, energy: bool) -> NDArray[np.float64]:
        """Initial state vector for the given specialisation (identity orientation, zero sums),
        laid out by creatio.dynamics.layout (docs/model.md s.4.7)."""
        R, alpha = self.start
        y = np.zeros(state_size(rotation, energy, self.structure_free))
        y[Y_R] = R
        y[Y_ALPHA] = alpha
        y[Y_RDOT] = self.Rdot_init
        y[Y_ALPHADOT] = self.alphadot_init
        if rotation:
            y[Y_OMEGA:Y_OMEGA + 3] = self.omega_init
            y[Y_Q] = 1.0
        return y


@dataclass(frozen=True)
class SimulationResult:
    """Sampled histories (world frame, SI units) and all-step extrema of one sphere run."""

    t: NDArray[np.float64]
    X: NDArray[np.float64]
    R: NDArray[np.float64]
    alpha: NDArray[np.float64]
    V: NDArray[np.float64]
    speed: NDArray[np.float64]
    N: NDArray[np.float64]
    f: NDArray[np.float64]
    slip_speed: NDArray[np.float64]
    omega: NDArray[np.float64]
    spin_rate: NDArray[np.float64]
    cumulative_spin: NDArray[np.float64]
    Q: NDArray[np.float64]
    marker: NDArray[np.float64]
    azimuth: NDArray[np.float64]
    kinetic: NDArray[np.float64]
    potential: NDArray[np.float64]
    energy: NDArray[np.float64]
    surface_work: NDArray[np.float64]
    friction_dissipation: NDArray[np.float64]
    energy_residual: NDArray[np.float64]
    cavity_R: NDArray[np.float64]
    min_N: float
    max_N: float
    max_slip_speed: float
    max_energy_residual: float
    max_cavity_tracking_error: float
    min_edge_clearance: float
    max_b_kappa: float
    status: str
    stop_time: float
    steps: int
    rhs_evals: int
    rotation_integrated: bool
    energy_integrated: bool
    dt: float
    stability_limit: float
    warnings: list[str] = field(default_factory=list)
    method: str = "rk4"
    rejected_steps: int = 0
    jacobians: int = 0
    lu_factorisations: int = 0
    cell_u: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    cell_v: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    theta: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    theta_rate: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    hz_structure: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    hz_orbital: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    hz_spin: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    confinement_work: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    world_azimuth: NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    left_cavity_time: float = math.nan
    max_hz_drift: float = math.nan
    max_structure_momentum: float = math.nan
    max_structure_rate: float = math.nan
    max_contact_radius: float = math.nan
    structure_free: bool = False
    start_R: float = math.nan
    start_alpha: float = math.nan
    equilibrium_message: str = ""
    flight: bool = False
    events: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, NEV)))
    max_flight_height: float = math.nan
    ends_in_flight: bool = False

    @property
    def carried(self) -> bool:
        """Whether the contact point never left its starting cavity's cell (docs/model.md
        s.8.2) over the steps that ran."""
        return math.isnan(self.left_cavity_time) and self.status != "no_equilibrium"


def _start_jets(problem: SphereProblem) -> tuple:
    """The offset jets at the start point and t = 0."""
    pr, pr1, pr2 = problem.law_r.scalar(0.0)
    pa, pa1, pa2 = problem.law_a.scalar(0.0)
    gm, g1, g2 = problem.law_gamma.scalar(0.0)
    R, alpha = problem.start
    return offset_jets(R, alpha, problem.R0, problem.k, problem.A, float(problem.Ka),
                       problem.b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2)


def normal_reaction_at_start(problem: SphereProblem) -> float:
    """N at the initial state (docs/model.md s.4), evaluated with the model's own scalar
    formulas, without a compiler: m n . (a0 - g) with the pull along -z of the problem,
    plus the normal preload (s.10); the structure's reaction term m theta'' n . (z^ x X) of
    s.9 is left out (it vanishes at rest on a fixed structure and is second order in 1/I_s
    otherwise)."""
    _, _, n1, n2, n3, P, Q, Z = _start_jets(problem)
    a0 = contact.acceleration_at_fixed_rates(P, Q, Z, problem.Rdot_init, problem.alphadot_init)
    return float(contact.normal_reaction(problem.m, problem.vertical_pull, n1, n2, n3, *a0)
                 + problem.preload)


def contact_radius_at_start(problem: SphereProblem) -> float:
    """Horizontal radius rho_c of the contact point at the start (the lever arm of the
    friction's reaction on a free structure, docs/model.md s.6.3 and s.9)."""
    return float(_start_jets(problem)[0][0])


def normal_estimate(problem: SphereProblem) -> float:
    """The a-priori normal reaction of the stability estimate (docs/model.md s.6)."""
    return contact.normal_estimate(normal_reaction_at_start(problem), problem.m,
                                   problem.vertical_pull)


def slip_rate(problem: SphereProblem, N: float, rho: float | None = None) -> float:
    """The slip relaxation rate of this sphere at normal reaction N (1/s); on a free
    structure with the contact at horizontal radius rho (default: the start's), the
    structure's turn adds rho^2 / I_s to the slip mobility (docs/model.md s.6.3)."""
    inv_Is = inverse_inertia(problem.structure_inertia)
    if inv_Is == 0.0:
        return contact.slip_relaxation_rate(problem.mu, N, problem.m, problem.b, problem.eps)
    rho = contact_radius_at_start(problem) if rho is None else rho
    return contact.slip_relaxation_rate(problem.mu, N, problem.m, problem.b, problem.eps, rho,
                                        inv_Is)


def stability_limit(problem: SphereProblem) -> float:
    """Largest stable dt (s) of the problem's fixed-step scheme for the friction's slip
    relaxation (docs/model.md s.6); inf for an error-controlled or L-stable method.

    Near zero slip the slip relaxes at lambda = 3.5 mu N / (m eps); an explicit method with
    real stability interval z* (solvers.Method.stability_bound: RK4 2.7853, dopri5 3.3066,
    dop853 6.3937) needs lambda dt <= z*. N is estimated a priori as 1.25 x max(N at the
    initial state, m g): on slowly actuated surfaces N stays within a few per cent of its
    start value, and the margin covers surface accelerations up to g/4 beyond it (simulate
    also checks the limit against the run's max N). On a free structure the rate gains
    rho_c^2 / I_s with rho_c the contact point's horizontal radius at the start (simulate
    checks it again with the largest rho_c reached). Returns inf for mu = 0.
    """
    method = solvers.get(problem.method)
    if problem.mu == 0.0 or problem.adaptive or method.l_stable:
        return math.inf
    return contact.stable_step(method.stability_bound, slip_rate(problem, normal_estimate(problem)))
