"""A scene page follows its URL's hash without a reload (a link to #t=6&sphere.mu=0.05 on an
open page, or the address bar edited), and the EN-02 page says in words why mu moves the
sphere or not, from the drawn member's own frames. Headless Chromium; skipped without it."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from chromium import Browser

pytestmark = pytest.mark.long

STATE = "JSON.parse(document.getElementById('scene-state').textContent)"


@pytest.fixture(scope="module")
def browser(need_chromium):
    with Browser(width=1280, height=800) as b:
        yield b


@pytest.fixture(scope="module")
def family_page(tmp_path_factory, library):
    """EN-02 on short cycles: mu in {0.05, 0.15, 0.3} x T in {8, 12} s, computed here."""
    from creatio.scenes.config import resolve, route
    from creatio.scenes.run import write_page, write_scene_dataset
    from creatio.store.netcdf import read_dataset

    d = tmp_path_factory.mktemp("hash")
    r = resolve("en02", route("en02", ["phases.T=12", "scene.axes.sphere.mu=0.05,0.3",
                                       "scene.axes.phases.T=8,12"])[0])
    write_scene_dataset(r, d / "scene.nc", store=d / "members")
    page = write_page(d / "scene.nc", d / "index.html", library)
    return page, read_dataset(d / "scene.nc")[0]


def _errors(browser: Browser) -> list[str]:
    return [str(e) for e in browser.errors()] + [
        f"page: {e}" for e in browser.evaluate("window.creatioErrors")]


def _go(browser: Browser, fragment: str) -> dict:
    """Change the open page's hash as a link does; what it draws once the event ran."""
    return browser.evaluate(
        f"new Promise((done) => {{ location.hash = {json.dumps(fragment)};"
        f"setTimeout(() => done({STATE}), 300); }})")


def test_the_page_follows_a_changed_hash_without_reloading(browser, family_page):
    page, ds = family_page
    axes = json.loads(ds.attrs["family_axes"])
    assert [a["labels"] for a in axes] == [["0.05", "0.15", "0.3"], ["8", "12"]]
    browser.messages.clear()
    browser.open(page.resolve().as_uri() + "#t=2", settle=0.8)
    assert not _errors(browser)
    browser.evaluate("window.notReloaded = 7")
    state = _go(browser, "#t=6&sphere.mu=0.05&phases.T=8")
    m = 0  # row-major (mu index 0, T index 0)
    assert state["member"] == m and state["values"] == {"sphere.mu": "0.05", "phases.T": "8"}
    assert state["time"] == 6
    k = int(np.argmin(np.abs(ds.time.values - 6.0)))
    np.testing.assert_allclose(state["runs"]["en02"]["drawn"], ds.family_centre.values[m, 0, k],
                               rtol=0, atol=1e-12)
    assert browser.evaluate("window.notReloaded") == 7
    sliders = browser.evaluate("[...document.querySelectorAll('input[data-key]')]"
                               ".map(s => s.value)")
    assert sliders == ["0", "0"] and browser.evaluate("document.getElementById('time').value") \
        == "6"
    # a hash naming only the time keeps the member; one naming only the member keeps the time
    state = _go(browser, "#t=3")
    assert (state["member"], state["time"]) == (m, 3)
    state = _go(browser, "#sphere.mu=0.3")
    assert state["values"] == {"sphere.mu": "0.3", "phases.T": "8"} and state["time"] == 3
    # a value that is not a number is said so, and changes nothing
    state = _go(browser, "#t=abc")
    assert state["time"] == 3
    notice = browser.evaluate("document.getElementById('notice').textContent")
    assert "#t=abc is not a number of seconds: ignored" in notice
    assert browser.evaluate("window.notReloaded") == 7 and not _errors(browser)


def test_the_surface_family_follows_a_changed_gamma(browser, tmp_path, library):
    from creatio.scenes.config import resolve
    from creatio.scenes.run import write_page, write_scene_dataset

    write_scene_dataset(resolve("surface_family"), tmp_path / "scene.nc")
    page = write_page(tmp_path / "scene.nc", tmp_path / "index.html", library)
    browser.messages.clear()
    browser.open(page.resolve().as_uri() + "#gamma=30", settle=0.8)
    assert browser.evaluate(STATE)["inclination"] == 30
    state = _go(browser, "#gamma=75")
    assert state["inclination"] == 75 and state["surface_class"] == "cone"
    assert browser.evaluate("document.getElementById('gamma').value") == "75"
    legend = browser.evaluate("document.getElementById('unit-u').textContent")
    assert "model length unit, not metres" in legend and "R0 = 0.68 u" in legend
    assert not _errors(browser)


def _tier(used: float) -> str:
    """The page's words for a share of the friction limit mu N (its thresholds)."""
    return ("mu barely moves it" if used < 0.1 else "a lower mu would make it slip"
            if used < 0.9 else "so mu sets how far the pattern drags it")


def test_the_page_says_why_mu_matters_from_the_members_own_frames(browser, family_page):
    page, ds = family_page
    browser.messages.clear()
    browser.open(page.resolve().as_uri() + "#t=4", settle=0.8)
    axes = json.loads(ds.attrs["family_axes"])
    for mu, T in (("0.05", "8"), ("0.15", "12"), ("0.3", "12")):
        state = _go(browser, f"#sphere.mu={mu}&phases.T={T}")
        m = state["member"]
        assert state["values"] == {"sphere.mu": mu, "phases.T": T}
        assert axes[0]["labels"].index(mu) * 2 + axes[1]["labels"].index(T) == m
        n = int(ds.family_frames_run.values[m, 0])
        f = ds.family_friction_magnitude.values[m, 0, :n]
        N = ds.family_normal_reaction.values[m, 0, :n]
        ratio = float(np.max(f / N))
        note = browser.evaluate("document.getElementById('friction-note').textContent")
        shown = float(re.search(r"at most (\S+) of the normal reaction", note).group(1))
        assert shown == pytest.approx(ratio, rel=1e-3)
        assert f"% of the limit mu N at mu = {mu} (cycle T = {T} s)" in note
        assert _tier(ratio / float(mu)) in note
    assert not _errors(browser)
