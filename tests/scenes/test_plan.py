"""What a scene computes is planned from what it draws: frame times only, no energy, no
dt / 2 partner, rotation only when the marker, band or spin is drawn; a study dataset that
holds the frames is reused."""

from __future__ import annotations

from creatio.scenes.config import resolve
from creatio.scenes.needs import needs
from creatio.scenes.plan import reusable
from creatio.studies.schema import vary


def test_a_sphere_scene_asks_for_frames_and_rotation_but_no_energy():
    (need,) = needs(resolve("en02"))
    assert need.outputs == ("trajectory", "rotation")
    assert need.interval == 0.4 and need.dt == 0.002 and need.frames == 301
    base = resolve("en02").obj.bases["en02"]
    problem = vary(base, need.changes()).sphere_problem()
    assert problem.output.energy is False
    assert problem.rotation_integrated
    assert problem.output.interval == 0.4
    assert len(problem.initial_state(True, False)) == 12  # 4 + rotation 8, no energy 2


def test_a_scene_that_draws_no_orientation_leaves_rotation_to_the_physics():
    runs = needs(resolve("compare"))
    assert [n.outputs for n in runs] == [("trajectory",), ("trajectory",)]
    base = resolve("compare").obj.bases["en02"]
    # mu > 0 couples the spin to the path: the core integrates it anyway
    assert vary(base, runs[0].changes()).sphere_problem().rotation_integrated
    frictionless = vary(base, {**runs[0].changes(), "sphere.mu": 0.0})
    assert not frictionless.sphere_problem().rotation_integrated


def test_kinematic_scenes_run_no_dynamics():
    assert needs(resolve("surface_family")) == [] == needs(resolve("velocity_normal"))


def test_a_study_dataset_is_reused_only_when_it_exists_and_holds_the_frames(tmp_path):
    r = resolve("en02")
    (need,) = needs(r)
    base = r.bases["en02"]
    assert reusable(base, need, tmp_path) is None
    path = tmp_path / "studies" / "en02" / "en02_dt0.002.nc"
    path.parent.mkdir(parents=True)
    path.write_bytes(b"")
    assert reusable(base, need, tmp_path) == str(path)
    # frames every 8 / 32 = 0.25 s: off the study's 0.1 s output grid, so its dataset does
    # not hold them (the scene alone: twice the frames would take its mu x T family's page
    # past its size limit)
    r2 = resolve("en02", ["scene.playback.fps=32", "~scene.axes.sphere", "~scene.axes.phases"])
    (need2,) = needs(r2)
    assert reusable(r2.bases["en02"], need2, tmp_path) is None


def test_a_beyond_study_builds_the_scenes_that_read_it_or_are_built_with_it():
    """EN-04's scene reads its datasets, EN-06's is built with it; EN-02F has none."""
    from creatio.scenes.plan import scenes_of

    assert scenes_of(["en04"]) == ["en04"]
    assert scenes_of(["en06"]) == ["en06"]
    assert scenes_of(["en02f"]) == []
    assert sorted(scenes_of(["en04", "en06"])) == ["en04", "en06"]
