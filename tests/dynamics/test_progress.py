"""Every run is bounded and says how it goes (creatio.dynamics.progress, the evaluation budget
of the driver and the flight loop): a run that spends solver.max_rhs_evals stops with status
budget_exceeded and one line, having taken exactly the steps the unbounded run takes; a run
whose step size collapses stops with step_size_collapse in seconds and one line naming the
likely cause; a long run prints progress lines to stderr."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from creatio.dynamics import SphereProblem, simulate
from creatio.dynamics import status as st
from creatio.dynamics.simulation import collapse_cause
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve


def _stderr(capfd) -> list[str]:
    """The lines a run wrote to stderr, without the notice of a compile (printed only on a
    cold cache: creatio.dynamics.jit.ensure_compiled)."""
    return [ln for ln in capfd.readouterr().err.strip().splitlines()
            if not ln.startswith("creatio: compiling ")]


def _prefix_equal(short, full) -> None:
    """The stopped run's histories are the unbounded run's, row for row, bit for bit."""
    t = short.histories.t
    assert t.size >= 2 and np.unique(t).size == t.size  # one row per time: no repeated stop row
    n = t.size
    for name in ("t", "X", "V", "omega", "N", "slip_speed"):
        a, b = getattr(short.histories, name), getattr(full.histories, name)[:n]
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
    assert full.counts.status == "ok" and full.counts.rhs_evals > 2 * budget
    assert short.counts.status == "budget_exceeded" and 0.0 < short.counts.stop_time < 3.0
    # the check comes before each step try: at most one try (and the stop row) beyond it
    assert budget <= short.counts.rhs_evals <= budget + beyond
    _prefix_equal(short, full)
    err = _stderr(capfd)
    assert len(err) == 1 and err[0].startswith("creatio: stopped at t = ")
    assert f"budget of {budget:,} right-hand-side evaluations" in err[0]
    assert err[0].removeprefix("creatio: ") in short.counts.warnings


def test_budget_bounds_the_flight_loop(capfd) -> None:
    """The hybrid loop (flight, docs/model.md s.11) has the same budget (set on the problem:
    the config refuses a fixed-step study whose steps alone exceed it)."""
    res = simulate(resolve("en02f").obj.drop_problem().replace(max_rhs_evals=3000))
    assert res.counts.status == "budget_exceeded" and res.events.flight
    t = res.histories.t
    assert 3000 <= res.counts.rhs_evals <= 3000 + 20 and np.unique(t).size == t.size
    assert len(_stderr(capfd)) == 1


def _collapse_line(capfd, res) -> str:
    """The one stderr line of a collapsed run, also among its warnings."""
    (line,) = _stderr(capfd)
    assert line.startswith("creatio: stopped at t = ") and "the step size collapsed" in line
    assert line.removeprefix("creatio: ") in res.counts.warnings
    return line


def test_a_stiff_regularisation_collapses_in_seconds_not_a_budget_later(capfd) -> None:
    """The example of issue 28: sphere.eps = 1e-9 with radau5 makes the friction so stiff
    that its steps (~8e-10 s) would take hours to cross 120 s, and the default budget (5e7
    evaluations) a minute of one core to spend. Steps below t_end / max_rhs_evals = 2.4e-6 s
    for COLLAPSE_TRIES tries in a row stop it first: step_size_collapse after ~1e4
    evaluations, one line naming sphere.eps and its slip relaxation time."""
    cfg = resolve("en02", ["sphere.eps=1e-9", "solver=radau5"]).obj
    res = simulate(cfg.sphere_problem())
    assert res.counts.status == "step_size_collapse"
    # the sustained floor needs that many tries in a row; each costs evaluations
    assert res.counts.steps + res.counts.rejected_steps > st.COLLAPSE_TRIES
    assert res.counts.rhs_evals < 50_000 and res.counts.stop_time < 1e-3
    t = res.histories.t
    assert np.unique(t).size == t.size and t[-1] == res.counts.stop_time
    line = _collapse_line(capfd, res)
    assert "t_end / solver.max_rhs_evals = 2.4e-06 s for 1,000 tries in a row" in line
    assert "likely cause: sphere.eps = 1e-09 m/s" in line
    # the slip relaxation time m eps / (3.5 mu N) at the a-priori N = 1.25 m g
    relax = float(re.search(r"\(3\.5 mu N\) = ([0-9.e+-]+) s", line).group(1))
    assert relax == pytest.approx(1e-9 / (3.5 * 0.15 * 1.25 * 9.81), rel=0.05)


def test_a_long_run_prints_progress_lines(en02_problem: SphereProblem, capfd) -> None:
    """With a progress interval below a clock look's spacing, every look after the first
    prints a line to stderr (file descriptor 2, from compiled code): simulated time against
    the end, steps, evaluations against the budget, the rate."""
    res = simulate(en02_problem.replace(t_end=60.0, progress_interval=1e-9))
    lines = _stderr(capfd)
    # one look every 4096 step tries: 30,000 steps give 7 looks, the first starts the clock
    assert res.counts.status == "ok" and len(lines) == math.ceil(res.counts.steps / 4096) - 1
    first = lines[0]
    assert first.startswith("creatio: t = ") and " of 60 s (" in first
    assert " 4096 steps, " in first and "% of the budget)" in first and "steps/s" in first
    quiet = simulate(en02_problem.replace(t_end=60.0))
    assert quiet.counts.rhs_evals == res.counts.rhs_evals and capfd.readouterr().err == ""


@pytest.mark.parametrize("value", [0, -5])
def test_the_budget_is_validated(value: int) -> None:
    with pytest.raises(ConfigError, match=rf"solver.max_rhs_evals={value}: must be a positive"):
        resolve("en02", [f"solver.max_rhs_evals={value}"])


def test_a_run_failing_at_its_first_step_has_one_row(capfd) -> None:
    """A step that fails at once (radau5 at eps = 1e-30: Newton cannot converge at any step,
    so the step size shrinks below 1e-12 x t_end within a few dozen tries) ends
    step_size_collapse at t = 0, in a few hundred evaluations, with one line naming eps; it
    records its start once, not once as a sample and again as the stop (issue 28 class 8)."""
    cfg = resolve("en02", ["sphere.eps=1e-30", "solver=radau5"]).obj
    res = simulate(cfg.sphere_problem())
    c = res.counts
    assert c.status == "step_size_collapse" and c.stop_time == 0.0 and c.steps == 0
    assert res.counts.rhs_evals < 1000
    assert np.unique(res.histories.t).size == res.histories.t.size == 1
    line = _collapse_line(capfd, res)
    assert line.startswith("creatio: stopped at t = 0 of 120 s after 0 steps: ")
    assert "likely cause: sphere.eps = 1e-30 m/s" in line and "(raise sphere.eps)" in line


def test_the_likely_cause_of_a_collapse_names_eps_only_when_it_is_too_small(
        en02_problem: SphereProblem) -> None:
    """At the default eps = 0.01 m/s the slip relaxation time (~1.6e-3 s) is far above the
    sustained floor (2.4e-6 s): the cause named is not eps; without friction neither."""
    cause = collapse_cause(en02_problem)
    assert "not sphere.eps" in cause and "= 0.0016 s" in cause
    assert "mu = 0" in collapse_cause(en02_problem.replace(mu=0.0))
    tiny = collapse_cause(en02_problem.replace(eps=1e-12))
    assert tiny.startswith("sphere.eps = 1e-12 m/s: ")
