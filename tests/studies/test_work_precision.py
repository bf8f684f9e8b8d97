"""The work-precision benchmark as a configured analysis: config refusals, the method plan
derived from the registry, the round-robin timing protocol, the noise flags and verdicts of
the report, the peer harnesses (scipy, and CVODE when scikit-sundae is installed) measuring
the native error on the same solution, and one tiny end-to-end run through the pipeline
(datasets with provenance, three reports). No assertion on wall-clock times.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from creatio.dynamics import simulate
from creatio.dynamics.solvers import EXPLICIT, METHODS, Method, Tableau
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve
from creatio.studies import work_precision as wp

#: Tiny grids on 2 s of each base (the fast default cycle of T = 2 s loses contact, so the
#: duration is shortened instead): one or two settings per method, two repeats, no cold
#: compile in a fresh process.
TINY = [
    "bases.en02.study.duration=2", "bases.en02r.study.duration=2",
    "study.methods.rk4.steps_per_output=[50,20]", "study.methods.dopri5.rtol=[1e-6]",
    "study.methods.dop853.rtol=[1e-8]", "study.methods.radau5.rtol=[1e-6,1e-8]",
    "study.methods.radau5.steps_per_output=[5]", "study.unlisted.rtol=[1e-6]",
    "study.unlisted.steps_per_output=[100,50]", "study.methods.dopri5.dense_rtol=[]",
    "study.methods.dop853.dense_rtol=[]", "study.methods.radau5.dense_rtol=[1e-8]",
    "study.methods.radau5.dense_dt=[0.06]", "study.methods.rodas4.rtol=[1e-6]",
    "study.methods.rodas4.steps_per_output=[]",
    "study.methods.radau9.rtol=[1e-8]", "study.methods.radau9.steps_per_output=[1]",
    "study.methods.radau9.newton_rtol=[]", "study.methods.radau9.dense_rtol=[]",
    "study.methods.radau13.rtol=[1e-8]", "study.methods.radau13.steps_per_output=[]",
    "study.methods.radau13.newton_rtol=[]", "study.methods.radau13.dense_rtol=[]",
    "study.methods.radau.rtol=[1e-8]", "study.methods.radau.dense_rtol=[1e-8]",
    "study.peers.DOP853=[1e-6]", "study.peers.Radau=[1e-6]", "study.peers.LSODA=[1e-8]",
    "study.peers.CVODE=[1e-8]",
    "study.repeats=2", "study.jit.methods=[rk4]", "study.jit.cold=false",
]


@pytest.fixture(scope="module")
def tiny():
    return resolve("work_precision", TINY)


def test_tiny_config_validates_and_plans_every_registered_method(tiny) -> None:
    cfg = tiny.obj
    assert [p.name for p in wp.parts(cfg)] == ["work_precision_en02", "work_precision_en02r"]
    assert [dict(p.args) for p in wp.parts(cfg)] == [{"base": "en02", "jit": True},
                                                     {"base": "en02r", "jit": False}]
    assert cfg.bases["en02"].study.duration == 2.0 and cfg.bases["en02r"].phases.T == 120.0
    plan = wp.settings(cfg.study, wp.base_problem(cfg, "en02"))
    native = {s.solver for s in plan if s.group == "native"}
    assert native == set(METHODS)
    for s in plan:  # adaptive methods by rtol (and "-fixed" by dt), fixed-step ones by dt
        if s.group == "native":
            adaptive = METHODS[s.solver].adaptive
            assert s.kind == ("dt" if "-fixed" in s.method or not adaptive else "rtol")
            assert s.dense == s.method.endswith("-dense")
    assert [s.label for s in plan if s.method == "rk4"] == ["dt=0.002", "dt=0.005"]
    assert [(s.method, s.label) for s in plan if s.dense] == [
        ("rk4-dense", "dt=0.003"), ("radau5-dense", "rtol=1e-08"),
        ("radau5-fixed-dense", "dt=0.06"), ("radau-dense", "rtol=1e-08")]
    assert [(s.method, s.label) for s in plan if s.solver in ("radau9", "radau13")] == [
        ("radau9", "rtol=1e-08"), ("radau9-fixed", "dt=0.1"), ("radau13", "rtol=1e-08")]
    dense = next(s for s in plan if s.dense)
    assert wp.native_problem(wp.base_problem(cfg, "en02"), dense, 0.01).solver.dense_output
    assert {s.method for s in plan if s.group == "full"} == {"rk4-full", "radau5-full"}
    assert {s.method for s in plan if s.group == "mu0"} == {"rk4-mu0", "rk4-mu0-full"}
    from creatio.dynamics.peer_solvers import PEERS, SUNDIALS

    assert tuple(wp.PEER_METHODS) == (*PEERS, *SUNDIALS)
    assert wp.SUNDIALS_PEERS == tuple(SUNDIALS)


def test_default_grids_are_the_notebook_benchmark() -> None:
    """The default config keeps the grids of the former module constants."""
    s = resolve("work_precision").obj.study
    plan = wp.settings(s, wp.base_problem(resolve("work_precision").obj, "en02"))
    rk4 = [x.value for x in plan if x.method == "rk4"]
    np.testing.assert_allclose(rk4, [0.1 / n for n in (400, 200, 100, 50, 40, 30, 25, 24, 23,
                                                       22, 20)], rtol=1e-15)
    fixed = [x.value for x in plan if x.method == "radau5-fixed" and x.newton_rtol is None]
    np.testing.assert_allclose(fixed, [0.1, 0.05, 0.1 / 3, 0.025, 0.02, 0.0125, 0.01],
                               rtol=1e-15)
    assert s.methods["radau5"].newton_rtol == [1e-9, 1e-10]
    assert s.levels == [1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
    assert s.methods["dop853"].rtol == [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]
    assert s.peers == {"DOP853": [1e-6, 1e-8, 1e-10, 1e-12], "Radau": [1e-5, 1e-7, 1e-9, 1e-11],
                       "LSODA": [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12],
                       "CVODE": [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]}
    assert [x.method for x in plan if x.solver == "CVODE"] == ["sundials-CVODE-BDF"] * 8
    assert (s.reference.method, s.reference.rtol, s.reference.check_method) == (
        "radau13", 1e-14, "dop853")
    for name in ("radau9", "radau13", "radau"):  # the new methods down to rtol 1e-13
        assert min(s.methods[name].rtol) == 1e-13
    assert s.repeats == 5 and not s.quick and s.atol_ratio == 0.01


BAD = [
    (["study.methods.rk4.steps_per_output=[0]"], "study.methods.rk4.steps_per_output[0]",
     ">= 1"),
    (["study.methods.rk4.steps_per_output=[1.5]"], "study.methods.rk4.steps_per_output",
     "Integer"),
    (["study.methods.dopri5.rtol=[1e-6,0]"], "study.methods.dopri5.rtol[1]", "(0, 1)"),
    (["study.methods.dopri5.rtol=[]"], "study.methods.dopri5.rtol", "at least 1 tolerance"),
    (["study.methods.rk4.rtol=[1e-6]"], "study.methods.rk4.rtol", "fixed step"),
    (["study.full_state.radau5.rtol=[3e-8]"], "study.full_state.radau5.rtol[0]", "swept"),
    (["study.peers.LSODA=[2.0]"], "study.peers.LSODA[0]", "(0, 1)"),
    (["study.methods.radau5.newton_rtol=[0]"], "study.methods.radau5.newton_rtol[0]",
     "(0, 1)"),
    (["study.methods.rk4.newton_rtol=[1e-9]"], "study.methods.rk4.newton_rtol", "explicit"),
    (["study.methods.radau5.steps_per_output=[]"], "study.methods.radau5.newton_rtol",
     "fixed steps"),
    (["study.full_state.radau5.newton_rtol=[1e-9]"], "study.full_state.radau5.newton_rtol",
     "base's tolerances"),
    (["+study.peers.BDF=[1e-6]"], "study.peers.BDF", "must be a peer"),
    (["study.levels=[]"], "study.levels", "at least 1"),
    (["study.levels=[1e-6,-1e-8]"], "study.levels[1]", "> 0"),
    (["study.repeats=0"], "study.repeats", ">= 1"),
    (["study.budget_s=0"], "study.budget_s", "> 0"),
    (["study.atol_ratio=0"], "study.atol_ratio", "(0, 1]"),
    (["study.reference.method=rk4"], "study.reference.method", "adaptive"),
    (["study.reference.fixed_steps_per_output=0"], "study.reference.fixed_steps_per_output",
     ">= 1"),
    (["study.jit.methods=[euler]"], "study.jit.methods[0]", "registered method"),
    (["study.jit.t_end=0.05"], "study.jit.t_end", "output_interval"),
    (["bases.en02.sphere.mu=-1"], "bases.en02.sphere.mu", "must be >= 0"),
    (["bases.en02.study.duration=2.05"], "bases.en02.study.duration", "output_interval"),
]


@pytest.mark.parametrize(("overrides", "key", "rule"), BAD)
def test_a_bad_value_is_refused_naming_its_key(overrides, key, rule) -> None:
    with pytest.raises(ConfigError) as info:
        resolve("work_precision", overrides)
    assert key in str(info.value) and rule in str(info.value), str(info.value)
    assert info.value.key.startswith(key.split("[")[0])


@pytest.mark.parametrize(("group", "name", "value", "rule"), [
    ("methods", "euler", {"rtol": [1e-6]}, "registered method"),
    ("full_state", "euler", {"rtol": [1e-6]}, "registered method"),
    ("peers", "BDF", [1e-6], "must be a peer"),
])
def test_an_unknown_method_in_a_config_file_is_refused(group, name, value, rule) -> None:
    """A grid for a method nobody registered (added in a yaml: OmegaConf cannot add a typed
    dict entry from the command line) is refused naming it."""
    from omegaconf import OmegaConf

    from creatio.pipeline.config import compose, validate

    data = OmegaConf.to_container(compose("work_precision"))
    data["study"][group][name] = value
    with pytest.raises(ConfigError) as info:
        validate(data)
    assert info.value.key == f"study.{group}.{name}" and rule in str(info.value)


def test_a_changed_grid_changes_the_hash(tiny) -> None:
    other = resolve("work_precision", [*TINY, "study.methods.dopri5.rtol=[1e-7]"])
    assert other.sha256 != tiny.sha256
    assert resolve("work_precision", TINY).sha256 == tiny.sha256
    assert resolve("work_precision").sha256 not in (tiny.sha256, other.sha256)


def test_quick_keeps_every_third_setting_and_the_full_state_partners() -> None:
    cfg = resolve("work_precision", ["study.quick=true"]).obj
    plan = wp.settings(cfg.study, wp.base_problem(cfg, "en02"))
    assert [s.value for s in plan if s.method == "radau5"] == [1e-4, 1e-7, 1e-8, 1e-10]
    assert len([s for s in plan if s.method == "scipy-LSODA"]) == 3


def test_repeats_are_interleaved_round_robin() -> None:
    """Round k times every run that still has repeats, starting at run k mod n (so no run
    always follows the same one); each repeat is kept where it was taken."""
    order: list[str] = []

    def run(name: str, count: int) -> wp.Run:
        s = wp.Setting("native", name, "rk4", "dt", 0.1)

        def call() -> float:
            order.append(name)
            return float(len(order))

        return wp.Run(s, call, 0.0, count, {})

    times = wp.round_robin([run("a", 2), run("b", 3), run("c", 1)])
    assert order == ["a", "b", "c", "b", "a", "b"]
    np.testing.assert_array_equal(times, [[1, 5, np.nan], [2, 4, 6], [3, np.nan, np.nan]])
    assert wp._repeat_count(0.01, 5, 2.0) == 5
    assert wp._repeat_count(0.5, 5, 2.0) == 4 and wp._repeat_count(5.0, 5, 2.0) == 1


def test_harness_measures_the_native_error_on_the_same_solution(tiny) -> None:
    """A native run's states pushed through the peer harness's centre formula give the
    same error against the reference as the native path measures."""
    from creatio.dynamics.peer_solvers import centre_grid

    base = wp.base_problem(tiny.obj, "en02")
    ref, evidence = wp.reference(base, tiny.obj.study.reference)
    assert evidence["check_adaptive_max_diff_m"] < 1e-12
    assert evidence["check_fixed_max_diff_m"] < 1e-12
    native = simulate(base.replace(method="dopri5", rtol=1e-6, atol=1e-8))
    h = native.histories
    states = np.zeros((h.t.size, base.initial_state(True, False).size))
    states[:, 0] = h.R
    states[:, 1] = h.alpha
    X = centre_grid(base, h.t, states, False)
    assert wp.errors(X, ref) == pytest.approx(wp.errors(h.X, ref), rel=1e-9, abs=1e-15)
    assert 0 < wp.errors(h.X, ref)[0] < 1e-6
    assert wp.errors(X[:-1], ref) == (math.inf, math.inf)


def _entry(method: str, group: str, setting: str, error: float, times: list[float],
           state: int = 12) -> dict:
    return {"study": "en02", "method": method, "group": group, "setting": setting,
            "error_m": error, "time_s": min(times), "time_max_s": max(times),
            "time_median_s": float(np.median(times)), "time_spread": max(times) / min(times),
            "state_size": state}


def test_overlapping_comparisons_and_negative_savings_are_flagged() -> None:
    from creatio.reports.work_precision import summary

    runs = [
        _entry("dop853", "native", "rtol=1e-08", 1e-12, [1.0, 1.5]),
        _entry("dopri5", "native", "rtol=1e-09", 1e-12, [1.2, 1.3]),
        _entry("scipy-LSODA", "peer", "rtol=1e-10", 1e-12, [1.4, 2.0]),
        _entry("scipy-DOP853", "peer", "rtol=1e-12", 1e-13, [50.0, 51.0]),
        _entry("radau5", "native", "rtol=1e-08", 1e-11, [2.0, 2.1]),
        _entry("radau5-full", "full", "rtol=1e-08", 1e-11, [1.9, 2.2], 14),
        _entry("rk4-mu0", "mu0", "dt=0.002", math.nan, [3.0, 3.1], 4),
        _entry("rk4-mu0-full", "mu0", "dt=0.002", math.nan, [2.0, 2.1], 14),
    ]
    evidence = {"check_adaptive_max_diff_m": 1e-15, "check_fixed_max_diff_m": 1e-14}
    s = summary(runs, evidence, [1e-11, 1e-12, 1e-13, 1e-14], 10.0)
    level11, level12, level13, level14 = s["fastest"]
    assert level11["native"]["method"] == "dop853" and level11["tied_with_runner_up"]
    assert level11["spreads_overlap"] and level11["speed_up"] == pytest.approx(1.4)
    assert level13["native"] is None
    assert not level14["resolved"]
    assert level12["resolved"]
    rows = {m["run"]: m for m in s["minimal_state"]}
    assert set(rows) == {"radau5 rtol=1e-08", "rk4-mu0 dt=0.002"}
    assert rows["radau5 rtol=1e-08"]["saved"] < 0 and rows["radau5 rtol=1e-08"]["flag"]
    assert rows["rk4-mu0 dt=0.002"]["saved"] < 0 and "noise" in rows["rk4-mu0 dt=0.002"]["flag"]


def test_a_newly_registered_method_is_benchmarked_without_editing(tiny, monkeypatch) -> None:
    """Heun's method registered at run time appears in the plan (unlisted grid) and runs."""
    heun = Method("heun", EXPLICIT, 2, None, "Heun's method, fixed step",
                  Tableau(np.array([0.0, 1.0]), np.array([[0.0, 0.0], [1.0, 0.0]]),
                          np.array([0.5, 0.5])))
    monkeypatch.setitem(METHODS, "heun", heun)
    cfg = dataclasses.replace(tiny.obj, study=dataclasses.replace(
        tiny.obj.study, peers={}, full_state={}, minimal_state=False))
    cfg.check()
    plan = [s for s in wp.settings(cfg.study, wp.base_problem(cfg, "en02"))
            if s.solver == "heun"]
    assert [s.label for s in plan] == ["dt=0.001", "dt=0.002"]
    ds = wp.run(cfg, "en02")
    rows = np.flatnonzero(ds.solver.values == "heun")
    assert rows.size == 2
    assert np.all(ds.status.values[rows] == "ok")
    assert 0 < ds.error_m.values[rows[0]] < ds.error_m.values[rows[1]] < 1e-4
    assert np.all(np.isfinite(ds.times_s.values[rows]))


def test_tiny_run_end_to_end(tiny, tmp_path) -> None:
    """run_resolved: one dataset per base with provenance, the three report files, every
    registered method in the data, every repeat recorded, JIT times on the first part."""
    from creatio.pipeline.run import run_resolved
    from creatio.store.netcdf import read_dataset

    root = run_resolved(tiny, data_dir=tmp_path)
    entry = tiny.entry
    paths = entry.datasets(str(root), tiny.obj)
    assert [p.rsplit("/", 1)[1] for p in paths] == ["work_precision_en02.nc",
                                                    "work_precision_en02r.nc"]
    for i, p in enumerate(paths):
        ds, config = read_dataset(p)
        assert ds.attrs["config_sha256"] == tiny.sha256
        assert config["study"]["id"] == "work_precision"
        assert set(METHODS) <= set(ds.solver.values[ds.group.values == "native"])
        assert ("jit" in ds.attrs) == (i == 0)
        assert ds.sizes["repeat"] == 2
        ok = ds.group.values != "mu0"
        assert np.all(np.isfinite(ds.error_m.values[ok]))
        np.testing.assert_array_equal(ds.time_s.values, np.nanmin(ds.times_s.values, axis=1))
        assert {"machine", "reference", "load_before_timing", "load_after_timing",
                "peers_unavailable"} <= set(ds.attrs)
    reports = entry.reports(str(root))
    assert [r.rsplit("/", 1)[1] for r in reports] == ["work_precision.json",
                                                      "work_precision.md",
                                                      "work_precision.png"]
    assert all(Path(r).stat().st_size > 0 for r in reports)
    report = json.loads((root / "benchmarks" / "work_precision.json").read_text())
    keys = {"study", "method", "setting", "error_m", "final_error_m", "time_s",
            "time_median_s", "time_spread", "rhs_evals", "steps", "status"}
    assert all(keys <= set(e) for e in report["entries"])
    assert set(report["studies"]) == {"en02", "en02r"}
    assert {e["method"] for e in report["entries"]} >= set(METHODS)
    md = (root / "benchmarks" / "work_precision.md").read_text()
    assert "## en02r" in md and "fastest native run" in md and "## All runs" in md
    assert md.count("Load average (1, 5, 15 min) before timing") == 2
    assert set(report["frontier"]) == {"en02", "en02r"}
    assert (root / "benchmarks" / "work_precision.png").stat().st_size > 10_000


def test_verdict_tells_apart_only_ranges_that_do_not_overlap() -> None:
    """faster / slower only when [min, max] ranges are apart; touching ranges are noise."""
    from creatio.reports.work_precision import verdict

    native = _entry("radau5", "native", "rtol=1e-08", 1e-10, [1.0, 1.2, 1.1])
    assert verdict(native, _entry("scipy-LSODA", "peer", "rtol=1e-10", 1e-10,
                                  [1.3, 4.0])) == "faster"
    assert verdict(native, _entry("sundials-CVODE-BDF", "peer", "rtol=1e-10", 1e-10,
                                  [0.5, 0.9])) == "slower"
    assert verdict(native, _entry("scipy-LSODA", "peer", "rtol=1e-10", 1e-10,
                                  [1.2, 1.3])) == "within noise"
    assert verdict(native, _entry("scipy-LSODA", "peer", "rtol=1e-10", 1e-10,
                                  [0.2, 9.0])) == "within noise"


def test_frontier_table_shows_median_spread_verdict_and_flags() -> None:
    """The markdown frontier row carries min, median and spread of both sides, the verdict,
    and the overlap flag; a peer faster beyond the noise is called slower, not hidden."""
    from creatio.reports.work_precision import _frontier, summary

    runs = [
        _entry("radau5-fixed", "native", "dt=0.05", 5e-11, [8e-3, 9e-3, 1.2e-2]),
        _entry("dop853", "native", "rtol=1e-10", 5e-11, [2e-2, 2.1e-2]),
        _entry("sundials-CVODE-BDF", "peer", "rtol=1e-11", 6e-11, [1e-1, 1.1e-1]),
        _entry("scipy-LSODA", "peer", "rtol=1e-08", 5e-9, [1e-3, 1.5e-3]),
    ]
    evidence = {"check_adaptive_max_diff_m": 1e-14, "check_fixed_max_diff_m": 1e-14}
    s = summary(runs, evidence, [1e-8, 1e-10], 10.0)
    low, high = s["fastest"]
    assert low["verdict"] == "slower" and low["peer"]["method"] == "scipy-LSODA"
    assert high["verdict"] == "faster" and high["peer"]["method"] == "sundials-CVODE-BDF"
    assert high["native"]["time_max_s"] == pytest.approx(1.2e-2)
    lines = _frontier(s["fastest"], 10.0)
    assert "median (ms)" in lines[0] and "verdict" in lines[0]
    assert "| faster |" in lines[3] and "| slower |" in lines[2]
    assert "| radau5-fixed dt=0.05 | 8 | 9 | 1.5 |" in lines[3]  # min, median, spread


def test_a_peer_that_is_not_installed_is_left_out_and_said_so(tiny, monkeypatch) -> None:
    """Without scikit-sundae the CVODE rows are dropped and the dataset names the peer."""
    import creatio.dynamics.peer_solvers as peers

    monkeypatch.setattr(peers, "available", lambda m: m in peers.PEERS)
    cfg = dataclasses.replace(tiny.obj, study=dataclasses.replace(
        tiny.obj.study, peers={"CVODE": [1e-8], "LSODA": [1e-8]}, full_state={},
        minimal_state=False, repeats=1))
    cfg.check()
    ds = wp.run(cfg, "en02")
    peer_rows = set(ds.method.values[ds.group.values == "peer"])
    assert peer_rows == {"scipy-LSODA"}
    assert json.loads(ds.attrs["peers_unavailable"]) == ["CVODE"]


def test_cvode_harness_measures_the_native_error_on_the_same_solution(tiny) -> None:
    """The CVODE peer returns states on the native output grid, in the native state layout,
    so the same centre formula and error give the native solution's centres: at tight
    tolerances both runs' centres agree far below the benchmark's levels, and the error
    prepare_peer records is the harness's error against the same reference."""
    pytest.importorskip("sksundae")
    from creatio.dynamics.peer_solvers import centre_grid, solve_peer

    base = wp.base_problem(tiny.obj, "en02")
    ref, _ = wp.reference(base, tiny.obj.study.reference)
    native = simulate(base.replace(method="radau5", rtol=1e-11, atol=1e-13))
    theirs = solve_peer(base, "CVODE", 1e-11, 1e-13)
    assert theirs.status == "ok" and theirs.steps == -1 and theirs.rhs_evals > 0
    np.testing.assert_array_equal(theirs.t, native.histories.t)
    np.testing.assert_array_equal(theirs.y[0], base.initial_state(True, False))
    np.testing.assert_allclose(theirs.y[:, 0], native.histories.R, rtol=0, atol=1e-8)
    np.testing.assert_allclose(theirs.y[:, 1], native.histories.alpha, rtol=0, atol=1e-8)
    X = centre_grid(base, theirs.t, theirs.y, False)
    np.testing.assert_allclose(X, native.histories.X, rtol=0, atol=1e-8)
    setting = wp.Setting("peer", wp.peer_label("CVODE"), "CVODE", "rtol", 1e-8)
    run = wp.prepare_peer(base, setting, ref, tiny.obj.study)
    again = solve_peer(base, "CVODE", 1e-8, 1e-8 * tiny.obj.study.atol_ratio)
    assert run.record["error_m"] == wp.errors(centre_grid(base, again.t, again.y, False),
                                              ref)[0]
    assert 1e-11 < run.record["error_m"] < 1e-6


def test_fixed_steps_also_run_at_each_newton_tolerance(tiny) -> None:
    """An implicit method's fixed step is planned at the base's tolerances, then at each
    newton_rtol, which the run's problem carries as rtol (atol = rtol x atol_ratio)."""
    cfg = resolve("work_precision", [*TINY, "study.methods.radau5.newton_rtol=[1e-9]"]).obj
    base = wp.base_problem(cfg, "en02")
    plan = [s for s in wp.settings(cfg.study, base) if s.method == "radau5-fixed"]
    assert [s.label for s in plan] == ["dt=0.02", "dt=0.02 newton_rtol=1e-09"]
    plain, newton = (wp.native_problem(base, s, cfg.study.atol_ratio) for s in plan)
    plain, newton, base = plain.solver, newton.solver, base.solver
    assert (plain.rtol, plain.atol) == (base.rtol, base.atol)
    assert (newton.rtol, newton.atol) == (1e-9, pytest.approx(1e-11))
    assert newton.dt == plain.dt == 0.02 and newton.fixed_step and newton.method == "radau5"


def test_frontier_against_cvode_names_cvode_and_shows_the_counts() -> None:
    """The CVODE table compares the fastest native run with CVODE BDF itself even when
    another peer is faster, and prints the work counts beside the times."""
    from creatio.reports.work_precision import _cvode_frontier, summary

    native = _entry("radau9", "native", "rtol=1e-10", 5e-11, [4e-3, 5e-3])
    native.update(rhs_evals=20440, jacobians=976, lu_factorisations=979,
                  newton_iterations=2481, rejected_steps=0, steps=1202)
    cvode = _entry("sundials-CVODE-BDF", "peer", "rtol=1e-11", 6e-11, [8e-2, 9e-2])
    cvode.update(rhs_evals=30000, jacobians=400)
    runs = [native, cvode, _entry("scipy-LSODA", "peer", "rtol=1e-11", 6e-11, [2e-2, 3e-2])]
    evidence = {"check_adaptive_max_diff_m": 1e-14, "check_fixed_max_diff_m": 1e-14}
    row = summary(runs, evidence, [1e-10], 10.0)["fastest"][0]
    assert row["peer"]["method"] == "scipy-LSODA"
    assert row["cvode"]["method"] == "sundials-CVODE-BDF"
    assert row["speed_up_cvode"] == pytest.approx(20.0)
    assert row["verdict_cvode"] == "faster"
    lines = _cvode_frontier(summary(runs, evidence, [1e-10], 10.0)["fastest"])
    assert "| 20440 / 976 / 979 / 2481 / 0 |" in lines[2]
    assert "| 30000 / 400 |" in lines[2] and "| 20x |" in lines[2]
