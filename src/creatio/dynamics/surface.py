"""The surface under the sphere at one time and contact point, for the compiled right-hand sides.

Everything the right-hand sides need that depends on (t, R, alpha) alone: the three time laws
(:func:`phases`) and the offset jets of creatio.model.offset. Split from the rest so that
evaluations at the same (t, R, alpha), such as the Jacobian's velocity columns, compute it
once, and so that a phase which is not a law of time could enter here alone.

The surface kind is a compile-time property of the parameter tuple's type: the ideal surface's
tuple holds the NPAR parameters (creatio.dynamics.layout P_*) and compiles exactly the
arithmetic it always did; a rib surface's (docs/model.md s.14.4) holds its spline table
after them (P_SKIN, creatio.model.ribs.skin_table), and only its specialisations compile the
skin's evaluation (:func:`with_skin` appends it, once, outside the loop).
"""

from __future__ import annotations

from numba.core import types
from numba.extending import overload

from creatio.dynamics.jit import INLINED, inlined
from creatio.dynamics.layout import (
    LAW_A,
    LAW_GAMMA,
    LAW_R,
    NPAR,
    P_A,
    P_B,
    P_K,
    P_KA,
    P_R0,
    P_SKIN,
)
from creatio.model.laws import law_eval
from creatio.model.offset import offset_jets, offset_jets_skin

__all__ = ["has_skin", "phases", "surface", "surface_with_phase", "with_skin"]


def has_skin(pp) -> bool:  # type: ignore[no-untyped-def]
    """Whether a parameter tuple's numba type carries a rib skin's table after its NPAR
    parameters (a compile-time property)."""
    return isinstance(pp, types.BaseTuple) and len(pp) > NPAR


@inlined
def phases(t: float, lc: tuple) -> tuple:
    """(phi_r, phi_r', phi_r'', phi_a, phi_a', phi_a'', gamma, gamma', gamma'') at time t, from
    the law coefficient vectors lc (rows LAW_R, LAW_A, LAW_GAMMA of the law matrix)."""
    pr, pr1, pr2 = law_eval(lc[LAW_R], t)
    pa, pa1, pa2 = law_eval(lc[LAW_A], t)
    gm, g1, g2 = law_eval(lc[LAW_GAMMA], t)
    return pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2


def surface(t: float, R: float, a: float, pp: tuple, lc: tuple) -> tuple:
    """(phi_r, phi_a, gamma, rho, z, n_rho, n_alpha, n_z, P, Q, Z) at time t and (R, alpha):
    the law values and the offset jets (creatio.model.offset.offset_jets, or offset_jets_skin
    on a rib surface), in the rotating frame; pp the parameter tuple (creatio.dynamics.layout
    P_*), lc the laws (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


def surface_with_phase(t: float, R: float, a: float, pp: tuple, lc: tuple, pa: float,
                       pa1: float, pa2: float) -> tuple:
    """:func:`surface` with the angular phase and its two derivatives given (the controlled
    path of docs/model.md s.12.2, where phi_a is a state) instead of read from its law
    (compiled code only)."""
    raise NotImplementedError("called only from compiled code")


def _ideal(t, R, a, pp, lc):  # type: ignore[no-untyped-def]
    """:func:`surface` on the ideal surface (the arithmetic it always had)."""
    pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2 = phases(t, lc)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_KA], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1,
        g2
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z


def _ribs(t, R, a, pp, lc):  # type: ignore[no-untyped-def]
    """:func:`surface` on a rib surface: the skin of the table pp[P_SKIN]."""
    pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2 = phases(t, lc)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets_skin(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2,
        pp[P_SKIN]
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z


def _ideal_with_phase(t, R, a, pp, lc, pa, pa1, pa2):  # type: ignore[no-untyped-def]
    """:func:`surface_with_phase` on the ideal surface."""
    pr, pr1, pr2 = law_eval(lc[LAW_R], t)
    gm, g1, g2 = law_eval(lc[LAW_GAMMA], t)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_KA], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1,
        g2
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z


def _ribs_with_phase(t, R, a, pp, lc, pa, pa1, pa2):  # type: ignore[no-untyped-def]
    """:func:`surface_with_phase` on a rib surface."""
    pr, pr1, pr2 = law_eval(lc[LAW_R], t)
    gm, g1, g2 = law_eval(lc[LAW_GAMMA], t)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets_skin(
        R, a, pp[P_R0], pp[P_K], pp[P_A], pp[P_B], pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2,
        pp[P_SKIN]
    )
    return pr, pa, gm, rho, z, n1, n2, n3, P, Q, Z


@overload(surface, jit_options=INLINED)
def _surface(t, R, a, pp, lc):  # type: ignore[no-untyped-def]
    """The ideal surface, or the rib skin where the parameter tuple carries its table."""
    return _ribs if has_skin(pp) else _ideal


@overload(surface_with_phase, jit_options=INLINED)
def _surface_with_phase(t, R, a, pp, lc, pa, pa1, pa2):  # type: ignore[no-untyped-def]
    """The ideal surface, or the rib skin where the parameter tuple carries its table."""
    return _ribs_with_phase if has_skin(pp) else _ideal_with_phase


@inlined
def with_skin(packed: tuple, table) -> tuple:  # type: ignore[no-untyped-def]
    """(pp, lc) of creatio.dynamics.sphere.pack with a rib skin's spline table appended to pp
    (at layout P_SKIN): the parameter tuple of a rib surface's specialisations."""
    pp, lc = packed
    return pp + (table,), lc
