"""CF-1.10: every kind of dataset the pipeline writes passes the IOOS compliance checker
with no high-priority failure, opens in cf_xarray and pint-xarray, and comes back through
read_dataset exactly as its study made it (docs/datasets.md)."""

from __future__ import annotations

import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from creatio.pipeline.config import resolve
from creatio.pipeline.run import run_study
from creatio.store import cf
from creatio.store.netcdf import read_dataset, write_dataset

cf_units = pytest.importorskip(
    "cf_units", reason="cf-units (UDUNITS-2) is a dev dependency: pip install -e '.[dev]'")
checker_runner = pytest.importorskip(
    "compliance_checker.runner", reason="compliance-checker is a dev dependency: "
    "pip install -e '.[dev]'")

#: Cheap configs of every kind of dataset: studies (kinematic in u and in m, sphere),
#: analyses, sweeps (a batch and the aggregate, one point refused), scenes.
KINDS = ["ct02", "en01", "en02", "work_precision", "stability_map_mu",
         "stability_map_duration", "boundaries", "sweep_batch", "sweep", "scene_surface_family",
         "scene_velocity_normal", "scene_compare"]
ANALYSES = {
    "work_precision": (["bases.en02.study.duration=2", "bases.en02r.study.duration=2",
                        "study.methods.rk4.steps_per_output=[50]",
                        "study.methods.dopri5.rtol=[1e-6]", "study.methods.dop853.rtol=[1e-8]",
                        "study.methods.radau5.rtol=[1e-6,1e-8]",
                        "study.methods.radau5.steps_per_output=[5]",
                        "study.methods.dopri5.dense_rtol=[]", "study.methods.dop853.dense_rtol=[]",
                        "study.methods.radau5.dense_rtol=[]",
                        "study.methods.radau5.dense_dt=[0.06]",
                        "study.methods.rodas4.rtol=[1e-6]",
                        "study.methods.rodas4.steps_per_output=[]",
                        "study.unlisted.rtol=[1e-6]", "study.unlisted.steps_per_output=[50]",
                        "study.peers.DOP853=[1e-6]", "study.peers.Radau=[1e-6]",
                        "study.peers.LSODA=[1e-8]", "study.repeats=1", "study.jit.methods=[rk4]",
                        "study.jit.cold=false"], "work_precision_en02r"),
    "stability_map": (["study.duration=2.0", "study.axes.mu=[1.0]", "study.axes.eps=[0.04]",
                       "study.methods=[rk4]", "study.duration_check.mu=[1.0]",
                       "study.duration_check.duration=3.0"], None),
    "boundaries": (["study.explore=[b]", "study.axes.b.grid=[0.12,0.2]"], "boundaries_b"),
}
SCENES = {"surface_family": [], "velocity_normal": [],
          "compare": ["bases.en02.phases.T=12", "bases.en02r.phases.T=12"]}


def _study(kind: str) -> xr.Dataset:
    if kind == "ct02":
        return run_study(resolve("ct02", ["study.inclinations_deg=[0,45,90]"]))
    if kind == "en01":
        return run_study(resolve("en01", [
            "study.n_radii=3", "study.n_angles=4", "study.regularity.n_radii=8",
            "study.regularity.n_angles=8", "study.regularity.inclinations_deg=[0,45,90]"]))
    return run_study(resolve("en02", ["phases.T=2"]), dt=0.002)


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, Path]:
    """One dataset of each kind, written by write_dataset (computed once for the module)."""
    from creatio.pipeline.sweep import aggregate, plan_sweep, run_batch
    from creatio.scenes.config import resolve as resolve_scene
    from creatio.scenes.run import write_scene_dataset

    root = tmp_path_factory.mktemp("cf")
    out = {kind: write_dataset(_study(kind), root / f"{kind}.nc")
           for kind in ("ct02", "en01", "en02")}
    for analysis, (overrides, part) in ANALYSES.items():
        r = resolve(analysis, overrides)
        if part:
            out[analysis] = write_dataset(run_study(r, part), root / f"{part}.nc")
        else:
            for name in ("mu", "duration"):
                out[f"{analysis}_{name}"] = write_dataset(run_study(r, f"{analysis}_{name}"),
                                                          root / f"{analysis}_{name}.nc")
    plan = plan_sweep("en02", ["sphere.mu=0,0.15,5"], ["phases.T=2.0"],
                      data_dir=str(root / "data"), batch_size=3)
    out["sweep_batch"] = run_batch(plan, 0)
    out["sweep"] = write_dataset(aggregate(plan), root / "sweep.nc")
    for scene, overrides in SCENES.items():
        out[f"scene_{scene}"] = write_scene_dataset(resolve_scene(scene, overrides),
                                                    root / f"scene_{scene}.nc")
    assert sorted(out) == sorted(KINDS)
    return out


@pytest.fixture(scope="module")
def suite():
    """The IOOS compliance checker with its CF checkers loaded (once: it takes seconds)."""
    s = checker_runner.CheckSuite()
    with warnings.catch_warnings():  # its deprecated IOOS SOS checkers say so on loading
        warnings.simplefilter("ignore", DeprecationWarning)
        s.load_all_available_checkers()
    return s


def check(suite, path: Path) -> tuple[dict, dict]:
    """`compliance-checker -t cf:1.10 path`: (aggregate counts and results, check errors)."""
    nc = suite.load_dataset(str(path))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            groups, errors = suite.run_all(nc, ["cf:1.10"], skip_checks=[])["cf:1.10"]
    finally:
        nc.close()
    return suite.build_structure("cf:1.10", groups, str(path), limit=1), errors


def failures(result: dict, level: str) -> list[str]:
    return [f"{r.name}: {m}" for r in result[f"{level}_priorities"] if r.value[0] < r.value[1]
            for m in r.msgs]


#: The one finding the checker makes on an elapsed time (docs/datasets.md, "Time"): it
#: takes a dimension *named* time for a calendar time axis (its s.5.1 name list), whatever
#: its units say. CF itself names no variable; a coordinate in s is an ordinary coordinate.
ELAPSED_TIME = ("§5.1 Independent Latitude, Longitude, Vertical, and Time Axes: Coordinate "
                "variable 'time' should have standard_name='time', found: 'None'")


def high_failures(result: dict) -> list[str]:
    """The high-priority failures, less the name-based finding on the elapsed time."""
    return [m for m in failures(result, "high") if m != ELAPSED_TIME]


@pytest.mark.parametrize("kind", KINDS)
def test_no_high_priority_failure_on_any_kind_of_dataset(written, suite, kind):
    """compliance-checker -t cf:1.10: no high-priority failure but the checker's guess that
    a dimension named time is a calendar axis (and that one only where time is a dimension),
    and no check that crashed (the variable-length string coordinates made one crash)."""
    result, errors = check(suite, written[kind])
    assert high_failures(result) == [], failures(result, "high")
    with netCDF4.Dataset(written[kind]) as nc:
        timed = "time" in nc.dimensions
    assert (ELAPSED_TIME in failures(result, "high")) == timed
    assert result["high_count"] == int(timed)
    assert not errors, {k: repr(e) for k, (e, _) in errors.items()}
    assert result["possible_points"] > 0


def test_a_dataset_written_the_old_way_fails_the_checker(suite, tmp_path):
    """The check bites: the same EN-02 data with today's metadata but none of conform's
    fixes (prose units, no long_name, _FillValue on coordinates) fails beyond the elapsed
    time's finding."""
    ds = _study("en02")
    ds["kinetic_energy"].attrs = {"units": "u (per coordinate unit)"}
    path = tmp_path / "raw.nc"
    ds.to_netcdf(path, engine="netcdf4")
    result, _ = check(suite, path)
    text = " ".join(high_failures(result))
    assert len({m.split(":")[0] for m in high_failures(result)}) >= 2
    for expected in ("kinetic_energy", "_FillValue"):
        assert expected in text


def test_every_variable_has_a_long_name_and_units_udunits_reads(written):
    """long_name everywhere; UDUNITS-parseable units on every numeric variable (except the
    declared mixed-unit ones); u never written as a unit symbol; text as char arrays;
    coordinates without _FillValue; lengths in u flagged by the global attribute."""
    for kind, path in written.items():
        with netCDF4.Dataset(path) as nc:
            for name, var in nc.variables.items():
                attrs = var.__dict__
                assert str(attrs.get("long_name", "")).strip(), (kind, name)
                if var.dtype == np.dtype("S1"):
                    assert attrs.get("_Encoding") == "utf-8", (kind, name)
                    continue
                assert var.dtype.kind in "fiu", (kind, name, var.dtype)  # no vlen strings
                if name in nc.dimensions:
                    assert "_FillValue" not in attrs, (kind, name)
                if name in cf.MIXED_UNITS:
                    assert "units" not in attrs, (kind, name)
                    continue
                assert "units" in attrs, (kind, name)
                assert not cf_units.Unit(attrs["units"]).is_unknown(), (kind, name)
                if "since" not in attrs["units"]:  # written in the normal form already
                    assert cf.udunits(attrs["units"]) == attrs["units"], (kind, name)
                assert "u" not in attrs["units"].split(), (kind, name)
            in_u = any("u" in str(v.__dict__.get(cf.ORIGINAL_UNITS, "")).split()
                       for v in nc.variables.values())
            assert ("model_length_unit" in nc.ncattrs()) == (kind in ("ct02",
                                                                       "scene_velocity_normal"))
            assert in_u == (kind in ("ct02", "scene_velocity_normal"))


def test_plain_open_dataset_gives_time_in_seconds(written):
    """The ordinary xarray.open_dataset (times decoded by default) gives simulated time as
    seconds, so that ds.centre.sel(time=0.5) works; it used to give 1970 dates and KeyError."""
    timed = {"en01", "en02", "scene_velocity_normal", "scene_compare"}
    for kind, path in written.items():
        with xr.open_dataset(path) as ds:
            if "time" not in ds.variables:
                assert kind not in timed, kind
                continue
            assert kind in timed, kind
            assert ds.time.dtype == np.float64 and ds.time.attrs["units"] == "s", kind
            assert ds.time.values[0] == 0.0
            assert "standard_name" not in ds.time.attrs and "calendar" not in ds.time.attrs
    back, _ = read_dataset(written["en02"])
    row = int(np.flatnonzero(back.time.values == 0.5)[0])
    with xr.open_dataset(written["en02"]) as ds:
        np.testing.assert_array_equal(ds.centre.sel(time=0.5).values, back.centre.values[row])


def test_cf_xarray_and_pint_xarray_read_every_dataset(written):
    """Opened the way users open them: pint-xarray quantifies every variable with UDUNITS
    units, lengths with a length and time with a time; no dataset claims a calendar axis."""
    cf_xarray = pytest.importorskip("cf_xarray.units", reason="cf_xarray is a dev dependency")
    pytest.importorskip("pint_xarray", reason="pint-xarray is a dev dependency")
    ureg = cf_xarray.units
    for kind, path in written.items():
        with xr.open_dataset(path) as ds:
            assert not ds.cf.standard_names.get("time"), kind
            q = ds.pint.quantify(unit_registry=ureg)
            n = sum(1 for v in q.variables.values() if hasattr(v.data, "units"))
            assert n > 0, kind
            if "time" in q.variables:
                assert q["time"].pint.dimensionality == ureg("s").dimensionality, kind
    with xr.open_dataset(written["en02"]) as ds:
        q = ds.pint.quantify(unit_registry=ureg)
        assert q["centre"].pint.to("mm").pint.magnitude[0, 0] == pytest.approx(
            1000 * float(ds["centre"][0, 0]))
        assert q["speed"].pint.dimensionality == ureg("m/s").dimensionality
    with xr.open_dataset(written["ct02"]) as ds:
        q = ds.pint.quantify(unit_registry=ureg)
        assert q["pitch_formula"].pint.dimensionality == ureg("1").dimensionality
        assert q["feature_velocity_error"].pint.dimensionality == ureg("s-1").dimensionality


def test_read_dataset_gives_back_what_the_study_made(written):
    """Values bit for bit, dtypes (text as numpy strings), and every attribute as the study
    wrote it: the units in project notation, nothing conform added."""
    for kind in ("ct02", "en02"):
        ds = _study(kind)
        back, _ = read_dataset(written[kind])
        for name, var in ds.variables.items():
            got = back[name].variable
            assert got.dtype == var.dtype, (kind, name)
            assert got.dims == var.dims, (kind, name)
            if var.dtype.kind == "f":
                assert got.values.tobytes() == var.values.tobytes(), (kind, name)
            else:
                np.testing.assert_array_equal(got.values, var.values)
            assert got.attrs == var.attrs, (kind, name)
        for key in ("Conventions", "config_sha256", "title"):
            assert back.attrs[key] == ds.attrs[key]
        assert cf.ADDED not in back.attrs and "model_length_unit" not in back.attrs
    back, _ = read_dataset(written["ct02"])
    assert back["h"].attrs["units"] == "model units (u, rad, s)"
    assert back["pitch_formula"].attrs["units"] == "u"
    assert "units" not in back["j_min_sampled"].attrs
    assert list(back["derivative"].values) == ["c_R", "c_alpha", "c_t"]
    batch = xr.load_dataset(written["sweep_batch"])  # plain xarray: text decoded as str too
    assert list(batch["status"].values)[2] == "invalid" and batch["message"].values[2]


def test_conform_is_idempotent_and_never_touches_values():
    """conform twice is conform once (a re-written dataset keeps its marks); the data are
    the same objects' values, bit for bit."""
    ds = _study("ct02")
    once = cf.conform(ds)
    twice = cf.conform(once)
    xr.testing.assert_identical(once, twice)
    for name, var in ds.variables.items():
        assert once[name].values.tobytes() == var.values.tobytes()
    assert "long_name" not in ds["j_min_sampled"].attrs  # the caller's dataset is untouched
    assert once["j_min_sampled"].attrs["long_name"] == "smallest sampled J"
    assert once["h"].attrs[cf.ORIGINAL_UNITS] == "model units (u, rad, s)"


@pytest.mark.parametrize(("stated", "expected"), [
    ("m", "m"), ("m/s", "m s-1"), ("m s-1", "m s-1"), ("rad/s", "rad s-1"), ("deg", "degree"),
    ("degree", "degree"), ("u", "1"), ("u s-1", "s-1"), ("u/s", "s-1"), ("u/s2", "s-2"),
    ("m/s^2", "m s-2"), ("kg m2", "kg m2"), ("1", "1"), ("N", "N"), ("J", "J"),
    ("model units (u, rad, s)", "1"), ("m, rad, s", "1"), ("u (per coordinate unit)", "1"),
    ("m (c_R: dimensionless)", "m"), ("metres, roughly", None), ("m/s/s", None), ("", None),
])
def test_project_unit_strings_become_udunits(stated, expected):
    """The unit strings the studies write, in UDUNITS form (u, the model length, as 1);
    prose no table knows is refused rather than guessed."""
    assert cf.udunits(stated) == expected
    if expected is not None:
        assert not cf_units.Unit(expected).is_unknown()


def test_a_study_no_table_knows_is_still_compliant(suite, tmp_path):
    """Variables added later: long_name from the name, units from a figure's suffix, prose
    units kept apart (creatio_units) instead of written as units; the file passes."""
    t = np.arange(4) * 0.5
    ds = xr.Dataset(
        {"peak_force_N": ("time", t + 1.0), "wobble": ("time", t * 2.0),
         "drift": ("time", t, {"units": "metres, roughly"}),
         "lap": ("time", t, {"units": "deg"}), "verdict": ("time", ["a", "b", "cc", ""])},
        coords={"time": t}, attrs={"title": "a future study"})
    path = write_dataset(ds, tmp_path / "future.nc")
    result, errors = check(suite, path)
    assert high_failures(result) == [] and not errors, failures(result, "high")
    with netCDF4.Dataset(path) as nc:
        assert nc["wobble"].long_name == "wobble" and "units" not in nc["wobble"].ncattrs()
        assert nc["peak_force_N"].long_name == "peak force" and nc["peak_force_N"].units == "N"
        assert "units" not in nc["drift"].ncattrs()
        assert nc["drift"].getncattr(cf.ORIGINAL_UNITS) == "metres, roughly"
        assert nc["lap"].units == "degree" and nc["time"].units == "s"
        assert "axis" not in nc["time"].ncattrs()
        assert nc.Conventions == cf.CONVENTIONS
    back, _ = read_dataset(path)
    assert back["drift"].attrs == {"units": "metres, roughly"}
    assert back["lap"].attrs == {"units": "deg"} and back["wobble"].attrs == {}
    assert list(back["verdict"].values) == ["a", "b", "cc", ""]


#: Angle variables of every kind of dataset (docs/datasets.md, "Angles"): in degree.
ANGLES = {"centre_azimuth", "contact_alpha", "pattern_angle", "angular_lag", "cumulative_spin",
          "inclination", "phase_r", "phase_a", "displacement", "pattern_rotation",
          "radial_phase", "cavity_cell_u", "cavity_cell_v", "start_alpha", "event_alpha"}


def test_one_unit_per_kind_of_angle_and_one_meaning_per_name(written):
    """contact_alpha was rad beside centre_azimuth in degree, a scene's inclination rad
    beside CT-02's degree, and a scene's `friction` a magnitude where the studies' is the
    force vector: every angle is in degree, every angular rate in rad s-1, no variable
    anywhere in rad, `friction` always has its three components (the units as a reader's
    xarray.open_dataset gives them)."""
    seen = set()
    for kind, path in written.items():
        with xr.open_dataset(path) as opened:
            back = opened.load()
        for name, var in back.variables.items():
            units = var.attrs.get("units")
            assert units != "rad", (kind, name)
            if name in ANGLES:
                assert units == "degree", (kind, name, units)
                seen.add(name)
            if units == "rad s-1":
                assert name in ("omega", "spin_rate", "pattern_rate", "pattern_rate_fd"), name
            if name == "friction":
                assert "component" in var.dims and var.attrs["units"] == "N", kind
    assert {"contact_alpha", "centre_azimuth", "inclination", "phase_r", "phase_a"} <= seen
