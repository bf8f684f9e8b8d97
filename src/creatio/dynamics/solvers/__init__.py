"""The integration methods: one record per method, one registry, no compiler at import.

A method is data, as scipy's RungeKutta classes are their constants: a stepper kind
(``explicit`` reads any Butcher tableau; ``radau5`` is the 3-stage Radau IIA collocation;
``rosenbrock`` the linearly implicit RODAS4; ``radau_high_order`` Radau IIA with 5 and 7
stages and the variable-order 5/9/13 method, told apart by their parameters), its order, the
order of its error estimate (None without one), its tableau, its dense output's order and its
real stability interval at a fixed step. The compiled loop that runs them all is
creatio.dynamics.solvers.driver; config validation, the stability estimate, benchmarks and the
stability map read this registry.

Adding an explicit method is a tableau (creatio.dynamics.solvers.tableaus) and one entry of
METHODS below.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from creatio.dynamics.solvers import tableaus as tb
from creatio.model.numerics import real_stability_bound, rk_stability_polynomial

__all__ = ["EXPLICIT", "IMPLICIT", "METHODS", "RADAU", "RADAU_VO", "ROSENBROCK", "STEPPERS",
           "DriverTableau", "Method", "Tableau", "get"]

#: Stepper kinds of the compiled driver, and their names (each a module of this package with
#: the stepper contract: workspace, step, dense).
EXPLICIT = 0
RADAU = 1
ROSENBROCK = 2
RADAU_VO = 3
STEPPERS = {EXPLICIT: "explicit", RADAU: "radau5", ROSENBROCK: "rosenbrock",
            RADAU_VO: "radau_high_order"}
#: The kinds with a Newton iteration (fully implicit: a Newton tolerance applies).
IMPLICIT = (RADAU, RADAU_VO)

#: Error estimators of an explicit tableau: none, one embedded pair (RMS norm), or Hairer's
#: combined 5th/3rd-order estimate of DOP853.
NO_ESTIMATE, EMBEDDED, COMBINED_5_3 = 0, 1, 2


class DriverTableau(NamedTuple):
    """An explicit tableau as the compiled stepper reads it (creatio.dynamics.solvers
    .explicit): A and b as their nonzeros (row st of A is a_idx/a_val[a_ptr[st]:a_ptr[st +
    1]], b in its summation order), the error weights e and e3 over the stages and the
    end-of-step derivative, the estimator kind and order, and the dense output: extra stages
    (c_extra, a_extra) and the polynomial weights dense (stages x degree)."""

    c: NDArray[np.float64]
    a_ptr: NDArray[np.int64]
    a_idx: NDArray[np.int64]
    a_val: NDArray[np.float64]
    b_idx: NDArray[np.int64]
    b_val: NDArray[np.float64]
    b_divisor: float
    e: NDArray[np.float64]
    e3: NDArray[np.float64]
    estimator: int
    error_order: int
    c_extra: NDArray[np.float64]
    a_extra: NDArray[np.float64]
    dense: NDArray[np.float64]


@dataclass(frozen=True)
class Tableau:
    """An explicit Runge-Kutta tableau in the layout the compiled stepper reads.

    y_new = y + (h / b_divisor) sum_q b[q] k_q, summed in b_order (the order fixes the
    rounding); e (and e3 for the combined estimate) weigh the stages plus the end-of-step
    derivative, as in scipy's RungeKutta.E. Dense output: y(t + x h) = y + h sum_q K_q
    sum_k dense[q, k] x^(k + 1) over the stages, the end-of-step derivative and the stages
    c_extra / a_extra computed only for it (a_extra's rows weigh every earlier stage), or
    dense_nested, the weights of Hairer's nested form (tableaus.nested_dense_polynomial,
    expanded on first use, not at import); without either, the step's cubic Hermite.
    """

    c: NDArray[np.float64]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    b_divisor: float = 1.0
    b_order: tuple[int, ...] | None = None
    e: NDArray[np.float64] | None = None
    e3: NDArray[np.float64] | None = None
    estimator: int = NO_ESTIMATE
    dense: NDArray[np.float64] | None = None
    dense_nested: NDArray[np.float64] | None = None
    c_extra: NDArray[np.float64] | None = None
    a_extra: NDArray[np.float64] | None = None

    @property
    def stages(self) -> int:
        """Number of stages s (the end-of-step derivative is not counted)."""
        return int(np.asarray(self.b).size)

    def arrays(self) -> tuple[NDArray, ...]:
        """The compiled stepper's layout: (c, a_ptr, a_idx, a_val, b_idx, b_val, e, e3).

        A and b as their nonzeros (row st of A is a_idx/a_val[a_ptr[st]:a_ptr[st + 1]], in
        column order; b in b_order), e and e3 padded to s + 1 (zeros when absent).
        """
        s = self.stages
        a = np.asarray(self.a, float)
        a_ptr, a_idx, a_val = [0], [], []
        for st in range(s):
            for q in range(min(st, a.shape[1])):
                if a[st, q] != 0.0:
                    a_idx.append(q)
                    a_val.append(a[st, q])
            a_ptr.append(len(a_idx))
        b = np.asarray(self.b, float)
        order = self.b_order if self.b_order is not None else range(s)
        b_idx = [q for q in order if b[q] != 0.0]
        e = np.zeros(s + 1)
        e3 = np.zeros(s + 1)
        if self.e is not None:
            e[:] = self.e
        if self.e3 is not None:
            e3[:] = self.e3
        return (np.ascontiguousarray(self.c, dtype=float), np.array(a_ptr, dtype=np.int64),
                np.array(a_idx, dtype=np.int64), np.array(a_val, dtype=float),
                np.array(b_idx, dtype=np.int64), b[b_idx].copy(), e, e3)

    def dense_arrays(self) -> tuple[NDArray, NDArray, NDArray]:
        """(c_extra, a_extra, dense) of the compiled dense output: a_extra as a dense
        (extra, s + 1 + extra) matrix, dense as (s + 1 + extra, degree)."""
        s = self.stages
        if self.dense_nested is not None:
            dense = tb.nested_dense_polynomial(self.weights(), self.dense_nested)
        elif self.dense is not None:
            dense = np.ascontiguousarray(self.dense, float)
        else:
            dense = tb.hermite_dense_polynomial(self.weights())
        if self.c_extra is None or self.a_extra is None:
            return np.zeros(0), np.zeros((0, s + 1)), dense
        return (np.ascontiguousarray(self.c_extra, float),
                np.ascontiguousarray(self.a_extra, float), dense)

    @property
    def dense_order(self) -> int:
        """Order of the dense output (the interpolant's degree): 3 for the Hermite cubic."""
        if self.dense_nested is not None:
            return int(np.asarray(self.dense_nested).shape[0]) + 3
        return 3 if self.dense is None else int(np.asarray(self.dense).shape[1])

    def weights(self) -> NDArray[np.float64]:
        """The weights b / b_divisor of the stability function."""
        return np.asarray(self.b, float) / self.b_divisor


@dataclass(frozen=True)
class Method:
    """One integration method of the driver."""

    name: str
    stepper: int
    order: int
    error_order: int | None
    description: str
    tableau: Tableau | None = None
    #: order of the dense output between steps (interpolant's degree; Radau IIA 5: its
    #: collocation cubic; radau9, radau13, radau: the collocation polynomial of s stages
    #: corrected by its defect, degree s + 1, at their fewest stages); None: the tableau's
    dense_order_override: int | None = field(default=None, repr=False)
    exact_stability_bound: float | None = field(default=None, repr=False)
    #: the stepper's parameters when its kind runs several methods (radau_high_order's PRM_*:
    #: stage range, first stage count, Jacobian reuse threshold); passed as the stand-in
    #: tableau's c
    params: tuple[float, ...] = field(default=(), repr=False)

    @property
    def adaptive(self) -> bool:
        """Whether the method has an error estimate (so can choose its own step)."""
        return self.error_order is not None

    @property
    def variable_order(self) -> bool:
        """Whether the method changes its order as it runs (radau: 5, 9, 13, its params'
        stage range, PRM_S_MIN and PRM_S_MAX, not one count); its order is the lowest."""
        return len(self.params) >= 2 and self.params[0] != self.params[1]

    @property
    def flight(self) -> bool:
        """Whether flight's event loop runs the method (it steps onto every event with an
        explicit stage scheme: solvers.flight)."""
        return self.stepper == EXPLICIT

    @property
    def l_stable(self) -> bool:
        """Whether stiff modes are damped at any step (no stability limit on dt)."""
        return self.stepper != EXPLICIT

    @property
    def dense_order(self) -> int:
        """Order of the dense output between steps (the interpolant's degree)."""
        if self.dense_order_override is not None:
            return self.dense_order_override
        assert self.tableau is not None
        return self.tableau.dense_order

    @functools.cached_property
    def driver_tableau(self) -> DriverTableau:
        """The tableau argument of the compiled driver (a one-stage stand-in, never read, for
        an implicit method, so every entry point has one signature, its c the method's params)."""
        error_order = int(self.error_order or 0)
        if self.tableau is None:
            one, none = np.zeros(1), np.zeros(1, dtype=np.int64)
            c = np.array(self.params, dtype=float) if self.params else one
            return DriverTableau(c, np.zeros(2, dtype=np.int64), none, one, none, one, 1.0,
                                 np.zeros(2), np.zeros(2), NO_ESTIMATE, error_order, np.zeros(0),
                                 np.zeros((0, 2)), np.zeros((2, 1)))
        c, a_ptr, a_idx, a_val, b_idx, b_val, e, e3 = self.tableau.arrays()
        c_extra, a_extra, dense = self.tableau.dense_arrays()
        return DriverTableau(c, a_ptr, a_idx, a_val, b_idx, b_val, float(self.tableau.b_divisor),
                             e, e3, int(self.tableau.estimator), error_order, c_extra, a_extra,
                             dense)

    @functools.cached_property
    def stability_bound(self) -> float:
        """Length of the negative real axis inside the stability region at a fixed step
        (inf for an L-stable method): RK4 2.7853, dopri5 3.3066, dop853 6.3937."""
        if self.l_stable:
            return math.inf
        if self.exact_stability_bound is not None:
            return self.exact_stability_bound
        assert self.tableau is not None
        return real_stability_bound(
            rk_stability_polynomial(self.tableau.a, self.tableau.weights()))


#: Jacobian reuse threshold of the radau_high_order methods (radau.f's THET): the Jacobian is
#: recomputed after a step whose Newton contraction was worse. Measured on EN-02 and EN-02R
#: (scripts/radau_thet.py): see docs/running.md, "Integrators".
_THET = 1e-3

#: The registry: every method the driver runs, by config name.
METHODS: dict[str, Method] = {
    m.name: m
    for m in (
        Method("rk4", EXPLICIT, 4, None,
               "classical Runge-Kutta 4, fixed step (the notebook's reference scheme)",
               Tableau(tb.RK4_C, tb.RK4_A, tb.RK4_B, tb.RK4_B_DIVISOR, tb.RK4_B_ORDER),
               exact_stability_bound=tb.RK4_REAL_STABILITY),
        Method("dopri5", EXPLICIT, 5, 4, "Dormand-Prince 5(4), adaptive explicit pair",
               Tableau(tb.DP5_C, tb.DP5_A, tb.DP5_B, e=tb.DP5_E, estimator=EMBEDDED,
                       dense=tb.DP5_P)),
        Method("dop853", EXPLICIT, 8, 7,
               "Dormand-Prince 8(5,3), adaptive explicit pair with Hairer's error estimate",
               Tableau(tb.DOP853_C, tb.DOP853_A, tb.DOP853_B, e=tb.DOP853_E5,
                       e3=tb.DOP853_E3, estimator=COMBINED_5_3,
                       dense_nested=tb.DOP853_D, c_extra=tb.DOP853_C_EXTRA,
                       a_extra=tb.DOP853_A_EXTRA)),
        Method("radau5", RADAU, 5, 3,
               "Radau IIA order 5, adaptive, L-stable (simplified Newton, Gustafsson control)",
               dense_order_override=3),
        Method("radau9", RADAU_VO, 9, 5,
               "Radau IIA order 9 (5 stages), adaptive, L-stable (Hairer's RADAU control)",
               dense_order_override=6, params=(5, 5, 5, _THET)),
        Method("radau13", RADAU_VO, 13, 7,
               "Radau IIA order 13 (7 stages), adaptive, L-stable (Hairer's RADAU control)",
               dense_order_override=8, params=(7, 7, 7, _THET)),
        Method("radau", RADAU_VO, 5, 3,
               "Radau IIA of variable order 5, 9, 13 (3, 5, 7 stages) by the Newton "
               "contraction, adaptive, L-stable (Hairer's RADAU)",
               dense_order_override=4, params=(3, 7, 3, _THET)),
        Method("rodas4", ROSENBROCK, 4, 3,
               "Rosenbrock RODAS4, adaptive, L-stable, linearly implicit (Jacobian every step)",
               dense_order_override=3),
    )
}


def get(name: str) -> Method:
    """The method registered under name; ValueError naming the choices otherwise."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {name!r}") from None
