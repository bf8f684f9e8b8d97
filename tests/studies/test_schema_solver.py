"""SolverConfig's convergence pair: one Rung per run (name, step, first step, tolerances),
solver.h0 and its refusals, and config hashes kept while h0 is null."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from creatio.errors import ConfigError
from creatio.pipeline.config import resolve
from creatio.studies import registry
from creatio.studies.schema import Method, Rung, SolverConfig


def test_rk4_rungs_are_the_step_and_its_half() -> None:
    """A fixed step: step dt, then dt / 2; no first step; tolerances scaled by 2**4."""
    assert SolverConfig().rungs() == [
        Rung(dt=0.002, label="dt0.002", step=0.002, h0=None, rtol=1e-8, atol=1e-10),
        Rung(dt=0.001, label="dt0.001", step=0.001, h0=None, rtol=1e-8 / 16, atol=1e-10 / 16),
    ]


@pytest.mark.parametrize(("method", "order"), [
    (Method.radau5, 5), (Method.dop853, 8), (Method.rodas4, 4), (Method.radau13, 13)])
def test_adaptive_rungs_start_at_their_dt_and_tighten_by_refine_to_the_order(
        method: Method, order: int) -> None:
    """h0 null: the first step is each run's dt (as before h0); the partner runs at rtol,
    atol / 2**order; no fixed step."""
    first, partner = SolverConfig(method=method).rungs()
    assert (first.label, first.dt, first.step, first.h0) == ("dt0.002", 0.002, None, 0.002)
    assert (first.rtol, first.atol) == (1e-8, 1e-10)
    assert (partner.label, partner.dt, partner.step, partner.h0) == ("dt0.001", 0.001, None,
                                                                     0.001)
    assert partner.rtol == pytest.approx(1e-8 / 2**order, rel=1e-15)
    assert partner.atol == pytest.approx(1e-10 / 2**order, rel=1e-15)


def test_h0_is_the_first_step_of_both_runs_and_changes_nothing_else() -> None:
    plain = SolverConfig(method=Method.radau5).rungs()
    with_h0 = SolverConfig(method=Method.radau5, h0=1e-4).rungs()
    assert [r.h0 for r in with_h0] == [1e-4, 1e-4]
    assert [(r.label, r.dt, r.step, r.rtol, r.atol) for r in with_h0] == [
        (r.label, r.dt, r.step, r.rtol, r.atol) for r in plain]


def test_an_adaptive_method_at_a_fixed_step_steps_dt_and_keeps_its_newton_tolerance() -> None:
    first, partner = SolverConfig(method=Method.radau5, fixed_step=True).rungs()
    assert (first.step, first.h0, partner.step, partner.h0) == (0.002, None, 0.001, None)
    assert partner.rtol == pytest.approx(1e-8 / 32, rel=1e-15)


def test_a_refine_of_three_names_the_partner_by_its_repr() -> None:
    """dt = 0.001, refine = 3 (dopri5, order 5): the partner is named dt / 3 as Python
    prints it, and runs at rtol / 3**5."""
    _, partner = SolverConfig(method=Method.dopri5, dt=0.001, refine=3).rungs()
    assert partner.label == "dt0.0003333333333333333" and partner.dt == 0.001 / 3
    assert partner.rtol == pytest.approx(1e-8 / 243, rel=1e-15)


def test_the_datasets_are_named_by_the_rungs() -> None:
    r = resolve("en03", ["solver=radau5", "solver.h0=1e-4"])
    names = [p.name for p in registry.get("en03").parts(r.obj)]
    assert names == ["en03_dt0.002", "en03_dt0.001", "en03_inertia_dt0.002",
                     "en03_inertia_dt0.001"]


def test_the_problem_of_each_rung_carries_its_fields() -> None:
    cfg = resolve("en02", ["solver=radau5", "solver.h0=1e-4"]).obj
    for rung in cfg.solver.rungs():
        sv = cfg.sphere_problem(rung.dt).solver
        assert (sv.dt, sv.h0, sv.first_step, sv.rtol, sv.atol) == (
            rung.dt, 1e-4, 1e-4, rung.rtol, rung.atol)
    plain = resolve("en02", ["solver=radau5"]).obj
    partner = plain.sphere_problem(plain.solver.rungs()[1].dt).solver
    assert (partner.h0, partner.first_step) == (None, 0.001)


def test_a_configured_h0_is_the_first_step_each_run_takes() -> None:
    """EN-02 with radau5, h0 = 1 ms and a budget of 2 evaluations (the start's and the first
    try's): both runs of the pair stop after one step, at t = h0; without h0 at their dt."""
    from creatio.dynamics import simulate

    for h0, firsts in (("1e-3", [1e-3, 1e-3]), ("null", [0.002, 0.001])):
        cfg = resolve("en02", ["solver=radau5", f"solver.h0={h0}",
                               "solver.max_rhs_evals=2"]).obj
        runs = [simulate(cfg.sphere_problem(r.dt)).counts for r in cfg.solver.rungs()]
        assert [(c.status, c.steps, c.rejected_steps) for c in runs] == [
            ("budget_exceeded", 1, 0)] * 2
        assert [c.stop_time for c in runs] == pytest.approx(firsts, rel=1e-15)


@pytest.mark.parametrize(("study", "overrides", "sha"), [
    ("en02", [], "e6889b3a2120"),
    ("en02", ["solver.h0=null"], "e6889b3a2120"),
    ("en02", ["solver=radau5"], "73c0a0e47855"),
    ("en03", [], "34464b359b04"),
])
def test_a_null_h0_keeps_every_config_hash(study: str, overrides: list[str], sha: str) -> None:
    """The hashes these configs had before solver.h0 existed: a null h0 is left out."""
    res = resolve(study, overrides)
    assert res.sha256.startswith(sha) and "h0" not in res.yaml


def test_a_set_h0_is_part_of_the_config() -> None:
    res = resolve("en02", ["solver=radau5", "solver.h0=1e-4"])
    assert "  h0: 0.0001\n" in res.yaml
    assert not res.sha256.startswith("73c0a0e47855")


@pytest.mark.parametrize(("overrides", "words"), [
    (["solver.h0=0.001"], "solver.h0=0.001: applies to adaptive methods only: rk4 takes the "
                          "constant step solver.dt; leave h0 null"),
    (["solver=radau5", "solver.fixed_step=true", "solver.h0=0.001"],
     "solver.h0=0.001: applies to adaptive methods only: solver.fixed_step=true makes every "
     "step solver.dt"),
    (["solver=radau5", "solver.h0=0"], "solver.h0=0.0: must be finite and > 0 s"),
    (["solver=radau5", "solver.h0=-1e-3"], "solver.h0=-0.001: must be finite and > 0 s"),
    (["solver=radau5", "solver.h0=nan"], "solver.h0=nan: must be a finite number"),
    (["solver=radau5", "solver.h0=inf"], "solver.h0=inf: must be a finite number"),
])
def test_a_bad_h0_is_refused_in_one_line(overrides: list[str], words: str) -> None:
    with pytest.raises(ConfigError) as err:
        resolve("en02", overrides)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_the_cli_refuses_h0_for_rk4_in_one_line_and_writes_nothing(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en02",
                           "solver.h0=0.001"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "solver.h0=0.001: applies to adaptive methods only: rk4" in lines[0]
    assert list(tmp_path.iterdir()) == []
