"""The surface under the sphere at one time and contact point, for the compiled right-hand sides.

Everything the right-hand sides need that depends on (t, R, alpha) alone: the three time laws
(:func:`phases`) and the offset jets of creatio.model.offset. Split from the rest so that
evaluations at the same (t, R, alpha), such as the Jacobian's velocity columns, compute it
once, and so that a phase which is not a law of time could enter here alone.
"""

from __future__ import annotations

from creatio.dynamics.jit import inlined
from creatio.dynamics.layout import LAW_A, LAW_GAMMA, LAW_R, P_A, P_B, P_K, P_KA, P_R0
from creatio.model.laws import law_eval
from creatio.model.offset import offset_jets

__all__ = ["phases", "surface", "surface_with_phase"]


@inlined
def phases(t: float, lc: tuple) -> tuple:
    """(phi_r, phi_r', phi_r'', phi_a, phi_a', phi_a'', gamma, gamma', gamma'') at time t, from
    the law coefficient vectors lc (rows LAW_R, LAW_A, LAW_GAMMA of the law matrix)."""
    pr, pr1, pr2 = law_eval(lc[LAW_R], t)
    pa, pa1, pa2 = law_eval(lc[LAW_A], t)
    gm, g1, g2 = law_eval(lc[LAW_GAMMA], t)
    return pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2


@inlined
def surface(t: float, R: float, a: float, pp: tuple, lc: tuple) -> tuple:
    """(phi_r, phi_a, gamma, rho, z, n_rho, n_alpha, n_z, P, Q, Z) at time t and (R, alpha):
    the law values and the offset jets (creatio.model.offset.offset_jets), in the rotating
    frame; pp the parameter tuple (creatio.dynamics.layout P_*), lc the laws."""
    pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2 = phases(t, lc)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_KA], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1,
        g2
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z


@inlined
def surface_with_phase(t: float, R: float, a: float, pp: tuple, lc: tuple, pa: float,
                       pa1: float, pa2: float) -> tuple:
    """:func:`surface` with the angular phase and its two derivatives given (the controlled
    path of docs/model.md s.12.2, where phi_a is a state) instead of read from its law."""
    pr, pr1, pr2 = law_eval(lc[LAW_R], t)
    gm, g1, g2 = law_eval(lc[LAW_GAMMA], t)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_KA], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1,
        g2
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z
