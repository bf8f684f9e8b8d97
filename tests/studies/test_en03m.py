"""EN-03M (docs/model.md s.10): microgravity with a confining force.

The confinement work closes the energy balance for both kinds; the base pull at P = m g on
a fixed structure is EN-02; the search for the smallest carrying force brackets the outcome
(below: contact lost or cavity left; above: carried); the normal preload carries at no
force; the study's dataset and report.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, simulate, stability_limit
from creatio.model.laws import Law
from creatio.pipeline.config import resolve
from creatio.reports.registry import writer
from creatio.studies.en03m import probe, round_up, search
from creatio.studies.schema import Confinement


def _micro(p: SphereProblem, kind: str, P: float, T: float, I_s: float = 10.0
           ) -> SphereProblem:
    return p.replace(g=0.0, inertia=I_s, confinement=kind, force=P,
                     phi_a=Law.quintic(0.0, 12 * math.pi, T), t_end=T)


def test_base_pull_closes_the_energy_balance_like_gravity(en02_problem) -> None:
    """base: F_c has the potential P z_X, so E - E0 = W_surface - D_friction, to rounding."""
    res = simulate(_micro(en02_problem, "base", 0.5, 30.0))
    assert res.counts.status == "ok" and res.carried
    assert np.abs(res.histories.energy - res.histories.energy[0]).max() > 0.1
    assert res.extrema.max_energy_residual < 1e-12  # 5.3e-14 J
    assert np.all(res.histories.confinement_work == 0.0)  # no preload: no confinement work
    assert res.extrema.max_hz_drift < 1e-13


def test_normal_preload_work_closes_the_energy_balance(en02_problem) -> None:
    """normal: E - E0 = W_surface - D_friction + W_confine, W_confine = integral of
    -P n . c_t; the residual is the scheme's error (4th order), W_confine is O(1 J)."""
    p = _micro(en02_problem, "normal", 5.0, 30.0)
    res = simulate(p)
    h = res.histories
    half = simulate(p.replace(dt=0.001))
    assert res.counts.status == "ok"
    without = h.energy - h.energy[0] - h.surface_work + h.friction_dissipation
    np.testing.assert_allclose(h.energy_residual, without - h.confinement_work, atol=1e-14)
    assert np.abs(h.confinement_work).max() > 1.0
    assert res.extrema.max_energy_residual < 1e-7 and half.extrema.max_energy_residual < 1e-8
    assert res.extrema.max_energy_residual / half.extrema.max_energy_residual > 10.0  # ~2^4
    # the preload's reaction acts on the structure: H_z stays conserved to the same order
    drift, drift_half = res.extrema.max_hz_drift, half.extrema.max_hz_drift
    assert drift < 1e-6 and drift / drift_half > 10.0


def test_base_at_m_g_on_a_fixed_structure_is_en02(en02_problem) -> None:
    en02 = simulate(en02_problem)
    base = simulate(en02_problem.replace(g=0.0, confinement="base", force=9.81))
    assert not base.counts.structure_free  # a fixed structure and a pull along -z: EN-02's path
    for name in ("X", "N", "f", "omega", "energy", "energy_residual"):
        np.testing.assert_array_equal(getattr(base.histories, name),
                                      getattr(en02.histories, name))
    # the same through the structure path (I_s = inf, so 1 / I_s = 0): to rounding
    path = simulate(en02_problem.replace(confinement="normal", force=0.0))
    assert np.abs(path.histories.X - en02.histories.X).max() < 1e-13


def test_the_normal_preload_does_not_carry(en02_problem) -> None:
    """A force along -n has no tangential part: it only adds friction, which pins the sphere
    to membrane points that move along the normal; the cavity passes it at any P."""
    for P in (0.01, 1.0, 100.0):
        p = _micro(en02_problem, "normal", P, 120.0, math.inf).replace(stop_on_leaving_cavity=True)
        limit = stability_limit(p)
        p = p.replace(dt=p.solver.dt / math.ceil(p.solver.dt / limit))
        res = simulate(p)
        assert res.counts.status == "left_cavity" and 20.0 < res.counts.stop_time < 21.0
        assert abs(math.degrees(res.histories.azimuth[-1] - res.histories.azimuth[0])) < 4.0


def test_search_brackets_the_smallest_carrying_force() -> None:
    cfg = resolve("en03m", ["phases.T=30.0", "study.confinements=[base]",
                            "study.inertias=[inf]"]).obj
    probes, lo, hi = search(cfg, Confinement.base, math.inf, 0.002)
    assert 0.0 < lo < hi and hi - lo <= 1e-3 * hi
    assert [q.carried for q in probes if q.force == hi] == [True]
    below = probe(cfg, Confinement.base, math.inf, lo, 0.002)
    above = probe(cfg, Confinement.base, math.inf, round_up(hi), 0.002)
    assert not below.carried and below.status in ("left_cavity", "contact_lost")
    assert above.carried and above.status == "ok"
    # monotone over the scan: nothing below the bracket carries
    assert not any(q.carried for q in probes if q.force <= lo)


def test_force_problem_refines_the_step_to_its_stability_limit() -> None:
    cfg = resolve("en03m").obj
    p = cfg.force_problem(Confinement.normal, 10.0, 981.0)
    dt = p.solver.dt
    assert dt < stability_limit(p) * (1 + 1e-12) and 0.002 / dt == round(0.002 / dt)
    assert cfg.force_problem(Confinement.base, 10.0, 0.05).solver.dt == 0.002


def test_round_up_keeps_three_digits() -> None:
    assert round_up(0.023080809612548745) == 0.0231
    assert round_up(981.0) == 981.0 and round_up(0.99951) == 1.0


def test_en03m_study_dataset_and_report(tmp_path) -> None:
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    cfg = resolve("en03m", ["phases.T=20.0", "study.bisection.decades=[-2,-1]",
                            "study.max_force_factor=1.0", "study.bisection.rtol=0.05"])
    paths = [write_dataset(run_study(cfg, q.name), tmp_path / f"{q.name}.nc")
             for q in cfg.entry.parts(cfg.obj)]
    files = writer(cfg.entry.id)(paths, tmp_path)
    report = json.loads(files["json"].read_text())
    for key in ("status", "timestep_difference_m", "energy_residual_J"):
        assert key in report
    for kind in ("normal", "base"):
        for key in ("min_confining_force_N", "carried_angle_deg", "structure_rotation_deg",
                    "confinement_work_J"):
            assert key in report[kind]
        assert set(report[kind]["by_structure_inertia"]) == {"10", "inf"}
    assert report["normal"]["min_confining_force_N"] is None  # none up to m g carries
    assert report["normal"]["figure_force_N"] == pytest.approx(9.81)
    assert report["base"]["min_confining_force_N"] > 0.0
    assert report["base"]["by_structure_inertia"]["inf"]["structure_rotation_deg"] == 0.0
