"""Datasets as files (creatio.store.netcdf): the NetCDF round trip with provenance, storage,
atomic writes, a clear error for a missing file."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from creatio.pipeline.config import resolve
from creatio.pipeline.run import run_study
from creatio.store.netcdf import read_dataset, write_dataset


@pytest.fixture(scope="module")
def ct02_dataset():
    """A real CT-02 dataset with provenance (computed once)."""
    resolved = resolve("ct02", ["study.inclinations_deg=[0,45,90]"])
    return resolved, run_study(resolved)


def test_round_trip_keeps_values_and_gives_the_config_back(tmp_path, ct02_dataset):
    """What is read back equals what was written, and the config comes back resolved."""
    resolved, ds = ct02_dataset
    path = write_dataset(ds, tmp_path / "sub" / "ct02.nc")
    back, config = read_dataset(path)
    xr.testing.assert_identical(back.drop_attrs(), ds.drop_attrs())
    assert config == resolved.data
    assert back.attrs["config_sha256"] == resolved.sha256
    for key in ("Conventions", "title", "source", "history", "references", "creatio_version",
                "git_commit", "git_dirty", "date_created", "version_numpy", "version_scipy",
                "version_xarray", "version_netCDF4"):
        assert key in back.attrs, key
    assert back.attrs["Conventions"].startswith("CF-")
    assert "CT02" in back.attrs["references"]
    assert back.encoding["source"].endswith("ct02.nc")
    assert back["fd_error"].encoding.get("contiguous") is True  # small: stored plainly


def test_large_variables_are_compressed(tmp_path):
    """Variables above the small-size threshold are written with zlib."""
    ds = xr.Dataset({"big": ("n", np.zeros(10_000)), "small": ("m", np.arange(3.0))})
    back, _ = read_dataset(write_dataset(ds, tmp_path / "c.nc"))
    assert back["big"].encoding.get("zlib") is True
    assert back["small"].encoding.get("contiguous") is True
    assert (tmp_path / "c.nc").stat().st_size < 10_000 * 8 / 4  # zeros: far below raw


def test_an_empty_table_is_written_and_read_back(tmp_path):
    """A zero-length dimension (EN-02F's event table of a run without events) is stored: HDF5
    refused it as contiguous ("NetCDF: Invalid argument"), found by a fuzz of the configs."""
    ds = xr.Dataset({"event_time": ("event", np.empty(0), {"units": "s"}),
                     "event_case": ("event", np.empty(0, np.int32)),
                     "small": ("m", np.arange(3.0))})
    back, _ = read_dataset(write_dataset(ds, tmp_path / "e.nc"))
    assert back.sizes["event"] == 0 and back["event_case"].dtype == np.int32
    assert back["small"].encoding.get("contiguous") is True


def test_write_is_atomic_and_leaves_no_partial_file(tmp_path, ct02_dataset):
    """A failing write leaves neither a temp file nor a clobbered destination."""
    _, ds = ct02_dataset
    target = tmp_path / "ct02.nc"
    write_dataset(ds, target)
    before = target.read_bytes()
    bad = ds.assign(broken=("h", np.array([object()] * ds.sizes["h"])))
    with pytest.raises(Exception):  # noqa: B017 - any serialisation error will do
        write_dataset(bad, target)
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ct02.nc"]


def test_read_missing_file_is_a_clear_error(tmp_path):
    """Reading a dataset that does not exist names the path."""
    with pytest.raises(FileNotFoundError, match="no dataset here"):
        read_dataset(tmp_path / "nope.nc")


def test_a_dataset_read_again_is_an_equal_copy_and_a_rewrite_is_read_anew(tmp_path,
                                                                          ct02_dataset):
    """The same file read again gives an identical dataset and config that the caller may
    change without changing the next read's; the file written again (atomically: a new
    file) is read with its new values."""
    ds = ct02_dataset[1]
    path = write_dataset(ds, tmp_path / "ct02.nc")
    first, config = read_dataset(path)
    second, config2 = read_dataset(path)
    assert second.identical(first) and config2 == config and second is not first
    name = next(n for n, v in second.data_vars.items() if v.dtype.kind == "f")
    second[name].values[...] = -1.0
    config2["changed"] = True
    third, config3 = read_dataset(path)
    assert third.identical(first) and "changed" not in config3
    changed = ds.copy(deep=True)
    changed[name].values[...] = 7.0
    write_dataset(changed, path)
    assert (read_dataset(path)[0][name].values == 7.0).all()
