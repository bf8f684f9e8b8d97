"""Scene configs: every scene composes and validates, overrides travel as for studies, and a
scene's studies resolve exactly as the studies themselves (the key of reuse)."""

from __future__ import annotations

import pytest

from creatio.errors import ConfigError
from creatio.pipeline.config import resolve as resolve_study
from creatio.scenes import registry
from creatio.scenes.config import resolve, route
from creatio.scenes.plan import SceneRuns


@pytest.mark.parametrize("scene", list(registry.SCENES))
def test_every_scene_composes_and_validates(scene):
    r = resolve(scene)
    assert r.id == scene and r.obj.scene.id == scene
    assert len(r.sha256) == 64


@pytest.mark.parametrize("scene", ["en02", "en02r", "compare"])
def test_a_scenes_study_resolves_as_the_study_itself(scene):
    r = resolve(scene)
    for name, base in r.bases.items():
        assert base.sha256 == resolve_study(name).sha256


def test_overrides_reach_the_bases_and_the_kinematic_scenes():
    routed, used = route("compare", ["sphere.mu=0.3", "geometry.A=0.1"])
    assert routed == ["bases.en02.sphere.mu=0.3", "bases.en02r.sphere.mu=0.3",
                      "bases.en02.geometry.A=0.1", "bases.en02r.geometry.A=0.1"]
    assert used == ["sphere.mu=0.3", "geometry.A=0.1"]
    assert route("surface_family", ["sphere.mu=0.3", "geometry.A=0.1"]) == (
        ["geometry.A=0.1"], ["geometry.A=0.1"])
    r = resolve("en02", route("en02", ["sphere.mu=0.3"])[0])
    assert r.obj.bases["en02"].sphere.mu == 0.3
    assert r.bases["en02"].sha256 == resolve_study("en02", ["sphere.mu=0.3"]).sha256


def test_a_config_group_override_reaches_the_bases_group():
    routed, _ = route("en02", ["solver=radau5"])
    assert routed == ["solver@bases.en02.solver=radau5"]
    r = resolve("en02", routed)
    assert str(r.obj.bases["en02"].solver.method) == "radau5"
    assert r.bases["en02"].sha256 == resolve_study("en02", ["solver=radau5"]).sha256


def test_overridden_scenes_go_under_their_config_hash_and_unknown_keys_are_refused():
    plans = SceneRuns(["sphere.mu=0.3"]).plans
    assert plans["surface_family"].root == "data"
    assert plans["en02"].root == f"data/runs/{plans['en02'].resolved.key}"
    with pytest.raises(ConfigError, match="no selected scene has these keys"):
        _ = SceneRuns(["sphere.nonsense=1"]).plans


def test_a_frame_interval_that_does_not_divide_the_run_is_refused():
    with pytest.raises(ConfigError, match="must divide bases.en02.study.duration"):
        resolve("en02", ["scene.playback.fps=2.5"])  # 3.2 s frames
    with pytest.raises(ConfigError, match="multiple of bases.en02.solver.dt"):
        resolve("en02", ["scene.playback.fps=30000"])
