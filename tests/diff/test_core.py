"""`creatio diff`: tolerances, structure, attributes, configs, reports, pairing, exit codes."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from creatio.diff.core import Tolerance, compare_arrays, diff, main
from creatio.pipeline.provenance import provenance
from creatio.store.netcdf import write_dataset

CONFIG = {"geometry": {"A": 0.18, "R0": 0.68}, "sphere": {"mu": 0.15}, "study": {"id": "en02"}}


def dataset(study: str = "en02", config: dict | None = None, n_time: int = 5) -> xr.Dataset:
    """A small dataset shaped like a study's, with full provenance."""
    text = yaml.safe_dump(config or CONFIG, sort_keys=True)
    attrs = provenance(study, text, hashlib.sha256(text.encode()).hexdigest(), "synthetic")
    t = np.arange(n_time) * 0.1
    return xr.Dataset(
        {
            "centre": (("time", "component"), np.outer(np.cos(t), [1.0, 2.0, 3.0]),
                       {"units": "m", "long_name": "centre"}),
            "energy": ("time", 9.81 + np.sin(t), {"units": "J"}),
            "fd_error": (("derivative", "h"), [[1e-4, 1e-6, 1e-8], [2e-4, 2e-6, 2e-8]]),
            "label": ("derivative", ["first", "second"]),
        },
        coords={"time": t, "component": ["x", "y", "z"], "derivative": ["c_R", "c_t"],
                "h": [1e-2, 1e-3, 1e-4]},
        attrs={**attrs, "max_slip_speed": 2.9e-5, "status": "ok"},
    )


def report(study: str = "en02", **changes) -> dict:
    """A small JSON report like the study reports (nested figures, lists, strings)."""
    data = {"study": study, "final_radius_m": 1.11, "fd_error": {"c_R": {"0.01": 1e-4}},
            "dt_s": [0.002, 0.001], "status": "ok", "config_sha256": "abc"}
    data.update(changes)
    return data


def write_pair(tmp_path: Path, a: xr.Dataset, b: xr.Dataset) -> tuple[str, str]:
    pa = write_dataset(a, tmp_path / "a" / "x.nc")
    pb = write_dataset(b, tmp_path / "b" / "x.nc")
    return str(pa), str(pb)


def write_tree(root: Path, studies: dict[str, xr.Dataset]) -> Path:
    """A data directory: studies/<s>/<s>.nc and reports/<s>.json (plus noise to ignore)."""
    for study, ds in studies.items():
        write_dataset(ds, root / "studies" / study / f"{study}.nc")
        (root / "reports").mkdir(parents=True, exist_ok=True)
        (root / "reports" / f"{study}.json").write_text(json.dumps(report(study)))
    write_dataset(dataset("ct02"), root / "runs" / "0123456789ab" / "studies" / "x" / "x.nc")
    (root / "reports" / "diff").mkdir(parents=True, exist_ok=True)
    (root / "reports" / "diff" / "old.json").write_text("{}")
    return root


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------------------ values
def test_one_ulp_is_a_difference_at_zero_tolerance_and_not_within_one(tmp_path, capsys):
    """One ulp in one value: exit 1 with atol = rtol = 0, exit 0 within any tolerance."""
    a = dataset()
    b = a.copy(deep=True)
    b["energy"].values[2] = np.nextafter(b["energy"].values[2], np.inf)
    pa, pb = write_pair(tmp_path, a, b)
    code, out, _ = run(capsys, pa, pb)
    assert code == 1
    assert "energy" in out and "time=0.2" in out
    for tol in (["--atol", "1e-12"], ["--rtol", "1e-15"], ["--tol", "energy=1e-12"],
                ["--tol", "ener*=0,1e-15"]):
        code, out, _ = run(capsys, pa, pb, *tol)
        assert code == 0, (tol, out)


def test_value_statistics_locate_the_largest_difference(tmp_path):
    """max abs, max rel, rms, count beyond tolerance and the coordinates of the maximum."""
    a = dataset()
    b = a.copy(deep=True)
    b["centre"].values[3, 1] += 1e-3
    b["centre"].values[1, 0] += 1e-9
    result = diff(*write_pair(tmp_path, a, b), tol=Tolerance(atol=1e-6))
    stats = result["datasets"]["x.nc"]["data"]["centre"]
    assert stats["max_abs"] == pytest.approx(1e-3)
    assert stats["at"] == {"time": pytest.approx(0.3), "component": "y"}
    assert stats["n_beyond"] == 1 and stats["n_differ"] == 2 and stats["n"] == 15
    assert stats["rms"] == pytest.approx(np.sqrt((1e-6 + 1e-18) / 15), rel=1e-6)
    assert stats["max_rel"] == pytest.approx(1e-3 / abs(b["centre"].values[3, 1]))
    assert result["exit_code"] == 1


def test_nan_appearing_is_a_difference_whatever_the_tolerance(tmp_path, capsys):
    """A NaN where there was a number is reported (and NaN against NaN is equal)."""
    a = dataset()
    b = a.copy(deep=True)
    b["energy"].values[1] = np.nan
    pa, pb = write_pair(tmp_path, a, b)
    result = diff(pa, pb, tol=Tolerance(atol=1e6, rtol=1.0))
    stats = result["datasets"]["x.nc"]["data"]["energy"]
    assert stats["nan_appeared"] == 1 and stats["nan_mismatch"] == 1 and stats["n_beyond"] == 1
    assert result["exit_code"] == 1
    code, out, _ = run(capsys, pa, pb)
    assert code == 1 and "NaN appeared 1" in out
    a["energy"].values[1] = np.nan
    pa, pb = write_pair(tmp_path, a, b)
    assert run(capsys, pa, pb)[0] == 0


def test_compare_arrays_follows_isclose():
    """Beyond tolerance exactly where numpy.isclose (equal_nan) says not close."""
    rng = np.random.default_rng(0)
    a = rng.normal(size=200)
    b = a * (1 + rng.normal(scale=1e-6, size=200))
    b[[3, 7]] = np.nan
    a[7] = np.nan
    a[[10, 11, 12]], b[[10, 11, 12]] = [np.inf, -np.inf, np.inf], [np.inf, np.inf, 1.0]
    stats, _ = compare_arrays(a, b, atol=1e-7, rtol=1e-6)
    expected = ~np.isclose(a, b, atol=1e-7, rtol=1e-6, equal_nan=True)
    assert stats["n_beyond"] == int(expected.sum())
    strings, where = compare_arrays(np.array(["a", "b"]), np.array(["a", "c"]))
    assert strings["n_beyond"] == 1 and where == 1


# ------------------------------------------------------------------------------ structure
def test_removed_variable_and_changed_dimension_are_reported(tmp_path, capsys):
    """A variable removed and a dimension grown are structure changes (exit 1)."""
    a = dataset()
    b = dataset(n_time=6).drop_vars("label")
    pa, pb = write_pair(tmp_path, a, b)
    code, out, _ = run(capsys, pa, pb, "--json")
    assert code == 1
    r = json.loads(out)["datasets"]["x.nc"]
    kinds = {(s["kind"], s["name"]) for s in r["structure"]}
    assert ("variable_removed", "label") in kinds
    assert ("dim_changed", "time") in kinds
    assert ("coordinate_values", "time") in kinds
    assert "compared_on" not in r["data"].get("energy", {})
    assert r["counts"]["structure"] >= 3
    code, out, _ = run(capsys, pa, pb)
    assert "variable label removed" in out and "dimension time: 5 -> 6" in out


def test_dtype_and_units_changes_are_structure(tmp_path):
    """A dtype change and a units change are each reported."""
    a = dataset()
    b = a.copy(deep=True)
    b["energy"] = b["energy"].astype(np.float32)
    b["energy"].attrs["units"] = "kJ"
    result = diff(*write_pair(tmp_path, a, b), tol=Tolerance(rtol=1e-6))
    kinds = {s["kind"] for s in result["datasets"]["x.nc"]["structure"]}
    assert {"dtype", "units"} <= kinds
    assert result["exit_code"] == 1


# ------------------------------------------------------------------------------ attributes
def test_changed_attribute_is_reported_volatile_ones_only_when_asked(tmp_path, capsys):
    """title and a variable's attribute count; history and date_created only with --all-attrs."""
    a = dataset()
    b = a.copy(deep=True)
    b.attrs["history"] = "another run"
    b.attrs["date_created"] = "2031-01-01T00:00:00+00:00"
    pa, pb = write_pair(tmp_path, a, b)
    assert run(capsys, pa, pb)[0] == 0
    code, out, _ = run(capsys, pa, pb, "--all-attrs")
    assert code == 1 and "history" in out
    b.attrs["title"] = "renamed"
    b["centre"].attrs["long_name"] = "centre of the sphere"
    pa, pb = write_pair(tmp_path, a, b)
    result = diff(pa, pb)
    names = {(x["variable"], x["name"]) for x in result["datasets"]["x.nc"]["attrs"]}
    assert names == {(None, "title"), ("centre", "long_name")}
    assert result["exit_code"] == 1
    c = a.copy(deep=True)
    c["energy"].attrs["long_name"] = "total energy"
    pa, pc = write_pair(tmp_path, a, c)
    gained = diff(pa, pc)
    assert gained["exit_code"] == 0, "an attribute new since A is reported, not counted"
    assert gained["datasets"]["x.nc"]["added"] == ["attribute energy:long_name = total energy"]
    assert diff(pa, pc, strict_provenance=True)["exit_code"] == 1


def test_numeric_attributes_use_the_tolerances(tmp_path):
    """A numeric attribute (an extremum) is compared with atol/rtol like the data."""
    a = dataset()
    b = a.copy(deep=True)
    b.attrs["max_slip_speed"] = 2.9e-5 * (1 + 1e-12)
    pa, pb = write_pair(tmp_path, a, b)
    assert diff(pa, pb)["exit_code"] == 1
    assert diff(pa, pb, tol=Tolerance(rtol=1e-9))["exit_code"] == 0


def test_provenance_is_reported_but_counted_only_when_strict(tmp_path, capsys):
    """A new commit or library version alone is not a difference unless --strict-provenance."""
    a = dataset()
    b = a.copy(deep=True)
    b.attrs["git_commit"] = "f" * 40
    b.attrs["version_numpy"] = "9.9.9"
    pa, pb = write_pair(tmp_path, a, b)
    code, out, _ = run(capsys, pa, pb)
    assert code == 0
    assert "git_commit" in out and "version_numpy" in out and "not counted" in out
    assert run(capsys, pa, pb, "--strict-provenance")[0] == 1


def test_changed_config_key_is_reported_key_by_key(tmp_path, capsys):
    """The resolved configs are flattened and compared: sphere.mu: 0.15 -> 0.3."""
    a = dataset()
    b = dataset(config={**CONFIG, "sphere": {"mu": 0.3}})
    b["energy"] = a["energy"]
    pa, pb = write_pair(tmp_path, a, b)
    code, out, _ = run(capsys, pa, pb)
    assert code == 1
    assert "sphere.mu: 0.15 -> 0.3" in out
    config = diff(pa, pb)["datasets"]["x.nc"]["config"]
    assert config == [{"key": "sphere.mu", "old": 0.15, "new": 0.3, "change": "changed"}]


# ------------------------------------------------------------------------------ reports
def test_report_figures_old_new_change_and_tolerance(tmp_path, capsys):
    """Numbers: abs and rel change, flagged beyond tolerance; strings and new keys count."""
    pa, pb = tmp_path / "a.json", tmp_path / "b.json"
    pa.write_text(json.dumps(report()))
    pb.write_text(json.dumps(report(final_radius_m=1.11 * (1 + 1e-6),
                                    fd_error={"c_R": {"0.01": 1e-4 + 1e-15}})))
    result = diff(str(pa), str(pb), tol=Tolerance(rtol=1e-9, overrides=(("fd_error", 1e-12, 0),)))
    figures = {f["key"]: f for f in result["reports"]["a.json vs b.json"]["figures"]}
    assert figures["final_radius_m"]["beyond"]
    assert figures["final_radius_m"]["rel_change"] == pytest.approx(1e-6)
    assert not figures["fd_error.c_R.0.01"]["beyond"]
    assert result["counts"]["reports"] == 1 and result["exit_code"] == 1
    pb.write_text(json.dumps(report(status="failed", warnings=["x"])))
    code, out, _ = run(capsys, str(pa), str(pb))
    assert code == 1 and "status" in out and "warnings" in out


def test_tolerance_names_match_dotted_prefixes_and_globs():
    """--tol fd_error covers report keys fd_error.c_R.0.01; the last matching --tol wins."""
    tol = Tolerance(1.0, 2.0, (("*_error", 5.0, 6.0), ("fd_error", 3.0, 4.0),
                               ("observed_order", 7.0, 8.0)))
    assert tol.get("fd_error.c_R.0.01") == (3.0, 4.0)
    assert Tolerance(0, 0, (("fd_error", 3.0, 4.0), ("*_error", 5.0, 6.0))).get(
        "fd_error") == (5.0, 6.0)
    assert tol.get("pattern_fd_error") == (5.0, 6.0)
    assert tol.get("observed_order.c_t.1e-05") == (7.0, 8.0)
    assert tol.get("final_radius_m") == (1.0, 2.0)


# ------------------------------------------------------------------------------ trees
def test_directories_pair_files_added_removed_unchanged(tmp_path):
    """Pairing by relative path; runs/ and reports/diff/ are ignored."""
    a = write_tree(tmp_path / "a", {"ct02": dataset("ct02"), "en01": dataset("en01")})
    changed = dataset("ct02")
    changed["energy"].values[0] += 1.0
    b = write_tree(tmp_path / "b", {"ct02": changed, "en02": dataset("en02")})
    result = diff(str(a), str(b))
    files = result["files"]
    assert files["added"] == ["reports/en02.json", "studies/en02/en02.nc"]
    assert files["removed"] == ["reports/en01.json", "studies/en01/en01.nc"]
    assert files["changed"] == ["studies/ct02/ct02.nc"]
    assert files["unchanged"] == ["reports/ct02.json"]
    assert result["counts"]["structure"] == 2 and result["exit_code"] == 1  # removed files
    assert result["counts"]["added"] == 2  # new files (a new study) reported, not counted
    only = diff(str(a), str(b), studies=["ct02"])
    assert only["files"]["added"] == [] and only["files"]["removed"] == []


def test_json_output_shape(tmp_path, capsys):
    """--json prints one object with sides, tolerance, files, datasets, reports, counts."""
    a = write_tree(tmp_path / "a", {"ct02": dataset("ct02")})
    b = write_tree(tmp_path / "b", {"ct02": dataset("ct02", n_time=4)})
    out_json = tmp_path / "out" / "d.json"
    code, out, _ = run(capsys, str(a), str(b), "--json", "--atol", "1e-9", "--json-out",
                       str(out_json))
    data = json.loads(out)
    assert code == 1 and data == json.loads(out_json.read_text())
    assert {"format", "a", "b", "tolerance", "options", "files", "datasets", "reports",
            "provenance", "warnings", "counts", "counted", "differences",
            "exit_code"} <= set(data)
    assert data["a"]["kind"] == "tree" and data["tolerance"]["atol"] == 1e-9
    assert set(data["files"]) == {"added", "removed", "omitted", "unchanged", "identical",
                                  "changed"}
    entry = data["datasets"]["studies/ct02/ct02.nc"]
    assert {"structure", "data", "config", "attrs", "provenance", "counts"} <= set(entry)
    assert set(data["counts"]) == {"structure", "data", "config", "attrs", "reports",
                                   "provenance", "added"}
    assert data["differences"] == sum(data["counts"][c] for c in data["counted"])


# ------------------------------------------------------------------------------ errors
def test_missing_file_release_or_bad_argument_exit_2(tmp_path, capsys, monkeypatch):
    """Unreadable or missing inputs and bad arguments: exit 2 with a message on stderr."""
    monkeypatch.chdir(tmp_path)
    ds = write_dataset(dataset(), tmp_path / "x.nc")
    code, _, err = run(capsys, str(ds), "nope.nc")
    assert code == 2 and "nope.nc: no such file" in err
    code, _, err = run(capsys, "0.1.0", "data")
    assert code == 2 and "no release 0.1.0" in err
    code, _, err = run(capsys, "latest", str(ds))
    assert code == 2 and "no release in" in err
    bad = tmp_path / "bad.nc"
    bad.write_bytes(b"not netcdf")
    code, _, err = run(capsys, str(ds), str(bad))
    assert code == 2 and "cannot read dataset" in err
    code, _, err = run(capsys, str(ds), str(ds), "--tol", "fd_error:1e-9")
    assert code == 2 and "NAME=ATOL" in err
    code, _, err = run(capsys, str(ds), str(tmp_path))
    assert code == 2 and "cannot compare a dataset" in err
    with pytest.raises(SystemExit) as e:
        main([str(ds), str(ds), "--atol", "-1"])
    assert e.value.code == 2


def test_exit_zero_and_text_out_for_the_workflow(tmp_path, capsys):
    """--exit-zero keeps 0 with differences; --text-out writes the screen report."""
    a = dataset()
    b = a.copy(deep=True)
    b["energy"].values[0] += 1
    pa, pb = write_pair(tmp_path, a, b)
    out_txt = tmp_path / "d.txt"
    code, out, _ = run(capsys, pa, pb, "--exit-zero", "--quiet", "--text-out", str(out_txt))
    assert code == 0 and out == ""
    text = out_txt.read_text()
    assert "exit 1" in text and "energy" in text
    assert len(text.splitlines()) < 40


# ------------------------------------------------------------------------------ conventions
RELEASED_EN02 = (Path(__file__).resolve().parents[2] / "data" / "releases" / "0.1.0" / "studies"
                 / "en02" / "en02_dt0.002.nc")


def todays_encoding(path: Path) -> xr.Dataset:
    """A 0.1.0 sphere dataset as today's code writes the same numbers: contact_alpha in
    degree (numpy.degrees, as studies.sphere does), time without standard_name."""
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(path)
    ds["contact_alpha"] = ("time", np.degrees(ds.contact_alpha.values),
                           {**ds.contact_alpha.attrs, "units": "degree"})
    ds["time"].attrs.pop("standard_name")
    return ds


def test_a_release_in_rad_compares_value_for_value_with_todays_degrees(tmp_path, capsys):
    """0.1.0 wrote contact_alpha in rad and time with standard_name time (the input that
    made `creatio diff 0.1.0 data` count them): the documented conventions map the old side
    (same numpy.degrees), 0 differences at atol = rtol = 0, each mapping named as provenance."""
    new = write_dataset(todays_encoding(RELEASED_EN02), tmp_path / "new.nc")
    code, out, _ = run(capsys, str(RELEASED_EN02), str(new), "--atol", "0", "--rtol", "0")
    assert code == 0, out
    assert "0 difference(s)" in out
    assert "contact_alpha units (converted before comparing): rad -> degree" in out
    assert "time:standard_name: time -> None" in out
    result = diff(str(RELEASED_EN02), str(new))
    notes = {p["name"]: p for p in result["provenance"]}
    assert notes["contact_alpha units (converted before comparing)"]["kind"] == "convention"
    assert result["counts"]["structure"] == result["counts"]["data"] == 0


def test_a_mapped_convention_still_finds_a_changed_value(tmp_path):
    """The mapping converts, it does not hide: one ulp moved in today's degrees, or units no
    convention names, is still counted."""
    ds = todays_encoding(RELEASED_EN02)
    ds["contact_alpha"].values[7] = np.nextafter(ds["contact_alpha"].values[7], np.inf)
    moved = write_dataset(ds, tmp_path / "moved.nc")
    result = diff(str(RELEASED_EN02), str(moved))
    assert result["exit_code"] == 1
    assert result["datasets"]["en02_dt0.002.nc vs moved.nc"]["data"]["contact_alpha"][
        "n_beyond"] == 1
    ds = todays_encoding(RELEASED_EN02)
    ds["contact_alpha"].attrs["units"] = "grad"
    other = write_dataset(ds, tmp_path / "grad.nc")
    kinds = {s["kind"] for s in diff(str(RELEASED_EN02), str(other))["datasets"][
        "en02_dt0.002.nc vs grad.nc"]["structure"]}
    assert "units" in kinds


def test_time_stored_with_a_placeholder_date_reads_back_in_seconds(tmp_path, capsys):
    """A dataset of the 0.1.x line stored time as 'seconds since 1970-01-01' (plain xarray
    gave 1970 dates): read_dataset gives seconds, the diff compares it value for value and
    names the encoding change as provenance."""
    import netCDF4

    from creatio.store.netcdf import read_dataset

    a = dataset()
    a["time"].attrs["units"] = "s"
    pa, pb = write_pair(tmp_path, a, a)
    with netCDF4.Dataset(pa, "a") as nc:  # what conform wrote before 0.2
        nc["time"].setncatts({"units": "seconds since 1970-01-01 00:00:00", "calendar": "standard",
                              "standard_name": "time", "axis": "T", "creatio_units": "s",
                              "creatio_added": "long_name standard_name calendar axis"})
    back, _ = read_dataset(pa)
    assert back.time.attrs == {"units": "s"} and back.time.values[1] == 0.1
    code, out, _ = run(capsys, pa, pb)
    assert code == 0, out
    assert "time stored units (read back as 's'): seconds since 1970-01-01" in out
    with xr.open_dataset(pb) as ds:
        assert ds.time.dtype == np.float64 and float(ds.energy.sel(time=0.2)) == float(
            a.energy.sel(time=0.2))
