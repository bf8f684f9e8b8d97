"""EN-05's report shows the Sobol' sample's accuracy check beside the indices: the line
"numerical error <= X (budget Y, checked on N points)" from the dataset's attributes, each
output's error beside its budget, the unresolved outputs named and their index rows marked;
a sample without a budget says so."""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from creatio.reports import en05 as report
from creatio.studies.budget import Rung, Verification
from creatio.studies.en05_schema import ACCURACY_PREFIX


def _sobol(attrs: dict) -> xr.Dataset:
    """A Sobol' dataset's attributes on an otherwise empty dataset."""
    return xr.Dataset({"unit_sample": (("point", "input"), np.zeros((2, 1)))}, attrs=attrs)


def test_the_check_is_read_back_with_its_line_and_unresolved_outputs():
    """Budgets and observed errors come back per output; the line names the worst output's
    error relative to its budget (2.9e-8 of 3.8e-8 beats 1e-9 of 1e-6)."""
    check = Verification(budget={"surface_work": 3.8e-8, "max_abs_lag": 1e-6, "carried": 0.0},
                         observed={"surface_work": 2.9e-8, "max_abs_lag": 1e-9, "carried": 0.0},
                         points=16, seed=6, rung=Rung("radau5", 1e-6, 1e-8),
                         reference=Rung("radau5", 1e-8, 1e-10))
    noise = {"final_radius": {"why": "numerically constant", "observed": 1e-10,
                              "budget": 3.3e-13}}
    attrs = {**check.attrs(ACCURACY_PREFIX), f"{ACCURACY_PREFIX}fraction": 1e-3,
             f"{ACCURACY_PREFIX}unresolved": json.dumps(noise)}
    acc = report.accuracy_summary(_sobol(attrs))
    assert acc["line"] == "numerical error <= 2.9e-08 (budget 3.8e-08, checked on 16 points)"
    assert acc["worst_output"] == "surface_work" and acc["ok"] and acc["tightened"] == 0
    assert acc["rung"] == {"method": "radau5", "rtol": 1e-6, "atol": 1e-8}
    assert acc["reference"]["rtol"] == 1e-8
    assert acc["outputs"]["carried"]["checked"] is False
    assert acc["outputs"]["max_abs_lag"] == {"budget": 1e-6, "observed": 1e-9, "checked": True}
    assert acc["unresolved"] == noise
    text = "\n".join(report._accuracy_lines(acc))
    assert acc["line"] in text and "rtol 1e-06" in text and "not resolved" in text
    assert "final_radius" in text and "broken" not in text


def test_a_broken_or_absent_budget_is_said():
    """An observed error beyond its budget makes the section say the budget is broken; a
    dataset without the check says the sample ran without a budget."""
    check = Verification(budget={"a": 1e-6}, observed={"a": 2e-6}, points=16, seed=1,
                         rung=Rung("radau5", 1e-8, 1e-10), reference=Rung("radau5", 1e-10,
                                                                          1e-12), tightened=3)
    acc = report.accuracy_summary(_sobol(check.attrs(ACCURACY_PREFIX)))
    assert acc["ok"] is False and acc["tightened"] == 3 and acc["unresolved"] == {}
    text = "\n".join(report._accuracy_lines(acc))
    assert "the budget is broken" in text and "tightened 3 time(s)" in text
    assert report.accuracy_summary(_sobol({})) is None
    assert "No accuracy budget" in "\n".join(report._accuracy_lines(None))
