"""The run's Solver record: the first step h0 of an adaptive run, apart from its step dt."""

from __future__ import annotations

import pytest

from creatio.dynamics import Solver, SphereProblem


def test_the_first_step_is_h0_or_else_dt() -> None:
    assert Solver(method="radau5", dt=0.002).first_step == 0.002
    assert Solver(method="radau5", dt=0.002, h0=1e-4).first_step == 1e-4
    assert Solver(method="rk4", dt=0.002).first_step == 0.002


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"method": "rk4", "h0": 1e-3}, "h0 is the first step of an adaptive run; rk4 at a fixed "
                                    "step takes dt = 0.002 every step, got h0 = 0.001"),
    ({"method": "radau5", "fixed_step": True, "h0": 1e-3}, "radau5 at a fixed step"),
    ({"method": "radau5", "h0": 0.0}, "h0 must be finite and > 0, got 0.0"),
    ({"method": "dopri5", "h0": float("nan")}, "h0 must be finite and > 0, got nan"),
])
def test_h0_is_refused_for_a_fixed_step_and_when_not_positive(kwargs: dict,
                                                               words: str) -> None:
    with pytest.raises(ValueError) as err:
        Solver(dt=0.002, **kwargs)
    assert words in str(err.value)


def test_a_null_h0_follows_dt_through_replace(en02_problem: SphereProblem) -> None:
    """The convergence partner built by replace(dt=...) starts at its own dt unless h0 is
    set, then at h0."""
    adaptive = en02_problem.replace(method="radau5")
    assert adaptive.replace(dt=0.001).solver.first_step == 0.001
    assert adaptive.replace(h0=1e-4).replace(dt=0.001).solver.first_step == 1e-4
