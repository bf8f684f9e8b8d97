"""Explorable scenes: a family over declared axes, planned from what the page draws, each
member equal to the scene computed for that config alone, refusals kept with their reason,
computed once (a store keyed by config and code), and refused before computing when its
page would not fit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from inproc import run_cli

from creatio.errors import ConfigError
from creatio.scenes.config import resolve, route
from creatio.scenes.family import compute_family, family_of, member
from creatio.scenes.run import scene_dataset

#: A 12 s cycle (6,000 RK4 steps a member) and a three-value axis around the default mu; the
#: scene's own cycle-length axis removed (a mu-only family).
SHORT = ["bases.en02.phases.T=12", "scene.axes.phases.T=null"]


def _resolve(scene: str, overrides: list[str]):
    return resolve(scene, route(scene, overrides)[0])


def test_the_default_family_is_the_notebooks_mu_control_on_a_long_and_short_cycles():
    """mu over range(0, 0.41, 0.025): 17 values written as meant (no 0.15000000000000002),
    times the cycle lengths 8, 10 and 120 s (EN-02's own, and the short cycles in which the
    sphere slides and mu moves it, as EN-05's design finds); the page opens on the study's
    mu = 0.15, T = 120 s, and the members beyond the RK4 friction stability limit are refused
    at every T: exactly those of the closed form dt <= 2.785 m eps / (3.5 mu 1.25 m g)."""
    from creatio.scenes.family import MAX_BYTES, PAGE_OVERHEAD, member_bytes

    r = resolve("en02")
    fam = family_of(r)
    axis, cycle = fam.axes
    assert axis.key == "sphere.mu" and len(axis.values) == 17 and not axis.inserted
    assert cycle.key == "phases.T" and cycle.labels == ("8", "10", "120") and not cycle.inserted
    assert fam.size == 51 and fam.links == (("en02", "phases.T", "study.duration"),)
    assert axis.labels[:4] == ("0.0", "0.025", "0.05", "0.075") and axis.labels[6] == "0.15"
    assert fam.base_member == fam.ravel((6, 2))
    assert axis.values[6] == r.obj.bases["en02"].sphere.mu
    assert cycle.values[2] == r.obj.bases["en02"].phases.T
    # the page stays under its limit: every member padded to the 120 s run's 301 frames
    assert member_bytes(r.obj, fam) == math.ceil(301 * 18 * 8 * 4 / 3)
    assert PAGE_OVERHEAD + (fam.size + 1) * member_bytes(r.obj, fam) <= MAX_BYTES
    sp, dt = r.obj.bases["en02"].sphere, r.obj.bases["en02"].solver.dt
    refused = [m.index for m in (member(r, fam, i) for i in range(fam.size)) if m.refused]
    limit = [fam.ravel((i, j)) for i, mu in enumerate(axis.values) for j in range(3)
             if mu > 0 and 2.785 * sp.m * sp.eps / (3.5 * mu * 1.25 * sp.m * sp.g) < dt]
    assert refused == limit and len(refused) == 4 * 3
    assert axis.labels[fam.unravel(refused[0])[0]] == "0.325"
    reason = member(r, fam, refused[0]).refused
    assert reason.startswith("bases.en02.solver.dt=0.002: beyond the RK4 stability limit")
    for scene in ("en02r", "compare"):
        assert [a.key for a in family_of(resolve(scene)).axes] == ["sphere.mu"]


def test_overrides_change_add_and_remove_axes():
    fam = family_of(_resolve("en02", ["scene.axes.sphere.mu=range(0,0.31,0.05)",
                                      "scene.axes.phases.T=60,120,240"]))
    assert [a.key for a in fam.axes] == ["sphere.mu", "phases.T"] and fam.shape == (7, 3)
    # the study's duration follows phases.T (an interpolation): the family varies it too
    assert fam.links == (("en02", "phases.T", "study.duration"),)
    assert fam.base_member == fam.ravel((3, 1))  # mu = 0.15, T = 120
    assert [a.key for a in family_of(_resolve("en02", ["scene.axes.sphere.mu=null"])).axes] \
        == ["phases.T"]
    assert family_of(_resolve("en02", ["scene.axes.sphere.mu=null",
                                       "scene.axes.phases.T=null"])) is None
    assert family_of(_resolve("en02", ["~scene.axes.sphere", "~scene.axes.phases"])) is None
    assert family_of(_resolve("en02", ["scene.axes={}"])) is None
    # a whole mapping replaces the declared axes (Hydra alone would merge it into them)
    fam = family_of(_resolve("compare", ["scene.axes={phases.T:'60,120'}"]))
    assert [(a.key, a.labels, a.studies) for a in fam.axes] == [
        ("phases.T", ("60", "120"), ("en02", "en02r"))]
    # a value the axis does not list is inserted: the page opens on the scene's own config
    axis, _ = family_of(_resolve("en02", ["sphere.mu=0.155"])).axes
    assert axis.inserted and axis.labels[axis.base] == "0.155" and len(axis.values) == 18


@pytest.mark.parametrize(("override", "message"), [
    ("scene.axes.sphere.muu=0.1,0.2", "scene.axes.sphere.muu='0.1,0.2': unknown key: no study"),
    ("scene.axes.solver=rk4,radau5", "must name a value of en02's config (sphere.mu), not a group"),
    ("scene.axes.sphere.mu=0.1,0.1", "lists 0.1 twice"),
])
def test_an_axis_the_scene_cannot_have_is_refused(override, message):
    with pytest.raises(ConfigError) as e:
        _resolve("en02", [override])
    assert message in str(e.value)


def test_a_family_whose_page_would_not_fit_is_refused_before_computing():
    """410 values of mu times the 3 cycle lengths: each member adds 301 frames (120 s every
    0.4 s) x 18 numbers (centre 3, orientation 4, phases 3, 8 readouts) as base64 float64 =
    57.8 kB."""
    from creatio.scenes.family import PAGE_OVERHEAD

    per = 301 * (3 + 4 + 3 + 8) * 8 * 4 / 3
    size = (PAGE_OVERHEAD + 1231 * per) / 2**20
    with pytest.raises(ConfigError) as e:
        _resolve("en02", ["scene.axes.sphere.mu=range(0,0.41,0.001)"])
    assert str(e.value) == (
        f"invalid config: scene.axes='1230 members': the page would be about {size:.1f} MB, "
        f"above its 5 MB limit ({per / 1e3:.0f} kB a member): use fewer values (about "
        f"{int((5 * 2**20 - PAGE_OVERHEAD) // math.ceil(per)) - 1} members fit), fewer "
        "readouts, or fewer frames (a lower scene.playback.fps)")


def test_two_studies_must_agree_on_an_axis_key():
    with pytest.raises(ConfigError, match="the studies of this scene differ on it "
                                          r"\(en02: 0.2, en02r: 0.15\)"):
        resolve("compare", ["bases.en02.sphere.mu=0.2"])


@pytest.fixture(scope="module")
def short_family(tmp_path_factory):
    """EN-02 on a 12 s cycle, mu in {0.1, 0.2, 0.4} (0.15 inserted, 0.4 refused), computed
    once into a store."""
    store = tmp_path_factory.mktemp("store")
    r = _resolve("en02", [*SHORT, "scene.axes.sphere.mu=0.1,0.2,0.4"])
    fam = family_of(r)
    return r, fam, compute_family(r, fam, store=store), store


def test_a_member_is_the_scene_computed_for_its_config_alone(short_family):
    """The member mu = 0.2 (the base config varied without Hydra) equals the scene resolved
    by Hydra with sphere.mu=0.2 and computed on its own: same frames to the last bit."""
    r, fam, ds, _ = short_family
    assert [a.labels for a in fam.axes] == [("0.1", "0.15", "0.2", "0.4")]
    alone = scene_dataset(_resolve("en02", [*SHORT, "sphere.mu=0.2", "~scene.axes.sphere"]))
    m = 2
    for name in ("centre", "quaternion", "cumulative_spin", "normal_reaction", "phase_a"):
        np.testing.assert_array_equal(ds[name].values[m], alone[name].values, err_msg=name)
    assert str(ds.status.values[m, 0]) == "ok" and ds.message.values[m] == ""
    assert str(ds.status.values[3, 0]) == "refused"
    assert "stability limit" in str(ds.message.values[3])
    assert np.all(np.isnan(ds.centre.values[3]))
    assert ds.attrs == {"computed": 3, "reused": 0, "refused": 1}


def test_headline_figures_are_the_runs_own(short_family):
    """final radius = |centre_xy| at the end; min N = the full study run's extremum over every
    step (the member writes 0.4 s frames only: the extremum does not depend on them)."""
    from creatio.pipeline.config import resolve as resolve_study
    from creatio.pipeline.run import run_study

    r, fam, ds, _ = short_family
    m = 2
    last = int(ds.frames_run.values[m, 0]) - 1
    assert ds.final_radius.values[m, 0] == pytest.approx(
        math.hypot(*ds.centre.values[m, 0, last, :2]), rel=1e-12)
    full = run_study(resolve_study("en02", ["phases.T=12", "sphere.mu=0.2"]), dt=0.002)
    assert ds.min_normal_reaction.values[m, 0] == full.attrs["min_normal_reaction"]
    assert ds.final_cumulative_spin.values[m, 0] == pytest.approx(
        float(full.cumulative_spin.values[-1]), rel=1e-12)
    assert ds.final_lag.values[m, 0] == pytest.approx(float(full.angular_lag.values[-1]),
                                                      rel=1e-12)


def test_a_family_is_computed_once_and_a_wider_axis_computes_only_the_new(short_family):
    r, fam, first, store = short_family
    again = compute_family(r, fam, store=store)
    assert again.attrs == {"computed": 0, "reused": 3, "refused": 1}
    np.testing.assert_array_equal(again.centre.values, first.centre.values)
    # every variable and its attributes as computed, the stored members read with netCDF4
    kept, computed = again.copy(), first.copy()
    kept.attrs = computed.attrs = {}
    assert kept.identical(computed)
    wider = _resolve("en02", [*SHORT, "scene.axes.sphere.mu=0.1,0.2,0.25,0.4"])
    ds = compute_family(wider, family_of(wider), store=store)
    assert ds.attrs == {"computed": 1, "reused": 3, "refused": 1}


def test_a_damaged_or_swapped_store_entry_is_computed_again(short_family, tmp_path):
    import shutil

    r, fam, first, store = short_family
    copy = tmp_path / "store"
    shutil.copytree(store, copy)
    keys = [m.key for m in (member(r, fam, i) for i in range(fam.size)) if not m.refused]
    entries = [copy / f"{key[:32]}.nc" for key in keys]
    assert all(e.is_file() for e in entries) and len(entries) == 3
    entries[0].write_bytes(b"not a netcdf file")
    shutil.copyfile(entries[2], entries[1])  # another member's numbers under this key
    ds = compute_family(r, fam, store=copy)
    assert ds.attrs["computed"] == 2 and ds.attrs["reused"] == 1
    np.testing.assert_array_equal(ds.centre.values, first.centre.values)


def test_the_scene_dataset_carries_its_family_and_the_page_packs_it(short_family, tmp_path):
    from creatio.scenes.page import family_data

    r, fam, _, store = short_family
    ds = scene_dataset(r, store=store)
    base = fam.base_member
    np.testing.assert_array_equal(ds.family_centre.values[base], ds.centre.values)
    assert list(ds.family_sphere__mu.values) == [0.1, 0.15, 0.2, 0.4]
    assert ds.attrs["family_reused"] == 3 and ds.attrs["family_computed"] == 0
    page = family_data(ds)
    assert page["rows"] == [0, 1, 2, -1] and page["arrays"]["centre"]["shape"][0] == 3
    assert "stability limit" in page["message"][3] and page["figures"]["final_radius"][
        "values"][3] == [None]


def test_the_family_batch_step_refuses_a_scene_without_axes_in_one_line(tmp_path):
    out = tmp_path / "b.nc"
    proc = run_cli("task", "scene", "family-batch", "en02", str(out), "--batch", "0",
                   "--override", "scene.axes.sphere.mu=null", "--override",
                   "scene.axes.phases.T=null")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "creatio task scene: invalid config: scene.axes={}: scene en02 declares no axis: it "
        "has no family to compute"]
    assert not out.exists()


def _friction_use(T: float, mu: float) -> tuple[float, float]:
    """EN-02 at cycle length T and friction mu: the largest |friction| / N over the run's
    outputs and the centre's final radius (m)."""
    from creatio.pipeline.config import resolve as resolve_study
    from creatio.pipeline.run import run_study

    cfg = resolve_study("en02", [f"phases.T={T}", f"sphere.mu={mu}"])
    ds = run_study(cfg, cfg.entry.parts(cfg.obj)[0].name)
    assert ds.attrs["status"] == "ok"
    ratio = np.linalg.norm(ds.friction.values, axis=-1) / ds.normal_reaction.values
    return float(np.max(ratio)), float(ds.centre_radius.values[-1])


def test_mu_barely_moves_the_sphere_on_the_slow_cycle_and_matters_on_the_short_one():
    """What the EN-02 page says, and why its family has an 8 s cycle: over 120 s the sphere
    needs a friction force of 4.4e-4 N per N whatever mu (rolling without slipping), far
    below mu N, and ends on the same radius; over 8 s the contact saturates at mu = 0.05
    (|f| = mu N: the sphere slides) and mu changes where it ends by centimetres."""
    slow = {mu: _friction_use(120.0, mu) for mu in (0.05, 0.15)}
    assert slow[0.05][0] == pytest.approx(slow[0.15][0], rel=1e-4)
    assert slow[0.05][0] < 0.01 * 0.05
    assert abs(slow[0.05][1] - slow[0.15][1]) < 1e-8
    fast = {mu: _friction_use(8.0, mu) for mu in (0.05, 0.15)}
    assert fast[0.05][0] == pytest.approx(0.05, rel=1e-3)
    assert fast[0.15][0] > 100 * slow[0.15][0]
    assert abs(fast[0.05][1] - fast[0.15][1]) > 0.01
