"""A sphere run as plain numbers, its result, and its stability limit (docs/model.md s.4-11).

Nothing here compiles: a SphereProblem is built, checked and its friction stability limit
estimated without numba (validation and workflow planning use it), and creatio.dynamics
.simulate hands it to the compiled driver. A problem is split the way a study's config is:

* :class:`Model`, the physical system: the surface's shape (creatio.model.surface.Surface)
  and motion (its three time laws, creatio.model.surface.Motion), the :class:`Sphere`, and
  the :class:`Structure` that carries the membrane (fixed, free to yaw, confined);
* :class:`Start`, the initial state;
* :class:`Solver`, how it is integrated: method, step, tolerances, dense output, budget;
* :class:`Output`, what is recorded: the span and grid, rotation and energy bookkeeping;
* :class:`Events`, what a run does at contact loss (flight) and at leaving its cavity.

Its :class:`SimulationResult` is split the same way: the sampled :class:`Histories`, the
all-step :class:`Extrema`, the :class:`Counts` (status and cost) and the :class:`EventLog`
(the cavity left, the flights).

The same problem describes the fixed structure of EN-02 (s.4), an equilibrium start on the
inclined family (s.8), a structure free to yaw (s.9), a confining force (s.10) and flight
(s.11).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from creatio.dynamics import solvers
from creatio.dynamics.layout import (
    CT_PHI,
    LAW_A,
    LAW_GAMMA,
    LAW_R,
    NCTLS,
    NEV,
    NLAWS,
    NPAR,
    P_A,
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
    P_PRELOAD,
    P_R0,
    P_STOP_LEAVE,
    Y_ALPHA,
    Y_ALPHADOT,
    Y_OMEGA,
    Y_Q,
    Y_R,
    Y_RDOT,
    control_start,
    state_size,
)
from creatio.model import sphere as contact
from creatio.model.cavity import cavity_angle_branch, cavity_branch
from creatio.model.control import Controller
from creatio.model.equilibrium import Equilibrium, static_equilibrium
from creatio.model.laws import NLAW, Law
from creatio.model.numerics import steps_in
from creatio.model.offset import offset_jets, offset_jets_skin
from creatio.model.structure import CONFINEMENTS, inverse_inertia
from creatio.model.surface import Motion, Surface

__all__ = [
    "MAX_IMPACT_CAP",
    "MAX_RHS_EVALS",
    "PROGRESS_INTERVAL",
    "Counts",
    "EventLog",
    "Events",
    "Extrema",
    "Histories",
    "Model",
    "Output",
    "SimulationResult",
    "Solver",
    "Sphere",
    "SphereProblem",
    "Start",
    "Structure",
    "UnstableStepError",
    "check_stable",
    "normal_reaction_at_start",
    "stability_limit",
]

#: Right-hand-side evaluations a run may spend before it stops with status budget_exceeded
#: (Solver.max_rhs_evals, solver.max_rhs_evals in a config): above every study's runs (EN-02
#: at dt / 2 takes 4.8e5, EN-03M's strongest confinement, 43 us steps over 120 s, 1.1e7),
#: and spent in about a minute of one core where a run would go on for hours.
MAX_RHS_EVALS = 50_000_000
#: Seconds between the progress lines a long run prints to stderr.
PROGRESS_INTERVAL = 10.0
#: Largest cap on impacts per second: the event table is sized 3 x cap x t_end rows.
MAX_IMPACT_CAP = 10_000.0


class UnstableStepError(ValueError):
    """dt lies beyond the fixed-step stability limit of the regularised friction
    (docs/model.md s.6.3)."""


def _positive(record: Any, *names: str) -> None:
    for name in names:
        value = getattr(record, name)
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be finite and > 0, got {value}")


def _nonnegative(record: Any, *names: str) -> None:
    for name in names:
        value = getattr(record, name)
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} must be finite and >= 0, got {value}")


def _multiple(name: str, value: float, dt: float) -> int:
    """Integer n with value = n dt within a relative 1e-9, else ValueError naming both."""
    n = steps_in(value, dt)
    if n is None:
        raise ValueError(f"{name} = {value} s is not an integer multiple of dt = {dt} s")
    return n


# ------------------------------------------------------------------------------- model
@dataclass(frozen=True)
class Sphere:
    """The homogeneous rigid sphere and its contact (docs/model.md s.4): mass m, radius b,
    gravity of magnitude g, friction coefficient mu and its regularisation speed eps, and the
    membrane's mounting tilt: its plane off level by beta (0 <= beta < pi/2) toward the
    azimuth psi, so gravity is g (sin beta cos psi, sin beta sin psi, -cos beta) in the
    structure's frame (beta = 0: along -z, as on a level membrane)."""

    m: float
    b: float
    g: float
    mu: float
    eps: float
    beta: float = 0.0
    psi: float = 0.0

    def __post_init__(self) -> None:
        _positive(self, "m", "b", "eps")
        _nonnegative(self, "g", "mu", "beta")
        if not self.beta < 0.5 * math.pi:
            raise ValueError(f"beta must be < pi/2 (the membrane off level by less than 90 "
                             f"degrees), got {self.beta}")
        if not math.isfinite(self.psi):
            raise ValueError(f"psi must be finite, got {self.psi}")

    @property
    def tilted(self) -> bool:
        """Whether gravity has a horizontal part in the structure's frame (beta > 0, g > 0)."""
        return self.beta != 0.0 and self.g != 0.0

    @property
    def gravity(self) -> tuple[float, float, float]:
        """Gravity g_vec in the structure's frame (m/s^2); exactly (0, 0, -g) at beta = 0."""
        if not self.tilted:
            return 0.0, 0.0, -self.g
        return contact.tilted_gravity(self.g, self.beta, self.psi)

    @property
    def inertia(self) -> float:
        """Moment of inertia of the homogeneous sphere, I = 2 m b^2 / 5."""
        return contact.inertia(self.m, self.b)


@dataclass(frozen=True)
class Structure:
    """What carries the membrane (docs/model.md s.9-10): its moment of inertia I_s about z
    (inf: fixed, EN-02) and a confining force P, ``normal`` (a preload along -n) or ``base``
    (a pull along -z, gravity of strength g + P / m)."""

    inertia: float = math.inf
    confinement: str = "none"
    force: float = 0.0

    def __post_init__(self) -> None:
        if not (self.inertia > 0.0 and not math.isnan(self.inertia)):
            raise ValueError(f"inertia must be > 0 (inf: fixed), got {self.inertia}")
        if self.confinement not in CONFINEMENTS:
            raise ValueError(f"confinement must be one of {', '.join(CONFINEMENTS)}, got "
                             f"{self.confinement!r}")
        _nonnegative(self, "force")
        if self.confinement == "none" and self.force != 0.0:
            raise ValueError(f"force = {self.force} N needs a confinement (normal or "
                             "base)")

    @property
    def free(self) -> bool:
        """Whether a run takes the structure path (docs/model.md s.9-10): a structure free to
        yaw (finite I_s) or the normal preload, which needs that path's bookkeeping even on
        a fixed structure (I_s = inf there, so theta stays 0 exactly)."""
        return math.isfinite(self.inertia) or self.confinement == "normal"

    @property
    def preload(self) -> float:
        """The normal preload P (N) along -n; 0 unless confinement is normal."""
        return self.force if self.confinement == "normal" else 0.0


@dataclass(frozen=True)
class Model:
    """The physical system: the surface's shape and motion, the sphere, the structure.
    Angles in radians, SI units."""

    surface: Surface
    motion: Motion
    sphere: Sphere
    structure: Structure = Structure()
    #: the phase-tracking controller (docs/model.md s.12.2); None: phi_a is its law of time
    control: Controller | None = None

    def __post_init__(self) -> None:
        _positive(self.surface, "R0", "dR")
        _nonnegative(self.surface, "A")
        for name in ("phi_r", "phi_a", "gamma"):
            law = getattr(self.motion, name)
            if not isinstance(law, Law):
                raise ValueError(f"{name} must be a creatio.model.laws.Law, got {law!r}")
            if not np.all(np.isfinite(law.coefficients())):
                raise ValueError(f"{name} has non-finite coefficients: {law}")

    @property
    def k(self) -> float:
        """Radial wavenumber k = 2 pi Kr / dR."""
        return self.surface.k

    @property
    def vertical_pull(self) -> float:
        """Acceleration of the pull along -z: gravity g, plus P / m for the base confinement
        (docs/model.md s.10: a pull toward the base acts as gravity of strength P / m)."""
        g = -self.sphere.gravity[2]
        if self.structure.confinement == "base":
            return g + self.structure.force / self.sphere.m
        return g

    @property
    def pull(self) -> float:
        """Magnitude of the whole pull (vertical and, under a tilt, horizontal): the m g of the
        a-priori normal reaction (docs/model.md s.6); the vertical pull without tilt."""
        gx, gy, _ = self.sphere.gravity
        if not self.sphere.tilted:
            return self.vertical_pull
        return math.sqrt(self.vertical_pull ** 2 + gx * gx + gy * gy)

    def law_matrix(self) -> NDArray[np.float64]:
        """The three laws' coefficient vectors as the (NLAWS, NLAW) array the compiled core
        reads (rows LAW_R, LAW_A, LAW_GAMMA of creatio.dynamics.layout)."""
        lawc = np.empty((NLAWS, NLAW))
        lawc[LAW_R] = self.motion.phi_r.coefficients()
        lawc[LAW_A] = self.motion.phi_a.coefficients()
        lawc[LAW_GAMMA] = self.motion.gamma.coefficients()
        return lawc


@dataclass(frozen=True)
class Start:
    """The initial state: contact point (R, alpha) and its rates, the sphere's spin (world
    frame), whether to start instead at rest at the static equilibrium nearest the bottom of
    the cavity nearest (R, alpha) (docs/model.md s.8.1), and a dropped start: the centre
    ``height`` along n above its contact position, at rest, in flight (s.11)."""

    R: float
    alpha: float
    Rdot: float = 0.0
    alphadot: float = 0.0
    omega: tuple[float, float, float] = (0.0, 0.0, 0.0)
    equilibrium: bool = False
    height: float = 0.0

    def __post_init__(self) -> None:
        omega = tuple(float(w) for w in self.omega)
        if len(omega) != 3:
            raise ValueError(f"omega needs 3 components, got {self.omega}")
        object.__setattr__(self, "omega", omega)
        _nonnegative(self, "height")


# ------------------------------------------------------------------ solver, output, events
@dataclass(frozen=True)
class Solver:
    """How a run is integrated: a method of the registry (creatio.dynamics.solvers.METHODS)
    at the constant step dt (RK4, or any method with fixed_step) or under local error control
    to rtol / atol from the first step h0 (None: dt; a fixed step refuses h0, every step being
    dt); ``dense_output`` samples the output grid from each step's interpolant instead of
    cutting steps to land on it (a fixed dt need not then divide the interval; the last step
    lands on t_end). A run stops with status
    budget_exceeded after ``max_rhs_evals`` right-hand-side evaluations (the budget never
    changes a step), an adaptive run with step_size_collapse when its step size falls below
    the floors of creatio.dynamics.status (UNDERFLOW, COLLAPSE_TRIES), and it prints a line of
    progress to stderr every ``progress_interval`` seconds while it runs (inf: never)."""

    method: str = "rk4"
    dt: float = 0.002
    rtol: float = 1e-10
    atol: float = 1e-12
    fixed_step: bool = False
    dense_output: bool = False
    allow_unstable: bool = False
    max_rhs_evals: int = MAX_RHS_EVALS
    progress_interval: float = PROGRESS_INTERVAL
    h0: float | None = None

    def __post_init__(self) -> None:
        solvers.get(self.method)
        _positive(self, "dt", "rtol", "atol")
        if self.h0 is not None:
            _positive(self, "h0")
            if not self.adaptive:
                raise ValueError(f"h0 is the first step of an adaptive run; {self.method} at "
                                 f"a fixed step takes dt = {self.dt} every step, got h0 = "
                                 f"{self.h0}")
        if int(self.max_rhs_evals) != self.max_rhs_evals or self.max_rhs_evals < 1:
            raise ValueError(f"max_rhs_evals must be a positive integer, got "
                             f"{self.max_rhs_evals}")
        if not self.progress_interval > 0.0:
            raise ValueError(f"progress_interval must be > 0 s (inf: never), got "
                             f"{self.progress_interval}")

    @property
    def adaptive(self) -> bool:
        """Whether the step is chosen by error control (adaptive method, not fixed_step)."""
        return solvers.get(self.method).adaptive and not self.fixed_step

    @property
    def first_step(self) -> float:
        """The step the run starts with: h0 (None: dt); a fixed step's every step is dt."""
        return self.dt if self.h0 is None else self.h0


@dataclass(frozen=True)
class Output:
    """What a run records: the span [0, t_end], a history row every ``interval``, and
    whether rotation (None: when friction or a spin couples it to the path) and the energy
    bookkeeping are integrated."""

    t_end: float = 120.0
    interval: float = 0.1
    rotation: bool | None = None
    energy: bool = True

    def __post_init__(self) -> None:
        _positive(self, "t_end", "interval")


@dataclass(frozen=True)
class Events:
    """What a run does at an event. ``flight`` (docs/model.md s.11) continues it through
    separations and impacts instead of stopping with contact_lost: restitution e in [0, 1],
    contact resumes after an impact leaving at less than ``resume_speed`` (m/s) or when more
    than ``impact_cap`` impacts fall within one second. ``stop_on_leaving_cavity`` turns
    leaving the starting cavity's cell from a recorded time into a stop (status left_cavity)."""

    flight: bool = False
    restitution: float = 0.0
    resume_speed: float = 1e-4
    impact_cap: float = 100.0
    stop_on_leaving_cavity: bool = False

    def __post_init__(self) -> None:
        e = self.restitution
        if not (math.isfinite(e) and 0.0 <= e <= 1.0):
            raise ValueError(f"restitution must be in [0, 1], got {e}")
        _nonnegative(self, "resume_speed")
        if not (math.isfinite(self.impact_cap) and 1.0 <= self.impact_cap <= MAX_IMPACT_CAP):
            raise ValueError(f"impact_cap must be between 1 and {MAX_IMPACT_CAP:g} per second, "
                             f"got {self.impact_cap}")


# ----------------------------------------------------------------------------- problem
@dataclass(frozen=True)
class SphereProblem:
    """One sphere on the moving corrugated surface: the model, its start, and how the run is
    integrated, recorded and continued at events (see the module)."""

    model: Model
    start: Start
    solver: Solver = Solver()
    output: Output = Output()
    events: Events = Events()

    def __post_init__(self) -> None:
        sv, out, ev, start = self.solver, self.output, self.events, self.start
        if not self.adaptive and not sv.dense_output:
            _multiple("interval", out.interval, sv.dt)
            _multiple("t_end", out.t_end, sv.dt)
        mu = self.model.sphere.mu
        if out.rotation is False and (mu > 0.0 or any(start.omega)):
            raise ValueError(
                "rotation=False needs mu = 0 and omega = 0: friction or an initial spin "
                f"couples rotation to the trajectory (mu = {mu}, omega = {start.omega})"
            )
        if start.equilibrium and not self.model.vertical_pull > 0.0:
            raise ValueError("equilibrium start needs a pull along -z (g > 0 or a base "
                             "confinement with P > 0): the equilibrium minimises the height")
        if self.model.sphere.tilted and (self.structure_free or ev.flight
                                         or start.equilibrium):
            raise ValueError(f"beta = {self.model.sphere.beta} rad (a mounting tilt) needs the "
                             "fixed structure without a normal preload, no flight and no "
                             "equilibrium start: only the contact dynamics of a fixed "
                             "membrane carry gravity off the -z axis")
        if self.model.control is not None and self.structure_free:
            raise ValueError("the controlled phase needs the fixed structure and no normal "
                             "preload")
        if self.model.surface.ribs is not None and (ev.flight or start.equilibrium):
            raise ValueError(f"ribs = {self.model.surface.ribs.N} (a rib surface) needs no "
                             "flight and no equilibrium start: their foot-point and "
                             "equilibrium searches solve on the ideal surface")
        if not ev.flight:
            if start.height > 0.0:
                raise ValueError(f"height = {start.height} m (a dropped start) needs flight")
            return
        if sv.dense_output:
            raise ValueError("flight takes its own steps to every event: dense_output is not "
                             "available with it")
        if not solvers.get(sv.method).flight:
            able = ", ".join(m.name for m in solvers.METHODS.values() if m.flight)
            raise ValueError(f"flight needs a method its event loop runs ({able}), got "
                             f"{sv.method!r}")
        if self.structure_free:
            raise ValueError("flight needs the fixed structure without a normal preload")
        if out.rotation is False or not out.energy:
            raise ValueError("flight needs rotation and energy bookkeeping (rotation: None "
                             "or True, energy: True)")

    def replace(self, **changes: Any) -> SphereProblem:
        """A copy with fields changed, each named by its field name wherever it sits in the
        tree (names are unique over it): ``p.replace(mu=0.3, method="radau5", t_end=30.0)``;
        a whole record by its name: ``p.replace(motion=Motion(...))``."""
        return _replace(self, changes)

    @property
    def adaptive(self) -> bool:
        """Whether the step is chosen by error control (adaptive method, not fixed_step)."""
        return self.solver.adaptive

    @property
    def structure_free(self) -> bool:
        """Whether the run takes the structure path of the core (docs/model.md s.9-10)."""
        return self.model.structure.free

    @property
    def rotation_integrated(self) -> bool:
        """Whether the spin and orientation are integrated (auto: mu > 0, a nonzero spin, or
        flight)."""
        if self.output.rotation is None:
            return (self.events.flight or self.model.sphere.mu > 0.0
                    or any(w != 0.0 for w in self.start.omega))
        return bool(self.output.rotation)

    @functools.cached_property
    def equilibrium(self) -> Equilibrium | None:
        """The static equilibrium of docs/model.md s.8.1 (None unless asked for)."""
        if not self.start.equilibrium:
            return None
        n, m = self.cavity_cell()
        model, motion = self.model, self.model.motion
        return static_equilibrium(model.surface.R0, model.k, model.surface.A,
                                  float(model.surface.Ka), model.sphere.b,
                                  motion.phi_r.scalar(0.0)[0], motion.phi_a.scalar(0.0)[0],
                                  motion.gamma.scalar(0.0)[0], n, m)

    @property
    def start_point(self) -> tuple[float, float]:
        """(R, alpha) the run starts at: the equilibrium when asked for and acceptable, else
        the start's (R, alpha)."""
        eq = self.equilibrium
        if eq is not None and eq.acceptable:
            return eq.R, eq.alpha
        return self.start.R, self.start.alpha

    def cavity_cell(self) -> tuple[int, int]:
        """The cavity (n, m) nearest the start's (R, alpha) at t = 0: the one whose cell the
        "carried" check follows (docs/model.md s.8.2) and whose bottom an equilibrium start
        begins from (cavity branch n of R_c = (pi/2 - phi_r + 2 pi n) / k)."""
        motion = self.model.motion
        n = cavity_branch(self.start.R, motion.phi_r.scalar(0.0)[0], self.model.k)
        m = cavity_angle_branch(self.start.alpha, motion.phi_a.scalar(0.0)[0],
                                float(self.model.surface.Ka))
        return n, m

    def parameter_vector(self) -> NDArray[np.float64]:
        """The parameter vector the compiled core reads (creatio.dynamics.layout P_*)."""
        model = self.model
        surface, sphere, structure = model.surface, model.sphere, model.structure
        p = np.empty(NPAR)
        p[P_R0] = surface.R0
        p[P_DR] = surface.dR
        p[P_K] = model.k
        p[P_A] = surface.A
        p[P_KA] = float(surface.Ka)
        p[P_M] = sphere.m
        p[P_B] = sphere.b
        p[P_G] = model.vertical_pull
        p[P_MU] = sphere.mu
        p[P_EPS] = sphere.eps
        p[P_I] = sphere.inertia
        n, m = self.cavity_cell()
        p[P_NCAV] = float(n)
        p[P_MCAV] = float(m)
        p[P_IS] = structure.inertia
        p[P_INV_IS] = inverse_inertia(structure.inertia)
        p[P_PRELOAD] = structure.preload
        p[P_STOP_LEAVE] = 1.0 if self.events.stop_on_leaving_cavity else 0.0
        p[P_GX], p[P_GY], _ = sphere.gravity
        return p

    def law_matrix(self) -> NDArray[np.float64]:
        """The laws as the compiled core reads them (:meth:`Model.law_matrix`)."""
        return self.model.law_matrix()

    @property
    def controlled(self) -> bool:
        """Whether phi_a is the controlled state of docs/model.md s.12.2."""
        return self.model.control is not None

    def run_parameters(self) -> NDArray[np.float64] | tuple[NDArray[np.float64],
                                                             NDArray[np.float64]]:
        """The parameters the driver receives: :meth:`parameter_vector`, followed on the
        controlled path by the controller's row (creatio.dynamics.layout C_*); on a rib
        surface the pair (that vector, the skin's spline table), which selects the rib
        surface's specialisations (creatio.dynamics.surface)."""
        p = self.parameter_vector()
        if self.model.control is not None:
            p = np.concatenate([p, self.model.control.coefficients()])
        table = self.model.surface.skin_table
        return p if table is None else (p, table)

    def initial_state(self, rotation: bool, energy: bool) -> NDArray[np.float64]:
        """Initial state vector for the given specialisation (identity orientation, zero sums),
        laid out by creatio.dynamics.layout (docs/model.md s.4.7)."""
        R, alpha = self.start_point
        y = np.zeros(state_size(rotation, energy, self.structure_free))
        y[Y_R] = R
        y[Y_ALPHA] = alpha
        y[Y_RDOT] = self.start.Rdot
        y[Y_ALPHADOT] = self.start.alphadot
        if rotation:
            y[Y_OMEGA:Y_OMEGA + 3] = self.start.omega
            y[Y_Q] = 1.0
        if self.model.control is not None:
            # the control block: the law's phase at t = 0, at rest
            y = np.concatenate([y, np.zeros(NCTLS)])
            y[control_start(rotation, energy) + CT_PHI] = self.model.motion.phi_a.scalar(0.0)[0]
        return y


#: The problem's tree: which record sits in which field of which record.
_TREE: dict[type, dict[str, type]] = {
    SphereProblem: {"model": Model, "start": Start, "solver": Solver, "output": Output,
                    "events": Events},
    Model: {"surface": Surface, "motion": Motion, "sphere": Sphere, "structure": Structure},
}


@functools.cache
def field_names(record: type) -> frozenset[str]:
    """Every field name in a record's tree, its own and its sub-records'."""
    names = {f.name for f in fields(record)}
    for sub in _TREE.get(record, {}).values():
        names |= field_names(sub)
    return frozenset(names)


def _replace(record: Any, changes: dict[str, Any]) -> Any:
    """dataclasses.replace over the problem's tree: each change applied in the record that has
    the field, the records above it rebuilt (and validated) on the way up."""
    unknown = set(changes) - field_names(type(record))
    if unknown:
        raise TypeError(f"{type(record).__name__} has no field {', '.join(sorted(unknown))}")
    own = {f.name for f in fields(record)}
    here = {k: v for k, v in changes.items() if k in own}
    for name, sub in _TREE.get(type(record), {}).items():
        below = {k: v for k, v in changes.items() if k not in own and k in field_names(sub)}
        if below and name not in here:
            here[name] = _replace(getattr(record, name), below)
    return dataclasses.replace(record, **here) if here else record


@dataclass(frozen=True)
class Histories:
    """The sampled histories of a run, one row per output time (world frame, SI units; a
    stopped run's last row is its stop). The structure's (docs/model.md s.9-10) are NaN off
    the structure path, where world_azimuth is azimuth; the control's (s.12.2) are NaN off
    the controlled path."""

    t: NDArray[np.float64]
    X: NDArray[np.float64]
    R: NDArray[np.float64]
    alpha: NDArray[np.float64]
    alphadot: NDArray[np.float64]
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
    cell_u: NDArray[np.float64]
    cell_v: NDArray[np.float64]
    # the structure
    theta: NDArray[np.float64]
    theta_rate: NDArray[np.float64]
    hz_structure: NDArray[np.float64]
    hz_orbital: NDArray[np.float64]
    hz_spin: NDArray[np.float64]
    confinement_work: NDArray[np.float64]
    world_azimuth: NDArray[np.float64]
    # the control: the angular phase and its rate
    phi_a: NDArray[np.float64]
    phi_a_rate: NDArray[np.float64]


@dataclass(frozen=True)
class Extrema:
    """Extrema of a run over every integration step, not only the sampled rows (NaN: not
    measured, as the structure's off the structure path and all of them in a run not run)."""

    min_N: float = math.nan
    max_N: float = math.nan
    max_slip_speed: float = math.nan
    max_energy_residual: float = math.nan
    max_cavity_tracking_error: float = math.nan
    min_edge_clearance: float = math.nan
    max_b_kappa: float = math.nan
    # the structure (max_hz_drift and max_structure_momentum on a free structure only)
    max_hz_drift: float = math.nan
    max_structure_momentum: float = math.nan
    max_structure_rate: float = math.nan
    max_contact_radius: float = math.nan


@dataclass(frozen=True)
class Counts:
    """How a run went and what it cost: the method, step and stability limit it ran with,
    which parts of the state it integrated, the start point it took (and why an equilibrium
    start was refused), its status and stop time, its steps, evaluations and the implicit
    methods' linear algebra, and its warnings."""

    method: str
    dt: float
    stability_limit: float
    rotation_integrated: bool
    energy_integrated: bool
    structure_free: bool
    status: str
    stop_time: float
    steps: int
    rhs_evals: int
    rejected_steps: int = 0
    jacobians: int = 0
    lu_factorisations: int = 0
    newton_iterations: int = 0
    warnings: list[str] = field(default_factory=list)
    start_R: float = math.nan
    start_alpha: float = math.nan
    equilibrium_message: str = ""


@dataclass(frozen=True)
class EventLog:
    """What happened at a run's events: when the contact point left its starting cavity's
    cell (NaN: never, docs/model.md s.8.2), and with flight on (s.11) the event table
    (creatio.dynamics.layout EV_* columns), the largest gap reached in flight and whether the
    run ended in flight."""

    left_cavity_time: float = math.nan
    flight: bool = False
    table: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, NEV)))
    max_flight_height: float = math.nan
    ends_in_flight: bool = False


@dataclass(frozen=True)
class SimulationResult:
    """One sphere run's result, split the way a problem is: its sampled :class:`Histories`,
    its all-step :class:`Extrema`, its :class:`Counts` (status, cost, what ran) and its
    :class:`EventLog` (cavity, flight). A study reads the record it needs:
    ``res.histories.R``, ``res.extrema.min_N``, ``res.counts.steps``."""

    histories: Histories
    extrema: Extrema
    counts: Counts
    events: EventLog

    @property
    def carried(self) -> bool:
        """Whether the contact point never left its starting cavity's cell (docs/model.md
        s.8.2) over the steps that ran."""
        return (math.isnan(self.events.left_cavity_time)
                and self.counts.status != "no_equilibrium")


def _start_jets(problem: SphereProblem) -> tuple:
    """The offset jets at the start point and t = 0."""
    model = problem.model
    motion, surface = model.motion, model.surface
    pr, pr1, pr2 = motion.phi_r.scalar(0.0)
    pa, pa1, pa2 = motion.phi_a.scalar(0.0)
    gm, g1, g2 = motion.gamma.scalar(0.0)
    R, alpha = problem.start_point
    if surface.skin_table is not None:
        return offset_jets_skin(R, alpha, surface.R0, model.k, surface.A, model.sphere.b, pr,
                                pr1, pr2, pa, pa1, pa2, gm, g1, g2, surface.skin_table)
    return offset_jets(R, alpha, surface.R0, model.k, surface.A, float(surface.Ka),
                       model.sphere.b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2)


def normal_reaction_at_start(problem: SphereProblem) -> float:
    """N at the initial state (docs/model.md s.4), evaluated with the model's own scalar
    formulas, without a compiler: m n . (a0 - g) with the pull along -z of the problem,
    plus the normal preload (s.10); the structure's reaction term m theta'' n . (z^ x X) of
    s.9 is left out (it vanishes at rest on a fixed structure and is second order in 1/I_s
    otherwise)."""
    _, _, n1, n2, n3, P, Q, Z = _start_jets(problem)
    a0 = contact.acceleration_at_fixed_rates(P, Q, Z, problem.start.Rdot, problem.start.alphadot)
    model = problem.model
    if model.sphere.tilted:
        gx, gy, _ = model.sphere.gravity
        alpha = problem.start_point[1]
        ca, sa = math.cos(alpha), math.sin(alpha)
        return float(contact.normal_reaction_tilted(
            model.sphere.m, gx * ca + gy * sa, gy * ca - gx * sa, model.vertical_pull, n1, n2,
            n3, *a0) + model.structure.preload)
    return float(contact.normal_reaction(model.sphere.m, model.vertical_pull, n1, n2, n3, *a0)
                 + model.structure.preload)


def contact_radius_at_start(problem: SphereProblem) -> float:
    """Horizontal radius rho_c of the contact point at the start (the lever arm of the
    friction's reaction on a free structure, docs/model.md s.6.3 and s.9)."""
    return float(_start_jets(problem)[0][0])


def normal_estimate(problem: SphereProblem) -> float:
    """The a-priori normal reaction of the stability estimate (docs/model.md s.6)."""
    model = problem.model
    return contact.normal_estimate(normal_reaction_at_start(problem), model.sphere.m,
                                   model.pull)


def slip_rate(problem: SphereProblem, N: float, rho: float | None = None) -> float:
    """The slip relaxation rate of this sphere at normal reaction N (1/s); on a free
    structure with the contact at horizontal radius rho (default: the start's), the
    structure's turn adds rho^2 / I_s to the slip mobility (docs/model.md s.6.3)."""
    sp = problem.model.sphere
    inv_Is = inverse_inertia(problem.model.structure.inertia)
    if inv_Is == 0.0:
        return contact.slip_relaxation_rate(sp.mu, N, sp.m, sp.b, sp.eps)
    rho = contact_radius_at_start(problem) if rho is None else rho
    return contact.slip_relaxation_rate(sp.mu, N, sp.m, sp.b, sp.eps, rho, inv_Is)


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
    method = solvers.get(problem.solver.method)
    if problem.model.sphere.mu == 0.0 or problem.adaptive or method.l_stable:
        return math.inf
    return contact.stable_step(method.stability_bound, slip_rate(problem, normal_estimate(problem)))


def check_stable(problem: SphereProblem) -> str:
    """The friction stability rule, in one place (docs/model.md s.6.3): raise
    UnstableStepError when dt exceeds stability_limit(problem), unless the problem allows it;
    returns the message ("" when stable), which a run that allows it records as a warning."""
    limit = stability_limit(problem)
    dt = problem.solver.dt
    if not dt > limit:
        return ""
    sp = problem.model.sphere
    name = problem.solver.method.upper()
    bound = solvers.get(problem.solver.method).stability_bound
    n_est = normal_estimate(problem)
    rate = slip_rate(problem, n_est)
    message = (
        f"beyond the {name} stability limit of the regularised friction (mu = {sp.mu}, "
        f"eps = {sp.eps} m/s, m = {sp.m} kg, b = {sp.b} m): the largest stable dt is "
        f"{limit:.6g} s, dt = {dt} s (slip rate 3.5 mu N / (m eps) = {rate:.4g} 1/s at the "
        f"a-priori N = {n_est:.4g} N; lambda dt = {rate * dt:.3g}, {name} needs <= {bound:.4g})"
    )
    if not problem.solver.allow_unstable:
        raise UnstableStepError(message)
    return message
