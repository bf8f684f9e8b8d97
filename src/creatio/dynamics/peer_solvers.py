"""The peers a user would reach for: scipy.integrate solvers and SUNDIALS CVODE (BDF).

(The benchmark uses DOP853, Radau and LSODA; RK45 is here for the harness test against the
native dopri5, which runs the same pair and controller.) CVODE runs through scikit-sundae,
a benchmark-only dependency (the ``bench`` extra): its variable-order BDF with the dense
linear solver and CVODE's own difference-quotient Jacobian, the output grid handed to
``solve`` so CVODE's dense output (CVodeGetDky) gives the grid states; scikit-sundae takes
a Python callable only (no compiled function pointer), so it gets the same compiled
derivative behind a thin in-place wrapper. Differences from the native
methods worth knowing when reading timings: native steps never cross the 0.1 s output
grid (scipy interpolates with its dense output), and native radau5 differences only the 7
Jacobian columns the dynamics depend on, where scipy differences all of them.

The right-hand side handed to scipy is `fun(t, y) -> ndarray`, one call of the same compiled
derivative the native loops use (sphere.derivative), so a comparison measures the solvers,
not two implementations of the model. The solver is stepped exactly as solve_ivp does with
t_eval (its dense output evaluated at the grid times each step passes), so the result is
what `solve_ivp(fun, (0, t_end), y0, method, t_eval=grid, rtol, atol)` returns, plus the
number of accepted steps, which solve_ivp does not report.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import DOP853, LSODA, RK45, Radau

from creatio.dynamics import sphere
from creatio.dynamics.problem import SphereProblem

__all__ = ["PEERS", "SUNDIALS", "PeerResult", "available", "centre_grid", "peer_rhs",
           "solve_peer"]

#: scipy solver classes by the name solve_ivp gives them.
PEERS: dict[str, Any] = {"RK45": RK45, "DOP853": DOP853, "Radau": Radau, "LSODA": LSODA}

#: SUNDIALS peers (scikit-sundae, the ``bench`` extra) by name: the import each needs.
SUNDIALS: dict[str, str] = {"CVODE": "sksundae"}


def available(method: str) -> bool:
    """Whether a peer can run here (scipy always; a SUNDIALS one when its package imports)."""
    import importlib.util

    if method in PEERS:
        return True
    return importlib.util.find_spec(SUNDIALS[method]) is not None


@dataclass(frozen=True)
class PeerResult:
    """States on the output grid and the solver's work counters."""

    t: NDArray[np.float64]
    y: NDArray[np.float64]
    status: str
    time_s: float
    rhs_evals: int
    steps: int
    jacobians: int
    lu_factorisations: int


def peer_rhs(problem: SphereProblem, rotation: bool, energy: bool):
    """fun(t, y) -> dy/dt as a new array: the plain callable scipy is given."""
    p, lawc = problem.parameter_vector(), problem.law_matrix()

    def fun(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        return sphere.derivative(p, lawc, t, y, rotation, energy)

    return fun


def output_grid(problem: SphereProblem) -> NDArray[np.float64]:
    """Output times 0, dt_out, ..., t_end (the native loops' history times)."""
    t_end, interval = problem.output.t_end, problem.output.interval
    n = int(np.floor(t_end / interval * (1 + 1e-12)))
    grid = np.arange(n + 1) * interval
    if grid[-1] < t_end * (1 - 1e-12):
        grid = np.append(grid, t_end)
    return grid


def solve_peer(
    problem: SphereProblem, method: str, rtol: float, atol: float, energy: bool = False
) -> PeerResult:
    """Integrate problem with the peer `method` at rtol/atol; states on the output grid.

    Rotation is integrated when the problem needs it (friction or initial spin); the
    energy accumulators only when asked. time_s covers the solver's construction and its
    stepping loop (scipy), or its construction and solve (CVODE).
    """
    if method in SUNDIALS:
        return _solve_cvode(problem, rtol, atol, energy)
    rot = problem.rotation_integrated
    fun = peer_rhs(problem, rot, energy)
    y0 = problem.initial_state(rot, energy)
    grid = output_grid(problem)
    ys = np.full((grid.size, y0.size), np.nan)
    ys[0] = y0
    t0 = time.perf_counter()
    solver = PEERS[method](fun, 0.0, y0, problem.output.t_end, rtol=rtol, atol=atol)
    steps = 0
    nxt = 1
    status = "ok"
    while solver.status == "running":
        message = solver.step()
        if solver.status == "failed":
            status = f"failed: {message}"
            break
        steps += 1
        hi = np.searchsorted(grid, solver.t, side="right")
        if hi > nxt:
            sol = solver.dense_output()
            ys[nxt:hi] = sol(grid[nxt:hi]).T
            nxt = hi
    elapsed = time.perf_counter() - t0
    return PeerResult(
        t=grid,
        y=ys,
        status=status,
        time_s=elapsed,
        rhs_evals=int(solver.nfev),
        steps=steps,
        jacobians=int(getattr(solver, "njev", 0)),
        lu_factorisations=int(getattr(solver, "nlu", 0)),
    )


def _solve_cvode(problem: SphereProblem, rtol: float, atol: float, energy: bool) -> PeerResult:
    """CVODE BDF (scikit-sundae) with its dense output on the grid; scikit-sundae reports
    neither accepted steps nor LU factorisations (-1 in both)."""
    from sksundae.cvode import CVODE

    rot = problem.rotation_integrated
    fun = peer_rhs(problem, rot, energy)

    def rhsfn(t: float, y: NDArray[np.float64], yp: NDArray[np.float64]) -> None:
        yp[:] = fun(t, y)

    y0 = problem.initial_state(rot, energy)
    grid = output_grid(problem)
    t0 = time.perf_counter()
    solver = CVODE(rhsfn, method="BDF", rtol=rtol, atol=atol, linsolver="dense",
                   max_num_steps=1_000_000)
    res = solver.solve(grid, y0)
    elapsed = time.perf_counter() - t0
    ys = np.full((grid.size, y0.size), np.nan)
    n = min(len(res.t), grid.size)
    ys[:n] = np.asarray(res.y)[:n]
    status = "ok" if res.success and n == grid.size else f"failed: {res.message}"
    return PeerResult(t=grid, y=ys, status=status, time_s=elapsed, rhs_evals=int(res.nfev),
                      steps=-1, jacobians=int(res.njev), lu_factorisations=-1)


def centre_grid(
    problem: SphereProblem, t: NDArray[np.float64], states: NDArray[np.float64], energy: bool
) -> NDArray[np.float64]:
    """Sphere centres (n, 3) of states on times t, by the formula the native loops use."""
    rot = problem.rotation_integrated
    good = np.all(np.isfinite(states), axis=1)
    X = np.full((t.size, 3), np.nan)
    if good.any():
        X[good] = sphere.centre_positions(
            problem.parameter_vector(),
            problem.law_matrix(),
            np.ascontiguousarray(t[good]),
            np.ascontiguousarray(states[good]),
            rot,
            energy,
        )
    return X
