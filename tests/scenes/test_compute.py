"""Scene datasets hold exactly what the scene draws, with provenance; a reused study dataset
and the scene's own minimal run give the same frames; the kinematic scenes' numbers are the
model's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.model.surface import Frame, Motion
from creatio.scenes.config import resolve
from creatio.scenes.run import scene_dataset

SHORT = ["bases.en02.phases.T=12",  # a 12 s cycle (duration follows T): 6,000 RK4 steps
         # the scene alone (its family: test_family.py)
         "~scene.axes.sphere", "~scene.axes.phases"]


@pytest.fixture(scope="module")
def short_en02():
    """The EN-02 scene on a 12 s cycle: its resolved config and its computed dataset."""
    r = resolve("en02", SHORT)
    return r, scene_dataset(r)


def test_a_sphere_scene_holds_what_it_draws_and_nothing_else(short_en02):
    r, ds = short_en02
    assert ds.sizes["frame"] == 31 and np.allclose(np.diff(ds.time.values), 0.4)
    drawn = {"centre", "quaternion", "phase_r", "phase_a", "inclination"}
    readouts = {str(x) for x in r.obj.scene.readouts} - {"time"}
    per_run = {"status", "stop_time", "frames_run", "sphere_radius", "direction", "source",
               "R0", "dR", "A", "Kr", "Ka"}
    assert set(ds.data_vars) == drawn | readouts | per_run
    assert not any("energy" in name for name in ds.data_vars)
    # one meaning per name: the studies' friction is the force vector, this is its magnitude
    assert "friction" not in ds and ds.friction_magnitude.attrs["units"] == "N"
    assert ds.phase_a.attrs["units"] == ds.inclination.attrs["units"] == "degree"
    assert "computed" in str(ds.source.values[0]) and "state size 12" in str(ds.source.values[0])


def test_a_scene_dataset_carries_provenance(short_en02):
    r, ds = short_en02
    for key in ("config_yaml", "config_sha256", "git_commit", "creatio_version",
                "date_created", "study_en02_config_sha256"):
        assert key in ds.attrs
    assert ds.attrs["config_sha256"] == r.sha256
    assert ds.attrs["study_en02_config_sha256"] == r.bases["en02"].sha256


def test_reused_and_computed_frames_agree(short_en02, tmp_path):
    """The study's own run (0.1 s history, energy, rotation) read at the frame times equals
    the scene's minimal run: leaving out energy and the 0.1 s rows changes no step."""
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    r, computed = short_en02
    study = run_study(r.bases["en02"], dt=0.002)
    path = write_dataset(study, tmp_path / "en02_dt0.002.nc")
    reused = scene_dataset(r, {"en02": path})
    assert str(reused.source.values[0]) == f"reused {path}"
    for name in ("centre", "quaternion", "speed", "normal_reaction", "cumulative_spin"):
        np.testing.assert_allclose(reused[name].values, computed[name].values,
                                   rtol=0, atol=1e-12, err_msg=name)


def test_a_dataset_of_another_config_is_not_reused(short_en02, tmp_path):
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    r, _ = short_en02
    other = resolve("en02", [*SHORT, "bases.en02.sphere.mu=0.2"]).bases["en02"]
    path = write_dataset(run_study(other, dt=0.002), tmp_path / "other.nc")
    ds = scene_dataset(r, {"en02": path})
    assert str(ds.source.values[0]).startswith("computed")


def test_compare_draws_no_orientation():
    ds = scene_dataset(resolve("compare", ["bases.en02.phases.T=12", "bases.en02r.phases.T=12",
                                           "~scene.axes.sphere"]))
    assert list(ds.run.values) == ["en02", "en02r"]
    assert "quaternion" not in ds
    assert "clockwise" in str(ds.direction.values[0])
    assert "counterclockwise" in str(ds.direction.values[1])
    assert "outward" in str(ds.direction.values[1])


def test_velocity_normal_numbers_are_the_models():
    r = resolve("velocity_normal")
    ds = scene_dataset(r)
    s = r.obj.scene
    surface = r.obj.geometry.surface()
    assert list(ds["mode"].values) == ["angular", "radial", "oscillation"]
    for m, name in enumerate(ds["mode"].values.tolist()):
        phases = s.modes[name]
        t = ds.time.values[17]
        fr = Frame(surface, Motion(*phases.laws()), math.radians(s.alpha_deg), s.R, t)
        np.testing.assert_allclose(ds.position.values[m, 17], fr.position, atol=1e-15)
        np.testing.assert_allclose(ds.normal.values[m, 17], fr.normal, atol=1e-15)
        np.testing.assert_allclose(ds.velocity.values[m, 17], fr.c_t, atol=1e-15)
    # the notebook's modes: the pattern turns, the wave runs outward, the inclination rocks
    assert np.ptp(ds.phase_a.values[0]) > 0 and np.ptp(ds.phase_r.values[1]) > 0
    assert math.isclose(ds.inclination.values[2].max(), 55.0, abs_tol=0.05)  # degree


def test_surface_family_labels_each_inclination():
    ds = scene_dataset(resolve("surface_family"))
    classes = dict(zip(ds.inclination.values.tolist(), ds.surface_class.values.tolist(),
                       strict=True))
    assert classes[0.0] == "annulus" and classes[45.0] == "cone" and classes[90.0] == "cylinder"
    assert ds.sizes["inclination"] == 91
    assert math.isclose(float(ds.phase_a), 29.0) and ds.phase_a.attrs["units"] == "degree"
