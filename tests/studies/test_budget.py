"""Accuracy budgets (creatio.studies.budget) on toy 'solvers' whose numerical error is known
exactly: a run at rtol returns the truth plus rtol x c per point, so its error against a run
100x tighter is rtol x c x (1 - 1/100)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.studies import budget as bd
from creatio.studies.budget import Rung, Verification

N = 64
TRUTH = np.sin(np.linspace(0.0, 6.0, N)) + 2.0          # std about 0.7


def toy(c: np.ndarray, calls: list | None = None) -> bd.Runner:
    """A 'solver' for outputs y (error rtol x c) and k (constant, exact)."""
    def run(rung: Rung, idx: np.ndarray) -> dict[str, np.ndarray]:
        if calls is not None:
            calls.append((rung, np.asarray(idx).size))
        return {"y": TRUTH[idx] + rung.rtol * c[idx], "k": np.full(np.asarray(idx).size, 3.0)}
    return run


def test_rung_overrides_changes_tighter_and_label() -> None:
    r = Rung("radau5", 1e-6, 1e-8)
    assert r.overrides() == ["solver=radau5", "solver.rtol=1e-06", "solver.atol=1e-08"]
    assert r.changes() == {"solver.method": "radau5", "solver.rtol": 1e-6, "solver.atol": 1e-8}
    assert r.tighter() == Rung("radau5", 1e-8, 1e-10)
    assert r.tighter(10.0) == Rung("radau5", 1e-7, 1e-9)
    assert r.label() == "radau5 rtol=1e-06 atol=1e-08"


def test_ladder_runs_loosest_first_to_the_reference() -> None:
    rungs = bd.ladder(Rung("radau5", 1e-8, 1e-10), 1e-4)
    assert [r.rtol for r in rungs] == [1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
    assert [r.atol for r in rungs] == [1e-6, 1e-7, 1e-8, 1e-9, 1e-10]
    assert bd.ladder(Rung("dop853", 1e-8, 1e-10), 1e-8) == [Rung("dop853", 1e-8, 1e-10)]


def test_budgets_and_subsample() -> None:
    b = bd.sobol_budget({"y": TRUTH, "k": np.full(N, 3.0)})
    assert b["y"] == pytest.approx(1e-3 * np.std(TRUTH), rel=1e-12)
    assert b["k"] == 0.0
    assert bd.noise_budget(0.5) == pytest.approx(5e-3)
    assert bd.resolution_budget(2e-3) == pytest.approx(2e-5)
    idx = bd.subsample(100, 16, seed=3)
    assert idx.size == 16 and np.all(np.diff(idx) > 0) and idx.max() < 100
    assert np.array_equal(idx, bd.subsample(100, 16, seed=3))
    assert not np.array_equal(idx, bd.subsample(100, 16, seed=4))
    assert np.array_equal(bd.subsample(10, 16, seed=3), np.arange(10))


def test_choose_takes_the_loosest_rung_within_the_safety_factor() -> None:
    c = np.ones(N)
    rungs = bd.ladder(Rung("radau5", 1e-8, 1e-10), 1e-2)
    pilot = bd.subsample(N, 16, 0)
    chosen = bd.choose(toy(c), rungs, pilot, bd.sobol_budget)
    # independently: error rtol (1 - 1e-8 / 100 / rtol) <= 0.5e-3 std(truth on the pilot)
    limit = bd.SAFETY * 1e-3 * np.std(TRUTH[pilot])
    ok = [r.rtol for r in rungs if r.rtol - 1e-10 <= limit]
    assert chosen.rtol == max(ok)
    assert chosen.rtol == 1e-4          # std about 0.7: 1e-4 <= 3.5e-4 < 1e-3


def test_verify_measures_the_error_on_the_subsample() -> None:
    c = np.linspace(1.0, 2.0, N)
    rung = Rung("radau5", 1e-5, 1e-7)
    rows = toy(c)(rung, np.arange(N))
    budget = bd.sobol_budget(rows)
    v = bd.verify(toy(c), rows, rung, budget, seed=7)
    idx = bd.subsample(N, 16, 7)
    assert v.points == 16 and v.reference == Rung("radau5", 1e-7, 1e-9)
    assert v.observed["y"] == pytest.approx((1e-5 - 1e-7) * c[idx].max(), rel=1e-6)
    assert v.observed["k"] == 0.0 and v.checked == ["y"]
    assert v.ok == (v.observed["y"] <= budget["y"])


def test_a_loose_rung_that_breaks_the_budget_is_detected_and_tightened() -> None:
    # the pilot's points err by rtol, every other point 50x more: the pilot chooses a rung
    # the full sample breaks, the verification subsample (another seed) sees it.
    pilot = bd.subsample(N, 16, 11)
    c = np.full(N, 50.0)
    c[pilot] = 1.0
    calls: list = []
    rungs = bd.ladder(Rung("radau5", 1e-8, 1e-10), 1e-2)
    rows, v = bd.budgeted(toy(c, calls), N, rungs, bd.sobol_budget, seed=11)
    assert calls[0][0] == Rung("radau5", 1e-10, 1e-12)   # the pilot's reference
    assert v.tightened >= 1 and v.ok
    budget = 1e-3 * np.std(rows["y"])
    assert v.budget["y"] == pytest.approx(budget, rel=1e-12)
    # the pilot chose 1e-4 (as above); 50 x 1e-4 breaks 7e-4, 50 x 1e-5 does not
    assert v.rung == Rung("radau5", 1e-5, 1e-7) and v.tightened == 1
    assert v.observed["y"] <= budget
    assert v.observed["y"] == pytest.approx(50 * (1e-5 - 1e-7), rel=1e-6)
    np.testing.assert_allclose(rows["y"], TRUTH + 1e-5 * c, rtol=0, atol=1e-15)
    assert "tightened 1 time(s)" in v.describe()


def test_a_budget_still_broken_after_max_tighten_is_reported() -> None:
    c = np.full(N, 1e6)
    rows, v = bd.budgeted(toy(c), N, [Rung("rk", 1e-2, 1e-4)], bd.sobol_budget, seed=0,
                          max_tighten=2)
    assert v.tightened == 2 and not v.ok and v.rung == Rung("rk", 1e-4, 1e-6)
    assert "BUDGET BROKEN" in v.describe()


def test_line_text_and_attrs_round_trip() -> None:
    v = Verification(budget={"a": 2e-5, "b": 1e-3, "k": 0.0},
                     observed={"a": 3.1e-7, "b": 5e-4, "k": 0.0}, points=16, seed=5,
                     rung=Rung("radau5", 1e-6, 1e-8), reference=Rung("radau5", 1e-8, 1e-10))
    assert v.worst() == "b"
    assert v.line() == "numerical error <= 0.0005 (budget 0.001, checked on 16 points)"
    assert v.lines() == [
        "a: numerical error <= 3.1e-07 (budget 2e-05, checked on 16 points)",
        "b: numerical error <= 0.0005 (budget 0.001, checked on 16 points)",
        "k: constant over the sample, not checked"]
    attrs = v.attrs("acc_")
    assert all(isinstance(x, (str, float, int)) for x in attrs.values())
    assert attrs["acc_rtol"] == 1e-6 and attrs["acc_ok"] == 1
    assert Verification.from_attrs(attrs, "acc_") == v
    with pytest.raises(KeyError, match="accuracy_outputs"):
        Verification.from_attrs(attrs)


def test_errors_treat_a_failed_point_as_infinite() -> None:
    e = bd.errors({"y": np.array([1.0, np.nan])}, {"y": np.array([1.0, 2.0])})
    assert math.isinf(e["y"])
    e = bd.errors({"y": np.array([1.0, np.nan])}, {"y": np.array([1.5, np.nan])})
    assert e["y"] == 0.5


def test_cheapest_takes_the_cheaper_method_within_budget() -> None:
    """Two toy methods: 'slow' (error rtol, a busy loop per call) and 'fast' (error 100 rtol,
    no loop). Within budget the cheaper is fast at its loosest passing rung (100 rtol <=
    3.5e-4: 1e-6); with a budget only slow meets at any rung, slow's loosest (1e-4)."""
    def run(rung: Rung, idx: np.ndarray) -> dict[str, np.ndarray]:
        if rung.method == "slow":
            x = 0.0
            for i in range(200_000):
                x += i * 1e-9
        c = 100.0 if rung.method == "fast" else 1.0
        return {"y": TRUTH[idx] + rung.rtol * c}

    rungs = [*bd.ladder(Rung("fast", 1e-8, 1e-10), 1e-4),
             *bd.ladder(Rung("slow", 1e-8, 1e-10), 1e-4)]
    pilot = bd.subsample(N, 16, 0)
    assert bd.cheapest(run, rungs, pilot, bd.sobol_budget) == Rung("fast", 1e-6, 1e-8)
    # the toy's errors are constant offsets here: an error of c rtol against the reference
    only_slow = [*bd.ladder(Rung("fast", 1e-4, 1e-6), 1e-4),
                 *bd.ladder(Rung("slow", 1e-8, 1e-10), 1e-4)]
    assert bd.cheapest(run, only_slow, pilot, bd.sobol_budget) == Rung("slow", 1e-4, 1e-6)
