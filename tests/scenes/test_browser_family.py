"""The explorable pages and their views in a real browser (headless Chromium): the family
slider draws the member's own numbers, a refused value shows its reason, switching is drawn
by the next frame; the cameras (framing, follow, linked views, gamma), the legend, URL values
that are not numbers, narrow screens, and text from the data that never becomes markup."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest
from chromium import Browser

STATE = "JSON.parse(document.getElementById('scene-state').textContent)"


@pytest.fixture(scope="module")
def browser(need_chromium):
    with Browser(width=1400, height=900) as b:
        yield b


def _open(browser: Browser, page, fragment: str = "") -> dict:
    browser.messages.clear()
    browser.open(page.resolve().as_uri() + fragment, settle=0.8)
    _no_errors(browser)
    return browser.evaluate(STATE)


def _no_errors(browser: Browser) -> None:
    errors = browser.errors() + [f"page: {e}" for e in browser.evaluate("window.creatioErrors")]
    assert not errors, "\n".join(map(str, errors))


def _slide(browser: Browser, key: str, index: int) -> dict:
    """Move an axis slider as a person does (value, then an input event); what is drawn."""
    return browser.evaluate(
        f"(() => {{ const s = document.querySelector('input[data-key=\"{key}\"]');"
        f"s.value = '{index}'; s.dispatchEvent(new Event('input'));"
        f"return {STATE}; }})()")


def _member(axes: list[dict], key: str, i: int) -> tuple[int, dict]:
    """The member with axis `key` at index i and every other axis at the page's own value
    (row-major), and its values as the page publishes them."""
    idx = [i if a["key"] == key else a["base"] for a in axes]
    m = 0
    for a, j in zip(axes, idx, strict=True):
        m = m * len(a["labels"]) + j
    return m, {a["key"]: a["labels"][j] for a, j in zip(axes, idx, strict=True)}


def _dataset(scenes, scene):
    from creatio.store.netcdf import read_dataset

    return read_dataset(scenes[scene] / "scene.nc")[0]


@pytest.mark.parametrize("scene", ["en02", "compare"])
def test_the_mu_slider_draws_that_members_sphere_at_the_pages_time(browser, scenes, scene):
    ds = _dataset(scenes, scene)
    axes = json.loads(ds.attrs["family_axes"])
    assert [a["key"] for a in axes] == (["sphere.mu", "phases.T"] if scene == "en02"
                                        else ["sphere.mu"])
    state = _open(browser, scenes[scene] / "index.html", "#t=60")
    k = int(np.argmin(np.abs(ds.time.values - 60.0)))
    assert state["member"] == ds.attrs["family_base_member"] and state["frame"] == k
    for mu in ("0.05", "0.25", "0.0"):
        m, values = _member(axes, "sphere.mu", axes[0]["labels"].index(mu))
        state = _slide(browser, "sphere.mu", axes[0]["labels"].index(mu))
        assert state["member"] == m and state["values"] == values
        assert float(ds.family_sphere__mu.values[m]) == float(mu)
        for r, run in enumerate(ds.run.values):
            drawn = state["runs"][str(run)]["drawn"]
            np.testing.assert_allclose(drawn, ds.family_centre.values[m, r, k], rtol=0,
                                       atol=1e-12)
            _assert_members_surface(state["runs"][str(run)]["surface"], ds, m, r, k)
        # the readouts are that member's, and its chart is marked
        speed = browser.evaluate("document.querySelector('#readouts tr[data-readout=speed] "
                                 "td:nth-child(2)').textContent")
        assert float(speed) == pytest.approx(float(ds.family_speed.values[m, 0, k]), rel=1e-3)
    _no_errors(browser)


def _assert_members_surface(probe: list[dict], ds, m: int, r: int, k: int) -> None:
    """The drawn membrane is the model's surface at the member's own phases (stated in the
    dataset's angle unit)."""
    from creatio.model.laws import Law
    from creatio.model.surface import Frame, Motion, Surface

    geo = [float(ds[f"family_{n}"].values[m, r]) for n in ("R0", "dR", "A", "Kr", "Ka")]
    ph = []
    for n in ("phase_r", "phase_a", "inclination"):
        var = ds[f"family_{n}"]
        value = float(var.values[m, r, k])
        ph.append(value if var.attrs.get("units") in ("rad", "radian") else math.radians(value))
    motion = Motion(*(Law.constant(p) for p in ph))
    surface = Surface(geo[0], geo[1], geo[2], int(geo[3]), int(geo[4]))
    for v in probe:
        expected = Frame(surface, motion, v["alpha"], v["R"], 0.0).position
        np.testing.assert_allclose(v["xyz"], expected, rtol=0, atol=2e-6)  # float32 mesh


def test_a_refused_value_shows_its_reason_not_a_number(browser, scenes):
    ds = _dataset(scenes, "en02")
    axes = json.loads(ds.attrs["family_axes"])
    i = axes[0]["labels"].index("0.35")
    m, _ = _member(axes, "sphere.mu", i)
    reason = str(ds.family_message.values[m])
    assert reason.startswith("bases.en02.solver.dt=0.002: beyond the RK4 stability limit")
    _open(browser, scenes["en02"] / "index.html", "#t=30")
    state = _slide(browser, "sphere.mu", i)
    assert state["refused"] == reason and "drawn" not in state["runs"]["en02"]
    shown = browser.evaluate("(() => { const e = document.querySelector('.view .refused');"
                             "return e.hidden ? '' : e.textContent; })()")
    assert shown == (f"sphere.mu = 0.35, phases.T = 120: refused by the validation, not "
                     f"computed. {reason}")
    cells = browser.evaluate("[...document.querySelectorAll('#readouts tr[data-readout]')]"
                             ".filter(tr => tr.dataset.readout !== 'time')"
                             ".map(tr => tr.children[1].textContent)")
    assert cells and set(cells) == {"refused"}
    marks = browser.evaluate("document.querySelectorAll('svg.chart .refused-mark').length")
    # the charts run along mu at the page's T: the refused members of that row
    row = [_member(axes, "sphere.mu", j)[0] for j in range(len(axes[0]["labels"]))]
    refused = int(np.sum(np.all(ds.family_status.values[row] == "refused", axis=1)))
    assert refused == 4  # mu = 0.325 ... 0.4: beyond the RK4 friction stability limit
    assert marks == 4 * refused  # one cross per refused member in each of the four charts
    _no_errors(browser)


def test_a_new_member_is_drawn_by_the_next_frame(browser, scenes):
    """The switch happens inside the input event: the frame after it draws the member."""
    _open(browser, scenes["en02"] / "index.html", "#t=60")
    axes = json.loads(_dataset(scenes, "en02").attrs["family_axes"])
    n, T = len(axes[0]["labels"]), len(axes[1]["labels"])
    assert axes[1]["base"] == T - 1  # the member of mu index i is i * T + T - 1
    result = browser.evaluate("""new Promise((done) => {
        const s = document.querySelector('input[data-key="sphere.mu"]');
        const out = [];
        let k = 0;
        const step = () => requestAnimationFrame((t0) => {
          const target = (k * 7) % N;
          const h0 = performance.now();
          s.value = String(target); s.dispatchEvent(new Event('input'));
          const h1 = performance.now();
          requestAnimationFrame((t1) => {
            const st = JSON.parse(document.getElementById('scene-state').textContent);
            out.push({ ok: st.member === target * T + T - 1, handler: h1 - h0,
                       frame: t1 - t0 });
            if (++k < 12) step(); else done(out);
          });
        });
        step();
      })""".replace("% N", f"% {n}").replace("* T + T", f"* {T} + {T}"))
    assert all(r["ok"] for r in result), result


def test_a_time_that_is_not_a_number_gives_a_message(browser, scenes):
    state = _open(browser, scenes["en02"] / "index.html", "#t=abc")
    assert state["time"] == 0
    notice = browser.evaluate("document.getElementById('notice').textContent")
    assert notice == "#t=abc is not a number of seconds: ignored"
    _assert_drawn(browser)
    state = _open(browser, scenes["surface_family"] / "index.html", "#gamma=steep")
    assert browser.evaluate("document.getElementById('notice').textContent") == (
        "#gamma=steep is not a number of degrees: ignored")


def _canvas_boxes(browser: Browser) -> list[tuple[float, float, float, float, float, float]]:
    """Per canvas: the box of its drawn (non-white) pixels as fractions of the canvas
    (left, top, right, bottom), and the canvas width and height in pixels."""
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("L"), float)
    rects = browser.evaluate("[...document.querySelectorAll('.view > canvas:first-of-type')]"
                             ".map(c => { const r = c.getBoundingClientRect();"
                             "return [r.left, r.top, r.width, r.height]; })")
    out = []
    for x, y, w, h in rects:
        crop = img[int(y) + 2: int(y + h) - 2, int(x) + 2: int(x + w) - 2] < 240
        if crop.size == 0 or not crop.any():  # below the fold of a narrow screen
            continue
        # the overlays (label, scale, triad) sit in the corners: count rows and columns
        # where the drawing covers more than a few pixels
        cols = np.flatnonzero(crop.sum(axis=0) > 8)
        rows = np.flatnonzero(crop.sum(axis=1) > 8)
        W, H = crop.shape[1], crop.shape[0]
        out.append((cols[0] / W, rows[0] / H, cols[-1] / W, rows[-1] / H, W, H))
    return out


def _assert_drawn(browser: Browser) -> None:
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(browser.screenshot())).convert("L"), float)
    assert np.mean(img < 245) > 0.05 and img.std() > 10, "blank page"


def test_compare_frames_each_annulus_and_links_the_cameras(browser, scenes):
    """Each annulus fills its panel across (it filled about 45 % before); orbiting one view
    turns the other the same way."""
    _open(browser, scenes["compare"] / "index.html", "#t=60")
    boxes = _canvas_boxes(browser)
    assert len(boxes) == 2
    for left, _, right, _, _, _ in boxes:
        assert right - left > 0.85, boxes
    views = browser.evaluate("window.creatio.views.map(v => v.state())")
    r = browser.evaluate("(() => { const c = document.querySelector('.view canvas')"
                         ".getBoundingClientRect(); return [c.left + c.width / 2,"
                         " c.top + c.height / 2]; })()")
    for kind, x in (("mousePressed", r[0]), ("mouseMoved", r[0] + 60), ("mouseMoved", r[0] + 120),
                    ("mouseReleased", r[0] + 120)):
        browser.call("Input.dispatchMouseEvent", {"type": kind, "x": x, "y": r[1],
                                                  "button": "left", "buttons": 1,
                                                  "clickCount": 1})
    after = browser.evaluate("window.creatio.views.map(v => v.state())")
    offsets = [np.subtract(v["position"], v["target"]) for v in after]
    assert not np.allclose(after[0]["position"], views[0]["position"]), "the drag did nothing"
    np.testing.assert_allclose(offsets[1], offsets[0], rtol=0, atol=1e-9)
    _no_errors(browser)


def test_follow_the_sphere_keeps_it_centred_and_large(browser, scenes):
    """The camera looks at the drawn sphere, which spans at least a fifth of the view's
    height (about 40 px of 800, a twentieth, in the whole-annulus view)."""
    ds = _dataset(scenes, "en02")
    b = float(ds.sphere_radius.values[0])
    for t in (30, 60):
        state = _open(browser, scenes["en02"] / "index.html", f"#t={t}&camera=follow")
        run = state["runs"]["en02"]
        cam = run["camera"]
        np.testing.assert_allclose(cam["target"], run["drawn"], rtol=0, atol=1e-9)
        d = math.dist(cam["position"], cam["target"])
        span = 2 * b / (2 * d * math.tan(math.radians(cam["fov"]) / 2))
        assert span > 0.2, span
    state = _open(browser, scenes["en02"] / "index.html", "#t=60")
    cam = state["runs"]["en02"]["camera"]
    d = math.dist(cam["position"], cam["target"])
    assert 2 * b / (2 * d * math.tan(math.radians(cam["fov"]) / 2)) < 0.1


def test_the_surface_family_camera_follows_gamma(browser, scenes):
    """At every inclination the surface is centred in the view and fills it (at 90 deg the
    cylinder sat in the upper half before)."""
    for gamma in (0, 45, 90):
        _open(browser, scenes["surface_family"] / "index.html", f"#gamma={gamma}")
        (box,) = _canvas_boxes(browser)
        left, top, right, bottom, _, _ = box
        assert abs((top + bottom) / 2 - 0.5) < 0.08 and abs((left + right) / 2 - 0.5) < 0.08, box
        assert max(right - left, bottom - top) > 0.8, box


def test_the_sphere_legend_says_what_each_colour_is(browser, scenes):
    _open(browser, scenes["en02"] / "index.html", "#t=60")
    items = browser.evaluate("[...document.querySelectorAll('.section .item span:last-child')]"
                             ".map(e => e.textContent)")
    joined = " | ".join(items)
    for word in ("membrane", "blue cavity", "brown crest", "marker", "band", "trace",
                 "axes triad"):
        assert word in joined, joined
    assert browser.evaluate("document.querySelector('canvas.triad') !== null")
    assert browser.evaluate("document.querySelector('.view .scale .text').textContent"
                            ).endswith(" at the orbit centre")
    browser.evaluate("document.getElementById('reset-view').click()")
    _no_errors(browser)


@pytest.mark.parametrize("scene", ["en02", "compare", "surface_family", "velocity_normal"])
def test_a_narrow_screen_stacks_the_views_above_the_panel(browser, scenes, scene):
    browser.call("Emulation.setDeviceMetricsOverride", {"width": 390, "height": 800,
                                                        "deviceScaleFactor": 1,
                                                        "mobile": False})
    try:
        _open(browser, scenes[scene] / "index.html", "#t=2")
        layout = browser.evaluate("""(() => {
            const views = [...document.querySelectorAll('.view')].map(
              v => v.getBoundingClientRect());
            const panel = document.getElementById('panel').getBoundingClientRect();
            return { scroll: document.documentElement.scrollWidth, views: views.map(
              r => [r.left, r.top, r.width, r.height]), panel: [panel.left, panel.top,
              panel.width] }; })()""")
        assert layout["scroll"] <= 390, layout
        for left, top, width, height in layout["views"]:
            assert left >= 0 and width > 350 and height > 250, layout
            assert top + height <= layout["panel"][1] + 1, layout
        assert layout["panel"][2] > 350
        for box in _canvas_boxes(browser)[:1]:
            assert box[2] - box[0] > 0.6, box
    finally:
        browser.call("Emulation.setDeviceMetricsOverride", {"width": 1400, "height": 900,
                                                            "deviceScaleFactor": 1,
                                                            "mobile": False})


def test_two_axes_give_two_sliders_and_each_member_its_own_run(browser, tmp_path, library):
    """mu x T: the T slider switches to a member whose run lasts its own T (the study's
    duration follows T), drawn from that member's frames; the chart follows the other axis."""
    from creatio.scenes.config import resolve, route
    from creatio.scenes.run import write_page, write_scene_dataset
    from creatio.store.netcdf import read_dataset

    r = resolve("en02", route("en02", ["phases.T=12", "scene.axes.sphere.mu=0.1,0.2",
                                       "scene.axes.phases.T=8,12"])[0])
    write_scene_dataset(r, tmp_path / "scene.nc", store=tmp_path / "members")
    page = write_page(tmp_path / "scene.nc", tmp_path / "index.html", library)
    ds, _ = read_dataset(tmp_path / "scene.nc")
    axes = json.loads(ds.attrs["family_axes"])
    assert [(a["key"], a["labels"]) for a in axes] == [("sphere.mu", ["0.1", "0.15", "0.2"]),
                                                       ("phases.T", ["8", "12"])]
    _open(browser, page, "#t=6")
    assert browser.evaluate("document.querySelectorAll('input[data-key]').length") == 2
    _slide(browser, "sphere.mu", 2)
    state = _slide(browser, "phases.T", 0)
    m = 2 * 2 + 0  # row-major: mu index 2, T index 0
    assert state["member"] == m and state["values"] == {"sphere.mu": "0.2", "phases.T": "8"}
    assert int(ds.family_frames_run.values[m, 0]) == 21  # 8 s every 0.4 s, both ends
    k = int(np.argmin(np.abs(ds.time.values - 6.0)))
    np.testing.assert_allclose(state["runs"]["en02"]["drawn"], ds.family_centre.values[m, 0, k],
                               rtol=0, atol=1e-12)
    # past that member's end (8 s) the sphere and the membrane hold its last frame
    state = json.loads(browser.evaluate(
        "(() => { const s = document.getElementById('time'); s.value = '10';"
        "s.dispatchEvent(new Event('input'));"
        "return document.getElementById('scene-state').textContent; })()"))
    assert state["runs"]["en02"]["frame"] == 20
    np.testing.assert_allclose(state["runs"]["en02"]["drawn"], ds.family_centre.values[m, 0, 20],
                               rtol=0, atol=1e-12)
    assert all(math.isfinite(p) for p in state["runs"]["en02"]["phases"])
    browser.evaluate("(() => { const s = document.getElementById('chart-axis');"
                     "s.value = '1'; s.dispatchEvent(new Event('change')); })()")
    ticks = browser.evaluate("[...document.querySelectorAll('svg.chart')][0].textContent")
    assert "phases.T" in ticks
    _no_errors(browser)
