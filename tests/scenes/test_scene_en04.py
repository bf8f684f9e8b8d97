"""The EN-04 scene (docs/studies.md "EN-04", README "Scenes"): the fastest carried closed loop
beside the open-loop quintic at its boundary, read from the study's control dataset exactly
as the study recorded it; refused configs and inputs in one line; the page draws the sphere
where the dataset puts it and shows the lead and the pattern speed.

One cut-down EN-04 control dataset (one controller, a coarse bisection, 8 s runs) is computed
for the module; the scene's sphere centre and phi_a must be that dataset's, bit for bit up to
1e-12.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from inproc import run_cli

from creatio.errors import ConfigError
from creatio.pipeline.config import resolve as resolve_study
from creatio.scenes.config import resolve, route

#: A cut-down EN-04 control: the fastest controller of the default grid alone, 8 s runs, the
#: quintic boundary to 0.5 s, one trapezoid and one robustness point.
SMALL = ["study.control.duration=8.0", "study.control.omega_max=[2.0]",
         "study.control.delta_max_deg=[20.0]", "study.control.omega_c=[4.0]",
         "study.control.omega_n=[20.0]", "study.control.quintic.hi=8.0",
         "study.control.quintic.tol=0.5", "study.control.trapezoid.omega_max=[1.5]",
         "study.control.trapezoid.a_max=[1.5]", "study.control.robustness.mus=[0.15]",
         "study.control.robustness.mass_factors=[1.0]"]


def _scene_overrides() -> list[str]:
    return route("en04", SMALL)[0]


@pytest.fixture(scope="module")
def control(tmp_path_factory) -> Path:
    """The cut-down EN-04 control dataset, written as the study's rule writes it."""
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    out = tmp_path_factory.mktemp("en04") / "en04_control.nc"
    return write_dataset(run_study(resolve_study("en04", SMALL), "en04_control"), out)


@pytest.fixture(scope="module")
def scene(control, tmp_path_factory, library) -> Path:
    """The scene's dataset and page from that dataset."""
    from creatio.scenes.run import write_page, write_scene_dataset

    d = tmp_path_factory.mktemp("scene_en04")
    write_scene_dataset(resolve("en04", _scene_overrides()), d / "scene.nc",
                        {"en04": control})
    write_page(d / "scene.nc", d / "index.html", library)
    return d


def test_the_scene_config_is_the_studys_and_names_its_dataset():
    """The config under bases.en04 resolves exactly as the study (its hash names the dataset
    read), overrides of the study reach it, and the plan waits for that dataset."""
    from creatio.scenes.plan import SceneRuns

    r = resolve("en04", _scene_overrides())
    assert r.bases["en04"].sha256 == resolve_study("en04", SMALL).sha256
    routed, used = route("en04", ["bases.en02.sphere.mu=0.2", "sphere.mu=0.3"])
    assert routed == ["bases.en04.bases.en02.sphere.mu=0.2"]
    assert used == ["bases.en02.sphere.mu=0.2"]
    plan = SceneRuns(None, ["en04"]).plans["en04"]
    assert plan.reuse() == {"en04": "data/studies/en04/en04_control.nc"}
    over = SceneRuns(["bases.en02.sphere.mu=0.2"], ["en04"]).plans["en04"]
    key = resolve_study("en04", ["bases.en02.sphere.mu=0.2"]).key
    assert over.reuse() == {"en04": f"data/runs/{key}/studies/en04/en04_control.nc"}
    # `snakemake scenes` without a selection leaves it to its study's target
    assert "en04" not in SceneRuns(None).scenes


def test_the_scene_draws_the_studys_own_runs(scene, control):
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(scene / "scene.nc")
    src, _ = read_dataset(control)
    fastest = int(src.attrs["fastest_case"])
    assert bool(src.carried.values[fastest])
    names = [str(p) for p in src.path.values]
    step = round(ds.attrs["frame_interval"] / (src.time.values[1] - src.time.values[0]))
    assert step == 2
    for r, name in enumerate(("closed_loop", "quintic")):
        p = names.index(name)
        np.testing.assert_allclose(ds.centre.values[r], src.path_centre.values[p, ::step],
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(ds.phase_a.values[r], src.path_phase_a.values[p, ::step],
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(ds.lead.values[r], src.path_lead.values[p, ::step],
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(ds.pattern_speed.values[r],
                                   src.path_pattern_speed.values[p, ::step], rtol=0, atol=1e-12)
        assert np.isfinite(ds.centre.values[r]).all()
    assert ds.attrs["en04_open_loop_boundary_T"] == src.attrs["open_loop_boundary_T"]
    assert [str(x) for x in ds.run.values] == ["closed loop", "open loop"]


def test_the_recorded_path_is_the_runs_own(control):
    """path_centre and path_phase_a are the run's own rows: the quintic boundary run redone
    from its law gives the same centre and phase at the path's times (the control part's
    runs are deterministic), and the phase is the law's value there."""
    import math

    from creatio.dynamics import simulate
    from creatio.model.laws import Law
    from creatio.model.surface import Motion
    from creatio.store.netcdf import read_dataset

    src, _ = read_dataset(control)
    cfg = resolve_study("en04", SMALL).obj
    c = cfg.study.control
    base = cfg.bases[c.base]
    Ka = float(base.geometry.Ka)
    T = float(src.attrs["open_loop_boundary_T"])
    nominal = base.sphere_problem().replace(t_end=c.duration, dt=base.solver.dt,
                                            interval=base.solver.dt)
    motion = nominal.model.motion
    pa0 = float(motion.phi_a.scalar(0.0)[0])
    law = Law.quintic(pa0, -Ka * math.radians(c.theta_goal_deg), T)
    res = simulate(nominal.replace(motion=Motion(motion.phi_r, law, motion.gamma)))
    p = [str(x) for x in src.path.values].index("quintic")
    k = np.rint(src.time.values / base.solver.dt).astype(int)
    np.testing.assert_allclose(src.path_centre.values[p], res.histories.X[k], rtol=0, atol=1e-12)
    np.testing.assert_allclose(src.path_phase_a.values[p], np.degrees(law(src.time.values).value),
                               rtol=0, atol=1e-9)


def test_a_dataset_of_another_config_is_refused(control, tmp_path):
    from creatio.scenes.run import write_scene_dataset

    other = resolve("en04", route("en04", [*SMALL, "study.control.arrival_tol_deg=3.0"])[0])
    with pytest.raises(ConfigError, match="is not the control dataset"):
        write_scene_dataset(other, tmp_path / "scene.nc", {"en04": control})
    with pytest.raises(ConfigError, match="--reuse en04="):
        write_scene_dataset(other, tmp_path / "scene.nc", {})


@pytest.mark.parametrize(("override", "key"), [
    ("scene.playback.fps=7", "scene.playback"),            # 1/7 s: not on the 0.02 s paths
    ("scene.playback.speed=0.6", "scene.playback"),        # 0.024 s frames
    ("scene.readouts=[time,lead,lead]", "scene.readouts"),
    ("study.control.omega_c=[-1.0]", "bases.en04.study.control.omega_c[0]"),
])
def test_refused_scene_configs(override, key):
    with pytest.raises(ConfigError) as e:
        resolve("en04", route("en04", [override])[0])
    assert e.value.key == key and "\n" not in str(e.value)


def test_a_refused_scene_config_is_one_line_exit_2(tmp_path):
    proc = run_cli("task", "scene", "dataset", "en04", str(tmp_path / "scene.nc"),
                   "--override", "scene.playback.fps=7")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "scene.playback" in lines[0] and "path_interval" in lines[0]
    assert not (tmp_path / "scene.nc").exists()


def test_the_page_draws_the_dataset_at_the_chosen_time(scene, need_chromium):
    from chromium import Browser

    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(scene / "scene.nc")
    t = 3.0
    with Browser(width=1280, height=800) as b:
        b.open((scene / "index.html").resolve().as_uri() + f"#t={t}", settle=0.8)
        errors = b.errors() + [f"page: {e}" for e in b.evaluate("window.creatioErrors")]
        assert not errors, "\n".join(map(str, errors))
        state = json.loads(b.evaluate("document.getElementById('scene-state').textContent"))
        rows = b.evaluate("[...document.querySelectorAll('#readouts tr[data-readout]')]"
                          ".map(tr => [tr.dataset.readout, [...tr.children].map("
                          "td => td.textContent)])")
    k = int(np.argmin(np.abs(ds.time.values - t)))
    assert state["frame"] == k and state["weight"] == 0
    for r, run in enumerate(ds.run.values):
        drawn = state["runs"][str(run)]["drawn"]
        np.testing.assert_allclose(drawn, ds.centre.values[r, k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(state["runs"][str(run)]["phases"][1],
                                   np.radians(ds.phase_a.values[r, k]), rtol=0, atol=1e-12)
    shown = dict(rows)
    assert set(shown) == {"time", "lead", "pattern_speed", "travel", "load_power"}
    for key in ("lead", "pattern_speed"):
        label, *values, unit = shown[key]
        assert label == ds[key].attrs["long_name"]
        # the page prints the dataset's value at that frame (fmt: a few significant digits)
        for r, text in enumerate(values):
            assert float(text) == pytest.approx(float(ds[key].values[r, k]), rel=1e-3, abs=1e-9)


def test_beyond_builds_the_scene_after_its_studys_dataset(tmp_path):
    """`snakemake beyond` with EN-04 plans the scene under the same overrides, its frames job
    (whose frames.nc its dataset job reads) waiting for the study's control dataset of that
    config; `snakemake scenes` without a selection leaves it out."""
    import re

    repo = Path(__file__).resolve().parents[2]

    def dry(*args: str) -> str:
        proc = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(repo / "Snakefile"),
                               "-d", str(tmp_path), "-c", "1", "-n", *args],
                              capture_output=True, text=True, timeout=600, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr[-3000:]
        return proc.stdout + proc.stderr

    out = dry("beyond", "--config", 'studies=["en04"]',
              'overrides=["bases.en02.sphere.mu=0.2"]')
    study = resolve_study("en04", ["bases.en02.sphere.mu=0.2"]).key
    scene = resolve("en04", ["bases.en04.bases.en02.sphere.mu=0.2"]).key
    inputs = re.search(rf"input: (.*)\n\s+output: data/runs/{scene}/scenes/en04/frames.nc", out)
    assert inputs is not None, out[-3000:]
    assert f"data/runs/{study}/studies/en04/en04_control.nc" in inputs.group(1).split(", ")
    dataset = re.search(rf"input: (.*)\n\s+output: data/runs/{scene}/scenes/en04/scene.nc", out)
    assert dataset is not None, out[-3000:]
    assert f"data/runs/{scene}/scenes/en04/frames.nc" in dataset.group(1).split(", ")
    assert "scenes/en04/" not in dry("scenes")
