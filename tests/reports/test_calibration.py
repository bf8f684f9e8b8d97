"""The calibration report's model-error line: read back from the dataset's attributes as the
fit recorded them (creatio.studies.budget.Verification), absent for an older dataset."""

from __future__ import annotations

import pytest
import xarray as xr

from creatio.reports import calibration
from creatio.studies.budget import Rung, Verification


def test_the_checked_model_error_reads_back_from_the_dataset():
    v = Verification({"centre": 1e-5}, {"centre": 3.14e-6}, 271, 0,
                     Rung("radau5", 1e-4, 1e-6), Rung("radau5", 1e-6, 1e-8), tightened=1)
    acc = calibration._accuracy(xr.Dataset(attrs=v.attrs()))
    assert acc["line"] == "numerical error <= 3.1e-06 (budget 1e-05, checked on 271 points)"
    assert acc["observed_m"] == pytest.approx(3.14e-6) and acc["budget_m"] == 1e-5
    assert acc["ok"] and acc["tightened"] == 1 and acc["points"] == 271
    assert acc["rung"] == "radau5 rtol=0.0001 atol=1e-06"


def test_a_broken_budget_reads_back_as_broken_and_an_old_dataset_has_no_line():
    v = Verification({"centre": 1e-5}, {"centre": 2e-5}, 16, 3,
                     Rung("radau5", 1e-3, 1e-5), Rung("radau5", 1e-5, 1e-7))
    assert not calibration._accuracy(xr.Dataset(attrs=v.attrs()))["ok"]
    assert calibration._accuracy(xr.Dataset()) == {}
