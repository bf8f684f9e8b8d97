"""Problem definition, result container and driver of the sphere dynamics (MODEL.md s.4-6)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from creatio.dynamics import core, integrators
from creatio.dynamics.laws import law_eval

__all__ = [
    "METHODS",
    "RK4_REAL_STABILITY",
    "STABILITY_MARGIN",
    "SimulationResult",
    "SphereProblem",
    "UnstableStepError",
    "simulate",
    "stability_limit",
]

#: Classical RK4 is stable for z = lambda dt on the negative real axis down to this value
#: (the real root of |1 + z + z^2/2 + z^3/6 + z^4/24| = 1, taken with a minus sign).
RK4_REAL_STABILITY = 2.785293563405282

#: Integration methods: fixed-step RK4 (the notebook's reference) and the compiled
#: adaptive / stiffness-aware ones of creatio.dynamics.integrators.
METHODS = ("rk4", "dopri5", "dop853", "radau5")

#: Accepted steps after which an adaptive run gives up (status step_failed).
MAX_STEPS = 20_000_000

#: Safety factor on the a-priori normal reaction used by :func:`stability_limit`.
STABILITY_MARGIN = 1.25

_REL_TOL = 1e-9


class UnstableStepError(ValueError):
    """dt lies beyond the RK4 stability limit of the regularised friction (MODEL.md s.6)."""


def _law_tuple(name: str, law: tuple[float, ...]) -> tuple[float, ...]:
    coeffs = tuple(float(c) for c in law)
    if len(coeffs) != 6:
        raise ValueError(f"{name} needs 6 coefficients (phi0, rate, delta, T, amplitude, omega)")
    if not coeffs[3] > 0.0:
        raise ValueError(f"{name}: cycle length T must be > 0, got {coeffs[3]}")
    if not all(math.isfinite(c) for c in coeffs):
        raise ValueError(f"{name} has non-finite coefficients: {coeffs}")
    return coeffs


def _multiple(name: str, value: float, dt: float) -> int:
    """Integer n with value = n dt within a relative 1e-9, else ValueError naming both."""
    ratio = value / dt
    n = round(ratio)
    if n < 1 or abs(ratio - n) > _REL_TOL * ratio:
        raise ValueError(f"{name} = {value} s is not an integer multiple of dt = {dt} s")
    return n


@dataclass(frozen=True)
class SphereProblem:
    """One sphere on the moving corrugated surface: geometry, laws, sphere, initial state, solver.

    Laws are the 6-coefficient vectors (phi0, rate, delta, T, amplitude, omega) of
    creatio.laws; angles in radians, SI units; gravity is (0, 0, -g).

    method: "rk4" (fixed step dt) or one of the adaptive methods "dopri5", "dop853",
    "radau5", which control the local error to rtol/atol (dt is then the first step; with
    fixed_step they take the constant step dt instead, without error control).
    """

    R0: float
    dR: float
    A: float
    Kr: int
    Ka: int
    law_r: tuple[float, ...]
    law_a: tuple[float, ...]
    law_gamma: tuple[float, ...]
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

    @property
    def adaptive(self) -> bool:
        """Whether the step is chosen by error control (adaptive method, not fixed_step)."""
        return self.method != "rk4" and not self.fixed_step

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
        object.__setattr__(self, "law_r", _law_tuple("law_r", self.law_r))
        object.__setattr__(self, "law_a", _law_tuple("law_a", self.law_a))
        object.__setattr__(self, "law_gamma", _law_tuple("law_gamma", self.law_gamma))
        omega = tuple(float(w) for w in self.omega_init)
        if len(omega) != 3:
            raise ValueError(f"omega_init needs 3 components, got {self.omega_init}")
        object.__setattr__(self, "omega_init", omega)
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        for name in ("rtol", "atol"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not self.adaptive:
            _multiple("output_interval", self.output_interval, self.dt)
            _multiple("t_end", self.t_end, self.dt)
        if self.rotation is False and (self.mu > 0.0 or any(omega)):
            raise ValueError(
                "rotation=False needs mu = 0 and omega_init = 0: friction or an initial spin "
                f"couples rotation to the trajectory (mu = {self.mu}, omega_init = {omega})"
            )

    @property
    def rotation_integrated(self) -> bool:
        """Whether the spin and orientation are integrated (auto: mu > 0 or a nonzero spin)."""
        if self.rotation is None:
            return self.mu > 0.0 or any(w != 0.0 for w in self.omega_init)
        return bool(self.rotation)

    @property
    def inertia(self) -> float:
        """Moment of inertia of the homogeneous sphere, I = 2 m b^2 / 5."""
        return 0.4 * self.m * self.b * self.b

    @property
    def k(self) -> float:
        """Radial wavenumber k = 2 pi Kr / dR."""
        return 2.0 * math.pi * self.Kr / self.dR

    def cavity_branch(self) -> int:
        """Branch n of the cavity R_c = (pi/2 - phi_r + 2 pi n) / k nearest R_init at t = 0."""
        phi_r0 = law_eval(*self.law_r, 0.0)[0]
        return round((self.k * self.R_init - 0.5 * math.pi + phi_r0) / (2.0 * math.pi))

    def parameter_vector(self) -> NDArray[np.float64]:
        """Plain parameter array in the layout the compiled core expects."""
        p = np.empty(core.NPAR)
        p[core.P_R0] = self.R0
        p[core.P_DR] = self.dR
        p[core.P_K] = self.k
        p[core.P_A] = self.A
        p[core.P_KA] = float(self.Ka)
        p[core.P_M] = self.m
        p[core.P_B] = self.b
        p[core.P_G] = self.g
        p[core.P_MU] = self.mu
        p[core.P_EPS] = self.eps
        p[core.P_I] = self.inertia
        p[core.P_NCAV] = float(self.cavity_branch())
        return p

    def law_matrix(self) -> NDArray[np.float64]:
        """The three laws (r, alpha, gamma) as a (3, 6) coefficient array."""
        return np.array([self.law_r, self.law_a, self.law_gamma], dtype=float)

    def core_arguments(self) -> tuple:
        """Arguments of core.run for this problem: parameters, laws, initial state, step
        counts, a preallocated output table and the rotation/energy specialisation.

        (The adaptive driver takes the first three and the table; its rows are the output
        grid, so the table is sized by t_end / output_interval for every method.)"""
        rot, en = self.rotation_integrated, bool(self.energy)
        if self.adaptive:
            n_steps, stride = math.ceil(self.t_end / self.output_interval * (1 - 1e-12)), 1
        else:
            n_steps = _multiple("t_end", self.t_end, self.dt)
            stride = _multiple("output_interval", self.output_interval, self.dt)
        out = np.empty((n_steps // stride + 3, core.NCOL))
        return (
            self.parameter_vector(),
            self.law_matrix(),
            self.initial_state(rot, en),
            n_steps,
            self.dt,
            stride,
            out,
            rot,
            en,
        )

    def initial_state(self, rotation: bool, energy: bool) -> NDArray[np.float64]:
        """Initial state vector for the given specialisation (identity orientation, zero sums)."""
        y = [self.R_init, self.alpha_init, self.Rdot_init, self.alphadot_init]
        if rotation:
            y += [*self.omega_init, 1.0, 0.0, 0.0, 0.0, 0.0]
        if energy:
            y += [0.0, 0.0]
        return np.array(y, dtype=float)


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


def _normal_reaction_at_start(problem: SphereProblem) -> float:
    y = problem.initial_state(True, True)
    _, N, _, _ = core.evaluate(problem.parameter_vector(), problem.law_matrix(), y, 0.0)
    return float(N)


def _slip_rate_per_newton(problem: SphereProblem) -> float:
    # d v_s/dt = (1/m + b^2/I) f; with f = -(mu N/eps) v_s near zero slip the rate is
    # mu N (1/m + b^2/I) / eps = 3.5 mu N / (m eps) per newton of N.
    return problem.mu * (1.0 / problem.m + problem.b**2 / problem.inertia) / problem.eps


def _normal_estimate(problem: SphereProblem) -> float:
    return STABILITY_MARGIN * max(_normal_reaction_at_start(problem), problem.m * problem.g)


def stability_limit(problem: SphereProblem) -> float:
    """Largest stable dt (s) of the problem's fixed-step scheme for the friction's slip
    relaxation (MODEL.md s.6); inf for an error-controlled or A-stable method.

    Near zero slip f = -(mu N / eps) v_s, and f feeds the slip through translation (f/m) and
    rotation (-b dw/dt x n = (b^2/I) f), so v_s relaxes at lambda = mu N (1/m + b^2/I) / eps
    = 3.5 mu N / (m eps); RK4 needs lambda dt <= 2.7853 (dopri5 3.3066, dop853 6.3937 at a
    fixed step: integrators.real_stability_bound). Adaptive runs find their stable step
    themselves and radau5 (L-stable) has none. N is estimated a priori as
    STABILITY_MARGIN (1.25) x max(N at the initial state, m g): on slowly actuated surfaces
    N stays within a few per cent of its start value, and the margin covers surface
    accelerations up to g/4 beyond it (simulate also checks the limit against the run's max N).
    Returns inf for mu = 0 (no friction, no slip stiffness).
    """
    if problem.mu == 0.0 or problem.adaptive or problem.method == "radau5":
        return math.inf
    return _bound(problem.method) / (_slip_rate_per_newton(problem) * _normal_estimate(problem))


@functools.cache
def _bound(method: str) -> float:
    """Real stability interval of a fixed-step explicit method (RK4's exact constant)."""
    return RK4_REAL_STABILITY if method == "rk4" else integrators.real_stability_bound(method)


def simulate(problem: SphereProblem) -> SimulationResult:
    """Integrate one sphere run with problem.method; return its histories and extrema.

    Raises UnstableStepError when dt exceeds stability_limit(problem) unless allow_unstable
    is set (then the run goes ahead and the result carries a warning).
    """
    warnings: list[str] = []
    limit = stability_limit(problem)
    name = problem.method.upper()
    bound = _bound(problem.method) if math.isfinite(limit) else math.inf
    if problem.dt > limit:
        n_est = _normal_estimate(problem)
        rate = _slip_rate_per_newton(problem) * n_est
        message = (
            f"dt = {problem.dt} s exceeds the {name} stability limit {limit:.6g} s of the "
            f"regularised friction (mu = {problem.mu}, eps = {problem.eps} m/s, m = {problem.m} "
            f"kg, b = {problem.b} m): the largest stable dt is {limit:.6g} s "
            f"(slip rate 3.5 mu N / (m eps) = {rate:.4g} 1/s at the a-priori N = {n_est:.4g} N; "
            f"lambda dt = {rate * problem.dt:.3g}, {name} needs <= {bound:.4g})"
        )
        if not problem.allow_unstable:
            raise UnstableStepError(message)
        warnings.append("allow_unstable override: " + message)
    rot = problem.rotation_integrated
    en = bool(problem.energy)
    args = problem.core_arguments()
    out = args[6]
    rejected = jacobians = factorisations = 0
    if problem.method == "rk4":
        status, steps, rows, evals, ext = core.run(*args)
        stop_time = steps * problem.dt
    else:
        p, lawc, y0 = args[0], args[1], args[2]
        (status, steps, rows, evals, ext, rejected, jacobians, factorisations, stop_time) = (
            integrators.run(
                p, lawc, y0, problem.t_end, problem.output_interval, problem.dt, problem.rtol,
                problem.atol, problem.method, problem.fixed_step, MAX_STEPS, out, rot, en,
            )
        )  # fmt: skip
    min_n, max_n, max_slip, max_res, max_track, min_clear, max_bk = (
        float(v) for v in ext[: core.E_E0]
    )
    if problem.mu > 0.0 and math.isfinite(max_n) and math.isfinite(bound):
        observed = bound / (_slip_rate_per_newton(problem) * max_n)
        if problem.dt > observed:
            warnings.append(
                f"max N = {max_n:.6g} N during the run puts the {name} stability limit at "
                f"{observed:.6g} s, below dt = {problem.dt} s (mu = {problem.mu}, "
                f"eps = {problem.eps} m/s): slip may chatter"
            )
    h = out[:rows]
    return SimulationResult(
        t=h[:, core.COL_T].copy(),
        X=h[:, core.COL_X : core.COL_X + 3].copy(),
        R=h[:, core.COL_R].copy(),
        alpha=h[:, core.COL_ALPHA].copy(),
        V=h[:, core.COL_V : core.COL_V + 3].copy(),
        speed=h[:, core.COL_SPEED].copy(),
        N=h[:, core.COL_N].copy(),
        f=h[:, core.COL_F : core.COL_F + 3].copy(),
        slip_speed=h[:, core.COL_SLIP].copy(),
        omega=h[:, core.COL_OMEGA : core.COL_OMEGA + 3].copy(),
        spin_rate=h[:, core.COL_SPIN_RATE].copy(),
        cumulative_spin=h[:, core.COL_SPIN].copy(),
        Q=h[:, core.COL_Q : core.COL_Q + 4].copy(),
        marker=h[:, core.COL_MARKER : core.COL_MARKER + 3].copy(),
        azimuth=h[:, core.COL_AZIMUTH].copy(),
        kinetic=h[:, core.COL_KINETIC].copy(),
        potential=h[:, core.COL_POTENTIAL].copy(),
        energy=h[:, core.COL_ENERGY].copy(),
        surface_work=h[:, core.COL_WORK].copy(),
        friction_dissipation=h[:, core.COL_DISSIPATION].copy(),
        energy_residual=h[:, core.COL_RESIDUAL].copy(),
        cavity_R=h[:, core.COL_CAVITY_R].copy(),
        min_N=float(min_n),
        max_N=float(max_n),
        max_slip_speed=float(max_slip),
        max_energy_residual=float(max_res),
        max_cavity_tracking_error=float(max_track),
        min_edge_clearance=float(min_clear),
        max_b_kappa=float(max_bk),
        status=core.STATUS_NAMES[status],
        stop_time=float(stop_time),
        steps=int(steps),
        rhs_evals=int(evals),
        rotation_integrated=rot,
        energy_integrated=en,
        dt=problem.dt,
        stability_limit=limit,
        warnings=warnings,
        method=problem.method,
        rejected_steps=int(rejected),
        jacobians=int(jacobians),
        lu_factorisations=int(factorisations),
    )
