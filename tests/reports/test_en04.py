"""EN-04's report: the bisection's accuracy budget as the control dataset records it
(creatio.studies.en04_control.StepCheck) and the report reads it back."""

from __future__ import annotations

import pytest
import xarray as xr

from creatio.reports.en04 import _accuracy
from creatio.studies.en04_control import StepCheck


@pytest.mark.parametrize(("observed", "ok"), [(0.0, True), (10.0 / 1024, False)])
def test_boundary_accuracy_survives_the_dataset(tmp_path, observed: float, ok: bool) -> None:
    """The check's attributes written to netCDF and read back give the report's entry: the
    budget 1e-2 of the 0.01 s resolution, the observed error, its verdict and the line."""
    check = StepCheck(0.01, 1e-4, observed, 2, 0.002, 0.0005, True)
    path = tmp_path / "control.nc"
    xr.Dataset(attrs=check.attrs("quintic_accuracy_")).to_netcdf(path)
    with xr.open_dataset(path) as ds:
        entry = _accuracy(ds.attrs, "quintic_accuracy_")
    assert entry is not None
    assert entry["resolution_s"] == 0.01 and entry["budget_s"] == pytest.approx(1e-4)
    assert entry["observed_s"] == observed and entry["ok"] is ok
    assert entry["points"] == 2 and entry["reference_dt_s"] == 0.0005 and entry["tightened"] == 0
    assert entry["line"] == (f"numerical error <= {observed:.2g} s (budget 0.0001 s, checked on "
                             "2 points)")


def test_a_dataset_without_the_check_has_no_entry() -> None:
    """A control dataset written before the budget existed reports None, not an error."""
    assert _accuracy({"open_loop_boundary_T": 6.91}, "quintic_accuracy_") is None
