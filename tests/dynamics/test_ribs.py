"""The rib surface in the compiled core (docs/model.md s.14.4): the compiled skin and offset
jets equal the NumPy evaluation, and a rib run approaches the ideal run as N grows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import simulate
from creatio.dynamics.jit import njit
from creatio.dynamics.problem import Output, Solver, SphereProblem
from creatio.model import ribs
from creatio.model.laws import Law
from creatio.model.offset import offset_jets_skin, skin_jets
from creatio.model.surface import Motion, Surface, Wave

KA = 6


@njit
def _compiled_skin(a, pa, pa1, pa2, table):  # type: ignore[no-untyped-def]
    return skin_jets(a, pa, pa1, pa2, table)


@njit
def _compiled_offset(R, a, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2, table):  # type: ignore[no-untyped-def]
    return offset_jets_skin(R, a, 0.68, 2.0 * math.pi / 1.72, 0.18, 0.12, pr, pr1, pr2, pa,
                            pa1, pa2, gm, g1, g2, table)


def test_compiled_skin_jets_equal_numpy_with_rib_errors() -> None:
    e, d = ribs.rib_errors(18, 0.01, math.radians(1.0), seed=3)
    table = ribs.Ribs(18, tuple(e), tuple(d)).table(KA)
    rng = np.random.default_rng(4)
    for a, pa, pa1, pa2 in rng.uniform(-20.0, 20.0, (25, 4)):
        jH, jHa = _compiled_skin(a, pa, pa1, pa2, table)
        ref = ribs.skin_jets(table, a, pa, pa1, pa2)
        H, Ha, Ht, Haa, Hat, Htt, Haaa, Haat, Hatt = (float(v) for v in ref)
        want = (H, Ha, Ht, Haa, Hat, Htt, Ha, Haa, Hat, Haaa, Haat, Hatt)
        got = (*jH, *jHa)
        scale = max(abs(v) for v in want)
        assert np.allclose(got, want, rtol=0, atol=1e-12 * scale)


def test_compiled_offset_surface_height_is_the_wave() -> None:
    """z of the offset jets is R sin(gamma) + W cos(gamma): its jet is the wave's W and its
    derivatives (NumPy Wave on the same rib surface) at random points and inclinations."""
    surf = Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=KA, ribs=ribs.Ribs(24))
    rng = np.random.default_rng(5)
    for R, a, pr, pa, gm in rng.uniform(0.0, 1.5, (10, 5)):
        pr1, pr2, pa1, pa2 = rng.normal(size=4)
        law = Motion(phi_r=Law.constant(pr), phi_a=Law.constant(pa), gamma=Law.constant(gm))
        w = Wave(surf, law, a, R, 0.0)
        _, z, *_ = _compiled_offset(R, a, pr, 0.0, 0.0, pa, 0.0, 0.0, gm, 0.0, 0.0,
                                    surf.skin_table)
        cg, sg = math.cos(gm), math.sin(gm)
        want = (R * sg + float(w.W) * cg, sg + float(w.W_R) * cg, float(w.W_a) * cg,
                float(w.W_RR) * cg, float(w.W_Ra) * cg, float(w.W_aa) * cg)
        got = (z[0], z[1], z[2], z[4], z[5], z[7])
        assert np.allclose(got, want, rtol=0, atol=1e-13)


def _rib_problem(en02_problem: SphereProblem, N: int | None) -> SphereProblem:
    surface = en02_problem.model.surface
    return en02_problem.replace(
        surface=Surface(surface.R0, surface.dR, surface.A, surface.Kr, surface.Ka,
                        ribs=None if N is None else ribs.Ribs(N)),
        solver=Solver(method="rk4", dt=0.002), output=Output(t_end=20.0, interval=0.1))


@pytest.mark.long
def test_rib_run_approaches_the_ideal_run(en02_problem: SphereProblem) -> None:
    ideal = simulate(_rib_problem(en02_problem, None)).histories.X
    dev = {}
    for N in (18, 36, 72):
        res = simulate(_rib_problem(en02_problem, N))
        assert res.counts.status == "ok" and res.carried
        # the energy identity holds on the rib surface as on the ideal one
        assert res.extrema.max_energy_residual < 1e-10
        dev[N] = float(np.max(np.abs(res.histories.X - ideal)))
    assert dev[72] < dev[36] < dev[18]
    # the shape error falls 64-fold per doubling; the trajectory at least 8-fold here
    assert dev[72] < dev[36] / 8 and dev[36] < dev[18] / 8
