"""The pages as a person opens them, in a real browser (Debian's Chromium, headless): no
console error, a canvas that is not blank, and the sphere drawn where the dataset says.

Each page publishes what it drew last in #scene-state (positions from the three.js objects
themselves); the URL fragment sets the time (``#t=60``), the inclination or the mode.
Skipped where Chromium is missing; CI installs it.
"""

from __future__ import annotations

import io
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
from chromium import Browser

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def browser(need_chromium):
    with Browser(width=1280, height=800) as b:
        yield b


def _open(browser: Browser, page: Path, fragment: str) -> dict:
    browser.messages.clear()
    browser.open(page.resolve().as_uri() + fragment, settle=0.8)
    errors = browser.errors() + [f"page: {e}" for e in browser.evaluate("window.creatioErrors")]
    assert not errors, "\n".join(map(str, errors))
    return json.loads(browser.evaluate("document.getElementById('scene-state').textContent"))


def _canvas_statistics(browser: Browser) -> list[tuple[float, float]]:
    """(share of non-white pixels, grey-level standard deviation) inside each canvas."""
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("L"), float)
    rects = browser.evaluate("[...document.querySelectorAll('.view > canvas:not(.triad)')]"
                             ".map(c => { const r = c.getBoundingClientRect();"
                             "return [r.left, r.top, r.width, r.height]; })")
    out = []
    for x, y, w, h in rects:
        crop = img[int(y): int(y + h), int(x): int(x + w)]
        out.append((float(np.mean(crop < 245)), float(crop.std())))
    return out


def _assert_drawn(browser: Browser) -> None:
    stats = _canvas_statistics(browser)
    assert stats, "no canvas on the page"
    for covered, spread in stats:
        assert covered > 0.05 and spread > 10, f"blank canvas: {stats}"


@pytest.mark.parametrize("scene", ["en02", "en02r", "compare"])
def test_a_sphere_page_draws_the_dataset_at_the_chosen_time(browser, scenes, scene):
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(scenes[scene] / "scene.nc")
    t = 60.0
    state = _open(browser, scenes[scene] / "index.html", f"#t={t}")
    _assert_drawn(browser)
    k = int(np.argmin(np.abs(ds.time.values - t)))
    assert state["frame"] == k and state["weight"] == 0
    for r, run in enumerate(ds.run.values):
        drawn = state["runs"][str(run)]["drawn"]
        np.testing.assert_allclose(drawn, ds.centre.values[r, k], rtol=0, atol=1e-12)
        # the membrane under it is the model's surface at that frame's phases
        _assert_surface_is_the_models(state["runs"][str(run)]["surface"], ds, r, k)
    # between two frames the page interpolates; the readouts are the dataset's
    cells = browser.evaluate("[...document.querySelectorAll('#readouts tr[data-readout]')]"
                             ".map(tr => tr.dataset.readout)")
    assert set(cells) == {str(x) for x in json.loads(ds.attrs["readouts"])}


def _assert_surface_is_the_models(probe: list[dict], ds, r: int, k: int) -> None:
    from creatio.model.laws import Law
    from creatio.model.surface import Frame, Motion, Surface

    if "run" in ds.dims:
        geo = [float(ds[n].values[r]) for n in ("R0", "dR", "A", "Kr", "Ka")]
        ph = [math.radians(ds[n].values[r, k]) for n in ("phase_r", "phase_a", "inclination")]
    else:
        geo = [float(ds.attrs[n]) for n in ("R0", "dR", "A", "Kr", "Ka")]
        ph = [math.radians(ds[n].values[r, k]) for n in ("phase_r", "phase_a", "inclination")]
    surface = Surface(geo[0], geo[1], geo[2], int(geo[3]), int(geo[4]))
    motion = Motion(*(Law.constant(p) for p in ph))
    for v in probe:
        expected = Frame(surface, motion, v["alpha"], v["R"], 0.0).position
        # the page's mesh is float32 on the GPU side
        np.testing.assert_allclose(v["xyz"], expected, rtol=0, atol=2e-6)


def test_the_surface_family_page_follows_the_slider(browser, scenes):
    from creatio.model.laws import Law
    from creatio.model.surface import Frame, Motion, Surface
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(scenes["surface_family"] / "scene.nc")
    state = _open(browser, scenes["surface_family"] / "index.html", "#gamma=90")
    _assert_drawn(browser)
    assert state["inclination"] == 90 and state["surface_class"] == "cylinder"
    # move the slider as a person would: to the middle stop, then read what is drawn
    state = json.loads(browser.evaluate(
        "(() => { const s = document.getElementById('gamma'); s.value = '45';"
        "s.dispatchEvent(new Event('input')); "
        "return document.getElementById('scene-state').textContent; })()"))
    assert state["inclination"] == 45 and state["surface_class"] == "cone"
    a = ds.attrs
    surface = Surface(a["R0"], a["dR"], a["A"], int(a["Kr"]), int(a["Ka"]))
    motion = Motion(Law.constant(math.radians(ds.phase_r)), Law.constant(math.radians(ds.phase_a)),
                    Law.constant(math.radians(45)))
    for v in state["surface"]:
        np.testing.assert_allclose(v["xyz"], Frame(surface, motion, v["alpha"], v["R"], 0.0)
                                   .position, rtol=0, atol=2e-6)


@pytest.mark.parametrize("mode", ["angular", "radial", "oscillation"])
def test_the_velocity_normal_page_draws_the_point_normal_and_velocity(browser, scenes, mode):
    from creatio.store.netcdf import read_dataset

    ds, _ = read_dataset(scenes["velocity_normal"] / "scene.nc")
    m = list(ds["mode"].values).index(mode)
    k = 30
    t = float(ds.time.values[k])
    state = _open(browser, scenes["velocity_normal"] / "index.html",
                  f"#t={t!r}&mode={mode}&magnification=2")
    _assert_drawn(browser)
    assert state["mode"] == mode and state["frame"] == k
    p = ds.position.values[m, k]
    np.testing.assert_allclose(state["point"], p, rtol=0, atol=1e-12)
    normal_tip = p + ds.attrs["normal_length"] * ds.normal.values[m, k]
    np.testing.assert_allclose(state["normal_tip"], normal_tip, rtol=0, atol=1e-9)
    velocity = ds.velocity.values[m, k]
    expected = p + ds.attrs["velocity_scale"] * 2 * velocity
    np.testing.assert_allclose(state["velocity_tip"], expected, rtol=0, atol=1e-9)
    _assert_surface_is_the_models(state["surface"], ds, m, k)


def test_pages_are_offline_single_files_under_5_mb(scenes):
    for scene, d in scenes.items():
        text = (d / "index.html").read_text()
        assert (d / "index.html").stat().st_size <= 5 * 1024 * 1024, scene
        for needle in ('src="http', "src='http", 'href="http', "import(", "fetch(",
                       "XMLHttpRequest", "<link "):
            assert needle not in text, (scene, needle)


def test_playing_advances_the_clock(browser, scenes):
    _open(browser, scenes["en02"] / "index.html", "#t=10")
    t0 = json.loads(browser.evaluate("document.getElementById('scene-state').textContent"))
    browser.evaluate("document.getElementById('play').click()")
    t1 = browser.evaluate("new Promise(r => setTimeout(() => r(JSON.parse("
                          "document.getElementById('scene-state').textContent).time), 600))")
    assert t1 > t0["time"]
    assert not browser.errors()


def report_path() -> Path | None:
    """The report to check: CREATIO_REPORT, else data/report.html if built."""
    env = os.environ.get("CREATIO_REPORT")
    path = Path(env) if env else REPO / "data" / "report.html"
    return path if path.is_file() else None


def test_the_snakemake_report_opens_without_errors(browser):
    path = report_path()
    if path is None:
        pytest.skip("no report: snakemake --report data/report.html (or set CREATIO_REPORT)")
    browser.messages.clear()
    browser.open(path.resolve().as_uri(), settle=0.5)
    # the report's app renders after its data (tens of MB with the scenes) are decoded
    text = browser.wait_for("document.body.innerText.includes('RESULTS') && "
                            "document.body.innerText", timeout=90)
    assert not browser.errors(), "\n".join(map(str, browser.errors()))
    assert "creatio" in text and "CT-02" in text
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("L"), float)
    assert img.std() > 10, "the report renders blank"


def test_the_report_links_the_scene_pages_instead_of_embedding_them():
    """Each scene's poster caption links its page and animation, files that exist relative
    to the report; no page (its own three.js) is embedded."""
    import re

    path = report_path()
    if path is None:
        pytest.skip("no report: snakemake --report data/report.html (or set CREATIO_REPORT)")
    text = path.read_text()
    if "filename=poster.png" not in text:
        pytest.skip("the report holds no scene (snakemake scenes, then the report)")
    # embedded files are data URIs naming their file; the studies' tables (<study>.html) are
    # embedded on purpose, a scene's page (index.html, with its own three.js) must not be
    assert "filename=index.html" not in text
    links = set(re.findall(r'href=\\"([^"\\]*/(?:index\.html|animation\.webp))\\"', text))
    pages = {x for x in links if x.endswith("index.html")}
    assert pages and len(links) == 2 * len(pages), links
    for link in links:
        assert (path.parent / link).is_file(), link
