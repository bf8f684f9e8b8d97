"""The sphere's static equilibrium on the frozen surface (docs/model.md s.8.1).

Gravity (and the ``base`` confinement of s.10, a pull along -z) acts along -z, so the
potential of the centre is proportional to its height X_z, and an equilibrium at rest on the
frozen surface solves J(q, 0)^T g = 0, i.e. grad_q X_z = 0 with q = (R, alpha). The height's
gradient and Hessian are exact: they are entries of the centre's jets
(creatio.model.offset.offset_jets), whose z component is the same in the rotating and the
world frame (Z_R, Z_alpha and Z_RR, Z_Ralpha, Z_alphaalpha). Newton's method on that
gradient, from the cavity bottom, converges quadratically; the solution is accepted only if
it is a minimum of X_z (positive definite Hessian) inside the starting cavity's cell.

Scalar Python like creatio.model.offset: evaluated once per run, without a compiler.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from creatio.model.cavity import cavity_cell_offsets, in_cavity_cell
from creatio.model.offset import offset_jets

__all__ = ["NEWTON_FLOOR", "NEWTON_MAX_ITER", "NEWTON_TOL", "Equilibrium", "equilibrium_limit",
           "height_derivatives", "static_equilibrium"]

#: Newton stops when its next correction is below this, relative to max(1, |q|): the
#: correction is then at rounding level and is not applied (so a start that already
#: solves the equation to rounding, like EN-02's cavity bottom at gamma = 0, is kept as is).
NEWTON_TOL = 2.0**-50
#: Below this relative correction, a correction that no longer halves means the iteration
#: has reached the rounding floor of the gradient (near the limit inclination the Hessian is
#: small, so gradient rounding makes corrections of a few 1e-15): converged, not applied.
NEWTON_FLOOR = 1e-9
#: Newton iterations before the search is declared failed.
NEWTON_MAX_ITER = 50


def height_derivatives(R: float, alpha: float, R0: float, k: float, A: float, Ka: float,
                       b: float, phi_r: float, phi_a: float, gamma: float
                       ) -> tuple[float, float, float, float, float, float]:
    """Height X_z of the centre on the frozen surface (phases and inclination held at their
    values, rates zero), its gradient (X_z,R, X_z,alpha) and Hessian entries (RR, Ralpha,
    alphaalpha): all exact, from the centre's jets."""
    Z = offset_jets(R, alpha, R0, k, A, Ka, b, phi_r, 0.0, 0.0, phi_a, 0.0, 0.0, gamma,
                    0.0, 0.0)[7]
    return Z[0], Z[1], Z[2], Z[4], Z[5], Z[7]


@dataclass(frozen=True)
class Equilibrium:
    """Outcome of the equilibrium search: the point, and why it is or is not accepted."""

    R: float
    alpha: float
    converged: bool
    minimum: bool
    in_cell: bool
    iterations: int
    gradient: tuple[float, float]
    hessian: tuple[float, float, float]

    @property
    def acceptable(self) -> bool:
        """A converged minimum of the height inside the starting cavity's cell."""
        return self.converged and self.minimum and self.in_cell

    @property
    def reason(self) -> str:
        """Empty when acceptable; otherwise what failed, in words."""
        if not self.converged:
            return f"Newton did not converge in {self.iterations} iterations"
        if not self.minimum:
            return "the stationary point is not a minimum of the centre's height"
        if not self.in_cell:
            return "the stationary point lies outside the starting cavity's cell"
        return ""


def static_equilibrium(R0: float, k: float, A: float, Ka: float, b: float, phi_r: float,
                       phi_a: float, gamma: float, n: int, m: int) -> Equilibrium:
    """Newton's method on grad X_z = 0 from the bottom (R_c, alpha_c) of cavity (n, m) of
    the surface frozen at the given phases and inclination (docs/model.md s.8.1).

    A correction below NEWTON_TOL (relative to max(1, |q|)), or below NEWTON_FLOOR and no
    smaller than half the previous one (the rounding floor), ends the iteration without
    being applied. The result records whether the iteration converged, whether the point is a
    minimum (Hessian positive definite) and whether it is inside the cell of cavity (n, m)
    (creatio.model.cavity.cavity_cell_offsets).
    """
    R = (0.5 * math.pi - phi_r + 2.0 * math.pi * n) / k
    alpha = (math.pi - phi_a + 2.0 * math.pi * m) / Ka
    converged = False
    iterations = 0
    previous = math.inf
    _, gR, ga, hRR, hRa, haa = height_derivatives(R, alpha, R0, k, A, Ka, b, phi_r, phi_a,
                                                  gamma)
    while iterations < NEWTON_MAX_ITER:
        iterations += 1
        det = hRR * haa - hRa * hRa
        if det == 0.0 or not math.isfinite(det):
            break
        dR = (haa * gR - hRa * ga) / det
        da = (hRR * ga - hRa * gR) / det
        if not (math.isfinite(dR) and math.isfinite(da)):
            break
        size = max(abs(dR) / max(1.0, abs(R)), abs(da) / max(1.0, abs(alpha)))
        if size <= NEWTON_TOL or (size <= NEWTON_FLOOR and size > 0.5 * previous):
            converged = True
            break
        previous = size
        R -= dR
        alpha -= da
        _, gR, ga, hRR, hRa, haa = height_derivatives(R, alpha, R0, k, A, Ka, b, phi_r,
                                                      phi_a, gamma)
    minimum = hRR > 0.0 and hRR * haa - hRa * hRa > 0.0
    du, dv = cavity_cell_offsets(R, alpha, phi_r, phi_a, k, Ka, n, m)
    return Equilibrium(R, alpha, converged, bool(minimum), bool(in_cavity_cell(du, dv)),
                       iterations, (gR, ga), (hRR, hRa, haa))


def equilibrium_limit(R0: float, k: float, A: float, Ka: float, b: float, phi_r: float,
                      phi_a: float, n: int, m: int, tol: float = 1e-10) -> float:
    """The largest constant inclination (rad, in [0, pi/2]) at which cavity (n, m) of the
    frozen surface holds the sphere in an acceptable equilibrium, by bisection on gamma to
    tol: where the minimum of the height meets the saddle on the cell's edge and both
    vanish. NaN if gamma = 0 has none; pi/2 if the cylinder still has one. Presumes, as the
    bisection must, that the equilibria that exist form one interval starting at 0."""
    def holds(gamma: float) -> bool:
        return static_equilibrium(R0, k, A, Ka, b, phi_r, phi_a, gamma, n, m).acceptable

    lo, hi = 0.0, 0.5 * math.pi
    if not holds(lo):
        return math.nan
    if holds(hi):
        return hi
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if holds(mid):
            lo = mid
        else:
            hi = mid
    return lo
