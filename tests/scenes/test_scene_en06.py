"""The EN-06 scene (docs/scenes.md "EN-06: the membrane coloured by strain"): the EN-02
membrane coloured by its largest principal Green-Lagrange strain, with the sphere it carries.

The strain the scene stores at each mesh vertex and frame is checked against the closed form
of a flat (gamma = 0) corrugated annulus, whose strain tensor is rank one,
eps = 1/2 (W_R, W_alpha / rho) (x) (W_R, W_alpha / rho), so its largest principal value is
1/2 (W_R^2 + (W_alpha / rho)^2), and against creatio.model.strain at the same points; the
page's 16-bit codes against the dataset; the legend against the data; the family and the
workflow against what the scene declares.
"""

from __future__ import annotations

import base64
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.errors import ConfigError
from creatio.model.strain import strains
from creatio.model.surface import Motion
from creatio.scenes import registry
from creatio.scenes.config import resolve, route
from creatio.scenes.strain import legend_range, mesh_coordinates, with_strain

#: A short EN-02 cycle (12 s, 15 frames of 0.8 s) for the tests that run the sphere.
SHORT = ["bases.en02.phases.T=12"]


def _frames_only(resolved, n: int | None = None) -> xr.Dataset:
    """The coordinates with_strain reads (the runs and the frame times) of a scene config."""
    s = resolved.obj.scene
    base = resolved.obj.bases["en02"]
    count = round(base.study.duration / s.playback.interval) + 1 if n is None else n
    times = np.arange(count) * s.playback.interval
    return xr.Dataset(coords={"run": ("run", ["en02"]), "time": ("frame", times)})


@pytest.fixture(scope="module")
def default():
    """The scene's default config and its strain over every frame (no sphere run)."""
    r = resolve("en06")
    return r, with_strain(_frames_only(r), r.obj)


def test_the_plan_says_what_the_scene_draws():
    """One EN-02 run, frames every 0.8 s with the orientation (marker, band) and no energy;
    the membrane coloured by the mid-surface strain; built by `snakemake scenes`."""
    from creatio.scenes.needs import needs
    from creatio.scenes.plan import SceneRuns

    r = resolve("en06")
    assert r.entry.kind is registry.STRAIN and r.entry.kind.runs
    s = r.obj.scene
    assert [str(x) for x in s.draw] == ["membrane", "sphere", "marker", "band", "trace"]
    assert s.strain.thickness == 0.0
    (need,) = needs(r)
    assert (need.study, need.outputs) == ("en02", ("trajectory", "rotation"))
    assert need.interval == pytest.approx(0.8) and need.duration == 120.0
    assert need.frames == 151
    assert "en06" in SceneRuns(None).scenes
    # the config under bases.en02 is EN-02's own: its dataset can be read instead of run
    from creatio.pipeline.config import resolve as resolve_study

    assert r.bases["en02"].sha256 == resolve_study("en02").sha256


def test_strain_colours_are_the_closed_form_and_the_models_at_sampled_vertices(default):
    r, ds = default
    base = r.obj.bases["en02"]
    g = base.geometry
    n_alpha, n_R = r.obj.scene.mesh.n_alpha, r.obj.scene.mesh.n_R
    assert ds.strain.dims == ("run", "frame", "mesh_alpha", "mesh_R")
    assert ds.strain.shape == (1, 151, n_alpha, n_R)
    laws = base.phases.laws()
    surface, motion = g.surface(), Motion(*laws)
    k = 2.0 * math.pi * g.Kr / g.dR
    rng = np.random.default_rng(6)
    for f, i, j in zip(rng.integers(0, 151, 40), rng.integers(0, n_alpha, 40),
                       rng.integers(1, n_R, 40), strict=True):
        t = float(ds.time.values[f])
        alpha, R = 2.0 * math.pi * i / (n_alpha - 1), g.dR * j / (n_R - 1)
        phr, pha, gam = (float(law(t).value) for law in laws)
        assert gam == 0.0  # EN-02 is flat: the rank-one closed form applies
        W_R = g.A * k * math.cos(k * R + phr) * math.cos(g.Ka * alpha + pha)
        W_a = -g.A * g.Ka * math.sin(k * R + phr) * math.sin(g.Ka * alpha + pha)
        closed = 0.5 * (W_R**2 + (W_a / (g.R0 + R)) ** 2)
        stored = float(ds.strain.values[0, f, i, j])
        assert stored == pytest.approx(closed, rel=1e-12, abs=1e-15)
        model = strains(surface, motion, alpha, R, t).membrane.principal()[0]
        assert stored == pytest.approx(float(model), rel=1e-14, abs=1e-16)
    a, R = mesh_coordinates(n_alpha, n_R, g.dR)
    np.testing.assert_array_equal(ds.mesh_alpha.values, a)
    np.testing.assert_array_equal(ds.mesh_R.values, R)


def test_the_face_strain_of_a_thick_sheet_is_the_models():
    """scene.strain.thickness = h colours the larger face's strain, eps -+ (h / 2) dkappa."""
    r = resolve("en06", route("en06", ["scene.strain.thickness=0.002"])[0])
    ds = with_strain(_frames_only(r, 4), r.obj)
    base = r.obj.bases["en02"]
    alpha, R = mesh_coordinates(r.obj.scene.mesh.n_alpha, r.obj.scene.mesh.n_R,
                                base.geometry.dR)
    st = strains(base.geometry.surface(), Motion(*base.phases.laws()), alpha[None, :, None],
                 R[None, None, :], ds.time.values[:, None, None], 0.002)
    upper, lower = st.upper.principal()[0], st.lower.principal()[0]
    np.testing.assert_allclose(ds.strain.values[0], np.maximum(upper, lower), rtol=1e-14,
                               atol=1e-16)
    assert "faces (h = 0.002 m)" in ds.strain.attrs["long_name"]
    # bending adds to the mid-surface strain somewhere: the faces' is not the membrane's
    assert np.max(np.maximum(upper, lower) - st.membrane.principal()[0]) > 1e-4


def test_the_legend_covers_the_data_on_round_ticks(default):
    _, ds = default
    low, high = json.loads(ds.attrs["strain_legend"])
    ticks = json.loads(ds.attrs["strain_ticks"])
    values = ds.strain.values
    assert low <= values.min() and values.max() <= high
    step = ticks[1] - ticks[0]
    assert ticks[0] == low and ticks[-1] == pytest.approx(high)
    np.testing.assert_allclose(np.diff(ticks), step, rtol=1e-9)
    assert high - values.max() < step  # not wider than one step beyond the data
    assert ds.attrs["strain_max"] == values.max() and ds.strain.attrs["units"] == "1"
    # the rounding on known data: from 0 for non-negative values, outward otherwise
    assert legend_range(np.array([0.0, 0.503])) == (0.0, 0.6, [0.0, 0.2, 0.4, 0.6])
    assert legend_range(np.array([0.012, 0.0349])) == (0.0, 0.04, [0.0, 0.01, 0.02, 0.03,
                                                                   0.04])
    assert legend_range(np.array([-0.013, 0.02])) == (-0.02, 0.02, [-0.02, -0.01, 0.0, 0.01,
                                                                    0.02])
    low0, high0, _ = legend_range(np.zeros(3))  # no corrugation: a legend all the same
    assert low0 == 0.0 < high0


def test_the_page_carries_the_strain_within_half_a_code(default):
    from creatio.scenes.page import CODES, page_data

    _, ds = default
    ds = ds.assign_attrs(kind="sphere")  # the rest of a sphere scene's page is not read here
    sent = page_data(ds)["arrays"]["strain"]
    low, high = sent["low"], sent["high"]
    codes = np.frombuffer(base64.b64decode(sent["u16"]), "<u2")
    assert sent["shape"] == list(ds.strain.shape)
    decoded = (low + codes * (high - low) / CODES).reshape(sent["shape"])
    assert np.max(np.abs(decoded - ds.strain.values)) <= (high - low) / CODES / 2 * (1 + 1e-9)
    attrs = page_data(ds)["attrs"]
    assert attrs["strain_legend"] == [low, high]
    assert attrs["strain_ticks"][-1] == pytest.approx(high)
    # a value outside the legend cannot be coded
    from creatio.scenes.page import _coded

    with pytest.raises(ValueError, match="outside"):
        _coded(np.array([[[0.0, 2.0]]]), [0.0, 1.0])
    # NaN (frames padded for a longer member) has its own code, above the range's
    nan = _coded(np.array([[[0.0, np.nan, 1.0]]]), [0.0, 1.0])
    assert np.frombuffer(base64.b64decode(nan["u16"]), "<u2").tolist() == [0, CODES + 1, CODES]


def test_the_family_axis_lists_its_values_with_the_scenes_own():
    """The strain scene is explorable as every sphere scene: an axis lists its values and the
    scene's own (inserted), one member each, planned before anything runs."""
    from creatio.scenes.family import family_of

    r = resolve("en06", route("en06", ["scene.axes={sphere.mu:'0.05,0.3'}"])[0])
    fam = family_of(r)
    (axis,) = fam.axes
    assert axis.key == "sphere.mu" and axis.labels == ("0.05", "0.15", "0.3")
    assert axis.inserted and fam.base_member == 1 and fam.size == 3
    assert axis.studies == ("en02",)


@pytest.mark.parametrize("value", ["-0.001", "nan", "inf", "0.06", "thick"])
def test_a_bad_thickness_is_refused_in_one_line(value):
    with pytest.raises(ConfigError) as e:
        resolve("en06", route("en06", [f"scene.strain.thickness={value}"])[0])
    assert e.value.key == "scene.strain.thickness" and "\n" not in str(e.value)


def test_a_scene_that_draws_no_membrane_is_refused():
    with pytest.raises(ConfigError, match="must draw the membrane") as e:
        resolve("en06", route("en06", ["scene.draw=[sphere,trace]"])[0])
    assert e.value.key == "scene.draw"


def test_a_refused_config_exits_2_in_one_line_and_writes_nothing(tmp_path, capsys):
    from creatio.scenes.cli import main

    out = tmp_path / "frames.nc"
    assert main(["frames", "en06", str(out), "--override", "scene.strain.thickness=-1"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "scene.strain.thickness" in lines[0] and "-1" in lines[0]
    assert not out.exists() and not any(tmp_path.iterdir())


@pytest.fixture(scope="module")
def built(tmp_path_factory, library) -> Path:
    """The scene on a 12 s cycle: its dataset (the sphere run computed here), page and
    media; a family over mu (the same surface and phases) and the cycle T (other phases)."""
    from creatio.scenes.run import build_scene

    d = tmp_path_factory.mktemp("scene_en06")
    overrides = [*SHORT, "scene.media.every=5", "scene.axes={sphere.mu:'0.05,0.15',"
                 "phases.T:'8,12'}"]
    build_scene(resolve("en06", route("en06", overrides)[0]), d, library,
                store=d / "members")
    return d


@pytest.mark.long
def test_the_built_scene_holds_the_run_and_its_strain(built):
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(built / "scene.nc")
    assert ds.attrs["kind"] == "sphere" and ds.sizes["frame"] == 16
    assert ds.strain.shape == (1, 16, 145, 21)
    assert np.isfinite(ds.centre.values).all() and "quaternion" in ds
    low, high = json.loads(ds.attrs["strain_legend"])
    assert low <= float(ds.strain.min()) and float(ds.strain.max()) <= high
    for name in ("index.html", "animation.webp", "poster.png"):
        assert (built / name).stat().st_size > 0
    # the poster's colour bar and membrane use the legend's colours: its darkest red shows
    from PIL import Image

    from creatio.scenes.strain import STRAIN_COLOURS

    rgb = np.asarray(Image.open(built / "poster.png").convert("RGB"), float) / 255
    top = np.array(STRAIN_COLOURS[-1])
    assert np.min(np.abs(rgb - top).sum(axis=-1)) < 0.03


@pytest.mark.long
def test_the_page_colours_the_drawn_vertices_by_the_datasets_strain(built, need_chromium):
    from chromium import Browser

    from creatio.scenes.page import CODES
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(built / "scene.nc")
    t = 4.0
    with Browser(width=1200, height=900) as b:
        b.open((built / "index.html").resolve().as_uri() + f"#t={t}", settle=0.8)
        errors = b.errors() + [f"page: {e}" for e in b.evaluate("window.creatioErrors")]
        assert not errors, "\n".join(map(str, errors))
        state = json.loads(b.evaluate("document.getElementById('scene-state').textContent"))
        legend = b.evaluate("[...document.querySelectorAll('.strain-ticks span')]"
                            ".map(s => s.textContent)")
    k = int(np.argmin(np.abs(ds.time.values - t)))
    assert state["frame"] == k and state["weight"] == 0
    run = state["runs"]["en02"]
    assert run["colour"] == "strain"
    low, high = json.loads(ds.attrs["strain_legend"])
    n_alpha, n_R = ds.sizes["mesh_alpha"], ds.sizes["mesh_R"]
    for probe, value in zip(run["surface"], run["strain"], strict=True):
        i = round(probe["alpha"] / (2 * math.pi) * (n_alpha - 1))
        j = round(probe["R"] / float(ds.dR.values[0]) * (n_R - 1))
        assert value == pytest.approx(float(ds.strain.values[0, k, i, j]),
                                      abs=(high - low) / CODES)
    ticks = json.loads(ds.attrs["strain_ticks"])
    assert legend == [f"{100 * x:g} %" for x in ticks]


@pytest.mark.long
def test_a_member_is_coloured_by_strain_only_on_the_scenes_own_surface_and_phases(
        built, need_chromium):
    """Another mu moves the sphere, not the membrane: its member keeps the strain colours;
    another cycle T moves the membrane otherwise: its member is coloured by height."""
    from chromium import Browser

    colours = {}
    with Browser(width=1200, height=900) as b:
        for mu, T in (("0.05", "12"), ("0.15", "8"), ("0.15", "12")):
            b.open((built / "index.html").resolve().as_uri()
                   + f"#t=4&sphere.mu={mu}&phases.T={T}", settle=0.8)
            errors = b.errors() + [f"page: {e}" for e in b.evaluate("window.creatioErrors")]
            assert not errors, "\n".join(map(str, errors))
            state = json.loads(b.evaluate(
                "document.getElementById('scene-state').textContent"))
            assert state["values"] == {"sphere.mu": mu, "phases.T": T}
            colours[mu, T] = state["runs"]["en02"]["colour"]
    assert colours == {("0.05", "12"): "strain", ("0.15", "8"): "height",
                       ("0.15", "12"): "strain"}


@pytest.mark.long
def test_the_dry_run_names_the_scenes_jobs(tmp_path):
    """`snakemake scenes --config 'scenes=["en06"]'` plans the scene's config, frames,
    dataset, page and media (and the three.js bundle), and the rib-count family's two batch
    jobs (six members); with no EN-02 dataset to read, no study job: the frames job runs the
    sphere itself."""
    import re

    repo = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-s", str(repo / "Snakefile"),
                           "-d", str(tmp_path), "-c", "1", "-n", "scenes", "--config",
                           'scenes=["en06"]'], capture_output=True, text=True, timeout=600,
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout + proc.stderr
    jobs = dict(re.findall(r"^(\w+)\s+(\d+)$", out, flags=re.M))
    assert jobs == {"scene_config": "1", "scene_frames": "1", "scene_dataset": "1",
                    "scene_page": "1", "scene_media": "1", "scene_library": "1",
                    "scene_family_batch": "2", "scenes": "1", "total": "9"}, out[-3000:]
    assert "data/scenes/en06/family/b3-00000.nc" in out
    for name in ("scene.nc", "index.html", "animation.webp", "poster.png"):
        assert f"data/scenes/en06/{name}" in out


def test_a_rib_surface_gives_its_splines_at_the_mesh_angles_and_the_ideal_none():
    """skin_rows: cos and sin(Ka alpha) on the ideal surface; on N exact ribs the splines
    through the ribs' samples, so at a rib's angle the wave's own value (the nodes are
    exact). A scene of the ideal surface carries no splines (its dataset is unchanged)."""
    import dataclasses

    from creatio.model.ribs import Ribs, alias_amplitudes
    from creatio.scenes.compute import skin_rows

    ideal = resolve("en06").obj.bases["en02"].geometry.surface()
    n_alpha = 145  # 144 intervals: every 8th mesh angle is one of 18 ribs
    alpha = 2.0 * math.pi * np.arange(n_alpha) / (n_alpha - 1)
    c, s = skin_rows(ideal, n_alpha)
    np.testing.assert_allclose(c, np.cos(6 * alpha), rtol=0, atol=1e-15)
    ribs = dataclasses.replace(ideal, ribs=Ribs(18))
    c, s = skin_rows(ribs, n_alpha)
    np.testing.assert_allclose(c[::8], np.cos(6 * alpha[::8]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(s[::8], np.sin(6 * alpha[::8]), rtol=0, atol=1e-12)
    # between ribs the skin is the wave plus its aliases, sum_m h_m cos((Ka + m N) alpha):
    # off by at most |1 - h_0| + sum_{m != 0} h_m, and by far more than rounding
    m = np.arange(-200, 201)
    h = alias_amplitudes(18, 6, m)
    bound = abs(1.0 - h[m == 0][0]) + h[m != 0].sum()
    between = np.abs(c[4::8] - np.cos(6 * alpha[4::8]))
    assert 1e-3 < between.max() <= bound + 1e-12
    ds = with_strain(_frames_only(resolve("en06"), 2), resolve("en06").obj)
    assert "skin_c" not in ds


def test_family_members_carry_their_splines_and_the_ideal_ones_nan():
    from creatio.scenes.family import assemble

    def member_ds(skin: bool) -> xr.Dataset:
        frame = {"centre": (("run", "frame", "component"), np.zeros((1, 2, 3)))}
        frame.update({v: (("run", "frame"), np.zeros((1, 2)))
                      for v in ("phase_r", "phase_a", "inclination")})
        scalars = {v: ("run", [1.0]) for v in ("frames_run", "stop_time", "sphere_radius",
                                               "R0", "dR", "A", "Kr", "Ka", "final_radius",
                                               "final_lag", "final_cumulative_spin",
                                               "min_normal_reaction")}
        texts = {v: ("run", ["ok"]) for v in ("status", "direction", "source")}
        ds = xr.Dataset({**frame, **scalars, **texts})
        if skin:
            ds["skin_c"] = (("run", "mesh_alpha"), np.full((1, 5), 0.5))
            ds["skin_s"] = (("run", "mesh_alpha"), np.full((1, 5), -0.5))
        return ds

    out = assemble([(0, member_ds(False), ""), (1, member_ds(True), ""), (2, None, "no")],
                   ["en02"], 2, False, [])
    assert out.skin_c.dims == ("member", "run", "mesh_alpha")
    assert np.isnan(out.skin_c.values[0]).all() and np.isnan(out.skin_c.values[2]).all()
    np.testing.assert_array_equal(out.skin_s.values[1], -0.5)
    assert "skin_c" not in assemble([(0, member_ds(False), "")], ["en02"], 2, False, [])


@pytest.mark.long
def test_the_page_draws_a_rib_surface_from_its_splines(built, tmp_path, library,
                                                       need_chromium):
    """A run on 18 ribs: the page's vertices are the model's rib surface (W_N, not the
    ideal W), to the float32 of the drawn vertices."""
    import dataclasses

    from chromium import Browser

    from creatio.model.ribs import Ribs
    from creatio.model.surface import Frame
    from creatio.scenes.compute import skin_rows
    from creatio.scenes.page import write_page
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(built / "scene.nc")
    r = resolve("en06", route("en06", SHORT)[0])
    base = r.obj.bases["en02"]
    surface = dataclasses.replace(base.geometry.surface(), ribs=Ribs(18))
    c, s = skin_rows(surface, ds.sizes["mesh_alpha"])
    ds["skin_c"] = (("run", "mesh_alpha"), c[None, :])
    ds["skin_s"] = (("run", "mesh_alpha"), s[None, :])
    page = write_page(ds, tmp_path / "index.html", library)
    with Browser(width=1200, height=900) as b:
        b.open(page.resolve().as_uri() + "#t=4", settle=0.8)
        errors = b.errors() + [f"page: {e}" for e in b.evaluate("window.creatioErrors")]
        assert not errors, "\n".join(map(str, errors))
        state = json.loads(b.evaluate("document.getElementById('scene-state').textContent"))
    motion = Motion(*base.phases.laws())
    ideal = base.geometry.surface()
    apart = 0.0
    for probe in state["runs"]["en02"]["surface"]:
        rib = Frame(surface, motion, probe["alpha"], probe["R"], 4.0).position
        # the drawn vertices are float32 (as test_browser.py's): 2e-6 on a 2.4 m annulus
        np.testing.assert_allclose(probe["xyz"], rib, rtol=0, atol=2e-6)
        wave = Frame(ideal, motion, probe["alpha"], probe["R"], 4.0).position
        apart = max(apart, float(np.max(np.abs(rib - wave))))
    assert apart > 1e-4  # the probes tell the rib surface from the ideal one


def test_the_rib_count_axis_lists_its_counts_then_the_ideal_surface():
    """The scene's axis over geometry.ribs: one member on each rib count, the scene's own
    ideal surface (ribs null) last, named so; N <= 2 Ka refused as the config refuses it."""
    from creatio.scenes.family import family_of, member

    r = resolve("en06")
    fam = family_of(r)
    (axis,) = fam.axes
    assert axis.key == "geometry.ribs" and axis.studies == ("en02",)
    assert axis.labels == ("18", "24", "36", "48", "72", "ideal")
    assert axis.values == (18, 24, 36, 48, 72, None) and fam.base_member == 5
    for i, n in enumerate((18, 24, 36, 48, 72)):
        geometry = member(r, fam, i).obj.bases["en02"].geometry
        assert geometry.ribs == n and geometry.surface().ribs.N == n
    assert member(r, fam, 5).obj.bases["en02"] == r.obj.bases["en02"]
    low = resolve("en06", route("en06", ["scene.axes.geometry.ribs=12,36"])[0])
    refused = member(low, family_of(low), 0)
    assert refused.obj is None and "geometry.ribs" in refused.refused and "2 Ka" in \
        refused.refused


def test_a_family_whose_page_the_strain_field_would_overfill_is_refused_before_running():
    """The page's size estimate counts the strain field (2 bytes a vertex and frame, base64):
    200 x 100 vertices over 151 frames (8.1 MB) cannot fit, whatever the members add."""
    overrides = ["scene.mesh.n_alpha=200", "scene.mesh.n_R=100"]
    with pytest.raises(ConfigError, match=r"page would be about 8\.\d MB") as e:
        resolve("en06", route("en06", overrides)[0])
    assert e.value.key == "scene.axes"
    assert resolve("en06").obj.scene.extra_page_bytes(1, 151) == math.ceil(
        151 * 145 * 21 * 8 / 3)
