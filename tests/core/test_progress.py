"""Every run is bounded and says how it goes (creatio.dynamics.progress, the evaluation budget
of the driver and the flight loop): a run that spends solver.max_rhs_evals stops with status
budget_exceeded and one line, having taken exactly the steps the unbounded run takes, and a
long run prints progress lines to stderr."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, simulate
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve


def _prefix_equal(short, full) -> None:
    """The stopped run's histories are the unbounded run's, row for row, bit for bit."""
    n = short.t.size
    assert n >= 2 and np.unique(short.t).size == n  # one row per time: no repeated stop row
    for name in ("t", "X", "V", "omega", "N", "slip_speed"):
        a, b = getattr(short, name), getattr(full, name)[:n]
        assert np.array_equal(a[:-1], b[:-1]), name  # the last row is the stop's own state


@pytest.mark.parametrize(("method", "budget", "beyond"), [
    ("rk4", 2000, 40), ("radau5", 400, 40), ("dop853", 1000, 40),
    # a radau9 try: a Jacobian (7), up to 12 Newton iterations of 5 stages, the stop row
    ("radau9", 150, 7 + 12 * 5 + 2)])
def test_budget_stops_a_run_without_changing_its_steps(en02_problem: SphereProblem, capfd,
                                                       method: str, budget: int,
                                                       beyond: int) -> None:
    base = en02_problem.replace(method=method, t_end=3.0, rtol=1e-8, atol=1e-10)
    full = simulate(base)
    short = simulate(base.replace(max_rhs_evals=budget))
    assert full.status == "ok" and full.rhs_evals > 2 * budget
    assert short.status == "budget_exceeded" and 0.0 < short.stop_time < 3.0
    # the check comes before each step try: at most one try (and the stop row) beyond it
    assert budget <= short.rhs_evals <= budget + beyond
    _prefix_equal(short, full)
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("creatio: stopped at t = ")
    assert f"budget of {budget:,} right-hand-side evaluations" in err[0]
    assert err[0].removeprefix("creatio: ") in short.warnings


def test_budget_bounds_the_flight_loop(capfd) -> None:
    """The hybrid loop (flight, docs/model.md s.11) has the same budget."""
    cfg = resolve("en02f", ["solver.max_rhs_evals=3000"]).obj
    res = simulate(cfg.drop_problem())
    assert res.status == "budget_exceeded" and res.flight
    assert 3000 <= res.rhs_evals <= 3000 + 20 and np.unique(res.t).size == res.t.size
    assert capfd.readouterr().err.count("\n") == 1


def test_a_stiff_regularisation_ends_with_its_status_not_hours_later(capfd) -> None:
    """The example of issue 28: sphere.eps = 1e-9 with radau5 makes the friction so stiff
    that the run would take hours; with a budget it ends with budget_exceeded and one line
    (here a budget of 2e5 evaluations; the default, 5e7, stops it in about a minute of one
    core)."""
    cfg = resolve("en02", ["sphere.eps=1e-9", "solver=radau5", "solver.max_rhs_evals=200000"]).obj
    res = simulate(cfg.sphere_problem())
    assert res.status == "budget_exceeded" and res.stop_time < 120.0
    assert res.rhs_evals < 200_000 + 100
    assert "stopped at t = " in capfd.readouterr().err


def test_a_long_run_prints_progress_lines(en02_problem: SphereProblem, capfd) -> None:
    """With a progress interval below a clock look's spacing, every look after the first
    prints a line to stderr (file descriptor 2, from compiled code): simulated time against
    the end, steps, evaluations against the budget, the rate."""
    res = simulate(en02_problem.replace(t_end=60.0, progress_interval=1e-9))
    lines = capfd.readouterr().err.strip().splitlines()
    # one look every 4096 step tries: 30,000 steps give 7 looks, the first starts the clock
    assert res.status == "ok" and len(lines) == math.ceil(res.steps / 4096) - 1
    first = lines[0]
    assert first.startswith("creatio: t = ") and " of 60 s (" in first
    assert " 4096 steps, " in first and "% of the budget)" in first and "steps/s" in first
    quiet = simulate(en02_problem.replace(t_end=60.0))
    assert quiet.rhs_evals == res.rhs_evals and capfd.readouterr().err == ""


@pytest.mark.parametrize("value", [0, -5])
def test_the_budget_is_validated(value: int) -> None:
    with pytest.raises(ConfigError, match=rf"solver.max_rhs_evals={value}: must be a positive"):
        resolve("en02", [f"solver.max_rhs_evals={value}"])


def test_a_run_failing_at_its_first_step_has_one_row() -> None:
    """A step that fails at once (radau5 at eps = 1e-30: Newton cannot converge at any step)
    records its start once, not once as a sample and again as the stop (issue 28 class 8)."""
    cfg = resolve("en02", ["sphere.eps=1e-30", "solver=radau5"]).obj
    res = simulate(cfg.sphere_problem())
    assert res.status in ("step_failed", "budget_exceeded")
    assert np.unique(res.t).size == res.t.size
