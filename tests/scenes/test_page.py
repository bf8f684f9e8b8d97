"""A page never reads text it was given as markup or as a template: the title, the data and
every string the viewer shows from them stay text (issue 28, class 10)."""

from __future__ import annotations

import html
import json
import re

import pytest

from creatio.scenes.config import resolve, route
from creatio.scenes.page import fill
from creatio.scenes.run import write_page, write_scene_dataset

TITLE = "{{THREE}} {{DATA}} <script>alert(1)</script> & {{TITLE}}"


def test_slots_are_filled_in_one_pass_over_the_template():
    assert fill("<h1>{{A}}</h1>{{B}}", {"A": "{{B}}", "B": "x"}) == "<h1>{{B}}</h1>x"
    with pytest.raises(KeyError):
        fill("{{NOPE}}", {})


@pytest.fixture(scope="module")
def titled(tmp_path_factory, library):
    """The surface-family page with a title made of slot names and markup, and the same
    page with a plain title."""
    out = {}
    for name, title in (("odd", TITLE), ("plain", "plain")):
        d = tmp_path_factory.mktemp(name)
        r = resolve("surface_family", route("surface_family", [f"scene.title='{title}'"])[0])
        assert r.obj.scene.title == title
        write_scene_dataset(r, d / "scene.nc")
        out[name] = write_page(d / "scene.nc", d / "index.html", library)
    return out


def test_a_title_holding_slot_names_stays_text(titled, library):
    odd, plain = titled["odd"].read_text(), titled["plain"].read_text()
    bundle = library.read_text()[:400]
    assert odd.count(bundle) == 1 == plain.count(bundle)
    assert abs(len(odd) - len(plain)) < 2000  # not a second bundle or a second data block
    assert f"<h1>{html.escape(TITLE)}</h1>" in odd
    assert f"<title>{html.escape(TITLE)}</title>" in odd
    assert "<script>alert(1)</script>" not in odd
    data = re.search(r'<script id="scene-data" type="application/json">(.*?)</script>', odd,
                     re.S).group(1)
    assert json.loads(data)["kind"] == "surface_family"


def test_the_browser_shows_the_title_as_written(titled, need_chromium):
    from chromium import Browser

    with Browser(width=1000, height=700) as b:
        b.open(titled["odd"].resolve().as_uri(), settle=0.5)
        assert b.evaluate("document.querySelector('h1').textContent") == TITLE
        assert b.evaluate("document.title") == TITLE
        assert b.evaluate("document.querySelectorAll('script').length") == 4
        assert not b.errors()


def test_text_from_the_data_never_becomes_markup(tmp_path, library, need_chromium):
    """A refused axis value carrying markup is shown, in the view and the slider, as text."""
    from chromium import Browser

    value = "<img src=x onerror=window.hit=1>"
    r = resolve("en02", route("en02", ["bases.en02.phases.T=12", "scene.axes.phases.T=null",
                                       f'scene.axes.sphere.mu=["{value}",0.1]'])[0])
    write_scene_dataset(r, tmp_path / "scene.nc", store=tmp_path / "members")
    page = write_page(tmp_path / "scene.nc", tmp_path / "index.html", library)
    with Browser(width=1200, height=800) as b:
        b.open(page.resolve().as_uri() + "#t=4", settle=0.5)
        b.evaluate("(() => { const s = document.querySelector('input[data-key=\"sphere.mu\"]');"
                   "s.value = '0'; s.dispatchEvent(new Event('input')); })()")
        shown = b.evaluate("document.querySelector('.view .refused').textContent")
        assert value in shown and "has the wrong type" in shown
        assert b.evaluate("document.getElementById('axis-0-value').textContent") == value
        assert b.evaluate("document.querySelectorAll('img').length") == 0
        assert b.evaluate("window.hit === undefined")
        assert not b.errors()


def test_a_title_is_drawn_as_written_in_the_animation(tmp_path):
    """matplotlib would read ``$...$`` as mathtext (``$\\frac$`` fails to parse): escaped."""
    from creatio.scenes.media import plain
    from creatio.scenes.run import write_media

    title = r"$\frac$ is not a fraction"
    assert plain(title) == r"\$\frac\$ is not a fraction"
    r = resolve("surface_family", route("surface_family", [
        f"scene.title='{title}'", "scene.media.every=45", "scene.media.width=320",
        "scene.media.height=200"])[0])
    write_scene_dataset(r, tmp_path / "scene.nc")
    write_media(tmp_path / "scene.nc", tmp_path / "a.webp", tmp_path / "p.png")
    assert (tmp_path / "a.webp").stat().st_size > 0 and (tmp_path / "p.png").stat().st_size > 0
