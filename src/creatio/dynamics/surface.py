"""The surface under the sphere at one time and contact point, for the compiled right-hand sides.

Everything the right-hand sides need that depends on (t, R, alpha) alone: the three time laws
and the offset jets of creatio.model.offset. Split from the rest so that evaluations at the
same (t, R, alpha), such as the Jacobian's velocity columns, compute it once.
"""

from __future__ import annotations

from creatio.dynamics.jit import njit
from creatio.model.laws import law_eval
from creatio.model.offset import offset_jets

__all__ = ["surface"]


@njit(cache=True, inline="always")
def surface(t: float, R: float, a: float, pp: tuple, lc: tuple) -> tuple:
    """(phi_r, phi_a, gamma, rho, z, n_rho, n_alpha, n_z, P, Q, Z) at time t and (R, alpha):
    the law values and the offset jets (creatio.model.offset.offset_jets), in the rotating
    frame; pp and lc as in creatio.dynamics.sphere.rhs."""
    R0, dR, k, A, Ka, m, b, g, mu, eps, inertia = pp
    pr, pr1, pr2 = law_eval(lc[0], lc[1], lc[2], lc[3], lc[4], lc[5], t)
    pa, pa1, pa2 = law_eval(lc[6], lc[7], lc[8], lc[9], lc[10], lc[11], t)
    gm, g1, g2 = law_eval(lc[12], lc[13], lc[14], lc[15], lc[16], lc[17], t)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, R0, k, A, Ka, b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z
