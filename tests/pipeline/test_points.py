"""EN-05's Sobol' sample under its accuracy budget (creatio.pipeline.points): a pilot picks
the loosest tolerance whose error on seeded points is within the budget, the batches run at
it, and the step that builds the dataset checks other seeded points rerun 100x tighter; a
deliberately loose setting is caught there and tightened; the indices agree with the
configured tolerance's within their bootstrap intervals. Small designs (N = 8: 64 runs)."""

from __future__ import annotations

import json
import logging
import math

import numpy as np
import pytest

from creatio.errors import ConfigError
from creatio.pipeline import points
from creatio.pipeline.config import resolve
from creatio.pipeline.sweep import SweepPlan, run_batch
from creatio.studies import en05
from creatio.studies.budget import Rung, subsample
from creatio.studies.en05_schema import ACCURACY_PREFIX

SMALL = ["study.sensitivity.base_sizes=[8]", "study.sensitivity.resamples=200"]


def _sample(root, *extra: str) -> tuple:
    resolved = resolve("en05", [*SMALL, *extra])
    return resolved, points.en05_sample(resolved, data_dir=str(root))


def _tight_outputs(sample, rung: Rung, idx) -> dict[str, np.ndarray]:
    """EN-05's outputs of points idx run alone at rung, each config composed from its
    overrides by Hydra (not the sample's own runner)."""
    from creatio.pipeline.config import resolve as compose_point
    from creatio.studies import sphere

    plan = sample.plan()
    out = {k: np.full(len(idx), np.nan) for k in en05.OUTPUTS}
    for i, index in enumerate(idx):
        changes = list(plan.overrides(int(index)))
        T = next(v for k, v in (c.split("=") for c in changes) if k == "phases.T")
        cfg = compose_point("en02", [*points.merged_overrides(plan.base, rung.overrides()),
                                     *changes, f"study.duration={T}"]).obj
        row = en05.point_outputs(sphere.run(cfg, cfg.solver.dt), cfg)
        for k in en05.OUTPUTS:
            out[k][i] = row[k]
    return out


@pytest.fixture(scope="module")
def budgeted(tmp_path_factory):
    """The small sample under the default budget: pilot, batches, the checked dataset."""
    root = tmp_path_factory.mktemp("en05_budget")
    resolved, sample = _sample(root)
    points.pilot(sample)
    plan = sample.plan(sample.rung())
    for k in range(plan.n_batches):
        run_batch(plan, k)
    return resolved, sample, points.sobol_dataset(resolved, sample)


def test_the_pilot_chooses_a_looser_rung_and_the_budget_holds_on_the_check(budgeted):
    """The pilot's rung is looser than the configured radau5 rtol 1e-8; the check's points
    (seeded, not the pilot's) rerun 100x tighter, here independently, composed by Hydra,
    differ from the sample's rows by what the dataset records, within each budget."""
    resolved, sample, ds = budgeted
    record = sample.pilot_record()
    rung = sample.rung()
    assert record["configured"] == {"method": "radau5", "rtol": 1e-8, "atol": 1e-10}
    assert rung.method == "radau5" and rung.rtol > 1e-8
    assert ds.attrs["sample_base_overrides"].endswith(" ".join(rung.overrides()))
    check, noise = points.accuracy(ds.attrs)
    assert check.ok and check.tightened == 0 and check.points == 16
    idx = subsample(sample.n_points, 16, resolved.obj.study.sensitivity.seed + 1)
    assert not set(idx) <= set(record["points"])  # another subsample than the pilot's
    few = idx[:4]  # four of the check's points, each composed and run alone
    tight = _tight_outputs(sample, rung.tighter(100.0), few)
    assert check.checked, "no output was checked"
    for k in check.checked:
        err = float(np.max(np.abs(ds[k].values[few] - tight[k])))
        assert err <= check.observed[k] * (1 + 1e-6) <= check.budget[k], k
        sd = float(np.std(ds[k].values[np.isfinite(ds[k].values)]))
        assert check.budget[k] == pytest.approx(1e-3 * sd, rel=1e-12), k
    assert set(check.budget) | set(noise) == set(en05.OUTPUTS)


def test_a_deliberately_loose_rung_is_caught_on_the_check_and_tightened(tmp_path, caplog):
    """The pilot's choice replaced by rtol 1e-3 (looser than any pilot would pick): the
    check finds the budget broken, tightens 10x and reruns every point until it holds,
    says so in the log, records the tightenings and the final rung's overrides."""
    import pathlib

    resolved, sample = _sample(tmp_path, "study.sensitivity.base_sizes=[4]")
    path = points.pilot(sample)
    record = json.loads(pathlib.Path(path).read_text())
    assert record["rung"]["rtol"] < 1e-3
    loose = Rung("radau5", 1e-3, 1e-5)
    record["rung"] = {"method": "radau5", "rtol": 1e-3, "atol": 1e-5}
    pathlib.Path(path).write_text(json.dumps(record))
    assert sample.rung() == loose
    plan = sample.plan(loose)
    for k in range(plan.n_batches):
        run_batch(plan, k)
    with caplog.at_level(logging.INFO, logger="creatio"):
        ds = points.sobol_dataset(resolved, sample)
    check, _ = points.accuracy(ds.attrs)
    assert check.tightened >= 1 and check.ok
    assert check.rung.rtol == pytest.approx(1e-3 / 10 ** check.tightened)
    assert "budget is broken on the check" in caplog.text
    assert f"solver.rtol={check.rung.rtol!r}" in ds.attrs["sample_base_overrides"]
    assert "tightened" in ds.attrs[f"{ACCURACY_PREFIX}describe"]


def test_indices_agree_with_the_configured_tolerance_within_their_intervals(budgeted,
                                                                            tmp_path):
    """The same design without a budget (every run at radau5 rtol 1e-8): each index of each
    resolved output of the budgeted sample lies within the bootstrap half-width of the
    configured one (and the other way round)."""
    resolved, sample, ds = budgeted
    plain, ref_sample = _sample(tmp_path, "study.sensitivity.budget=null")
    assert ref_sample.budget is None and ref_sample.rung_file is None
    ref = points.sobol_dataset(plain, ref_sample, compute_missing=True)
    assert ACCURACY_PREFIX + "outputs" not in ref.attrs
    _, noise = points.accuracy(ds.attrs)
    outs = [str(o) for o in ds.output.values]
    compared = 0
    for j, out in enumerate(outs):
        if out in noise or not np.all(np.isfinite(ref.S1.values[-1, j])):
            continue
        for key in ("S1", "ST"):
            a, b = ds[key].values[-1, j], ref[key].values[-1, j]
            half = np.maximum(ds[f"{key}_conf"].values[-1, j], ref[f"{key}_conf"].values[-1, j])
            assert np.all(np.abs(a - b) <= half), (out, key, a, b, half)
            compared += a.size
    assert compared >= 4 * 2 * 6


def test_a_design_float_is_read_as_hydra_reads_it():
    """PointPlan.typed_axes' shortcut (a float as Python writes it) gives what Hydra's
    grammar gives, types included; anything else still goes through the grammar."""
    values = ("0.05", "1e-05", "180.0", "5", "abc", "inf", "1.0000000000000002")
    p = points.PointPlan("en02", (("sphere.mu", values),), (), "x", "/tmp/x", 1)
    s = SweepPlan("en02", (("sphere.mu", values),), (), "x", "/tmp/x", 1)
    fast, slow = p.typed_axes()[0][1], s.typed_axes()[0][1]
    assert [type(v) for v in fast] == [type(v) for v in slow]
    assert all(a == b for a, b in zip(fast, slow, strict=True))


def test_a_point_row_from_the_raw_run_equals_the_outputs_of_its_dataset(tmp_path):
    """A batch row of EN-05 is read from the point's raw run (en05.point_row), never its
    EN-02 dataset: the same status and the same floats as the outputs read from the dataset
    of the study's first part and its summary (what the rows held before), for two points
    of a batch and a run its evaluation budget stops (NaN, carried 0); a point the model
    refuses is NaN with status invalid in the batch."""
    from creatio.pipeline.sweep import _base, point_changes
    from creatio.reports import summary
    from creatio.studies import registry
    from creatio.studies.schema import vary

    _, sample = _sample(tmp_path)
    plan = points.PointPlan(
        "en02", (("sphere.mu", ("0.1", "0.25", "-0.1")), ("sphere.eps", ("0.01", "0.003",
                                                                       "0.01"))),
        tuple(points.merged_overrides(sample.base, Rung("radau5", 1e-6, 1e-8).overrides())),
        "three", str(tmp_path / "three"), 3, outputs="creatio.studies.en05:point_row")
    run_batch(plan, 0)
    rows = points.collect(plan, list(en05.OUTPUTS))
    base = _base(plan)
    configs = [vary(base.obj, point_changes(plan, base, i)) for i in (0, 1)]
    configs.append(vary(configs[0], {"solver.max_rhs_evals": 2000}))
    entry = registry.get("en02")
    for i, cfg in enumerate(configs):
        ds = entry.run_function()(cfg, **entry.parts(cfg)[0].args)
        ds.attrs["study"] = "en02"
        want = {"status": summary(ds)["status"], **en05.point_outputs(ds, cfg)}
        got = en05.point_row(cfg) if i == 2 else {k: rows[k][i] for k in want}
        assert got["status"] == want["status"] == ("ok" if i < 2 else "budget_exceeded")
        np.testing.assert_array_equal([got[k] for k in en05.OUTPUTS],
                                      [want[k] for k in en05.OUTPUTS])
    assert math.isnan(got["final_radius"]) and got["carried"] == 0.0
    assert rows["status"][2] == "invalid" and "sphere.mu" in rows["message"][2]
    assert all(math.isnan(rows[k][2]) for k in en05.OUTPUTS)


def test_a_batch_job_reads_the_design_the_pilot_kept_and_only_under_its_key(tmp_path,
                                                                           monkeypatch):
    """The pilot keeps the design's values in the point store; a job that finds them under
    its key (sample, code, library versions) takes them, SALib not called; a file under
    another key is ignored and the design computed anew; the same array every way."""
    _, sample = _sample(tmp_path)
    points._DESIGNS.clear()
    computed = sample.inputs()
    assert computed.shape == (8 * 8, 6) and not (tmp_path / "sweeps").exists()
    sample.inputs(keep=True)
    points._DESIGNS.clear()

    def refuse(*args, **kwargs):
        raise AssertionError("the design was computed, not read")

    monkeypatch.setattr(en05, "sobol_design", refuse)
    np.testing.assert_array_equal(sample.inputs(), computed)
    np.savez(sample.design_file, X=computed + 1.0, key=np.array("another key"))
    points._DESIGNS.clear()
    with pytest.raises(AssertionError, match="computed, not read"):
        sample.inputs()
    monkeypatch.undo()
    np.testing.assert_array_equal(sample.inputs(), computed)
    points._DESIGNS.clear()


def test_overrides_merge_later_keys_over_earlier_ones():
    """A rung's solver.rtol replaces the base's; the group override keeps one place."""
    got = points.merged_overrides(["sphere.b=0.13", "solver=radau5", "solver.rtol=1e-9"],
                                  Rung("radau5", 1e-6, 1e-8).overrides())
    assert got == ["sphere.b=0.13", "solver=radau5", "solver.rtol=1e-06", "solver.atol=1e-08"]


def test_a_batch_needs_the_pilot_first_and_a_fixed_step_sample_has_no_budget(tmp_path):
    """Without rung.json the sample refuses in one line naming the budget; an rk4 sample
    under a budget is refused by the pilot (no tolerance to loosen)."""
    _, sample = _sample(tmp_path)
    with pytest.raises(ConfigError, match="study.sensitivity.budget.*pilot"):
        sample.rung()
    _, rk4 = _sample(tmp_path, "study.sensitivity.overrides=['solver=rk4','solver.dt=0.0005']")
    with pytest.raises(ConfigError, match="adaptive solver"):
        points.pilot(rk4)
    assert not (tmp_path / "sweeps").exists() or not [
        f for f in (tmp_path / "sweeps").rglob("*") if f.is_file()]


def test_unresolved_outputs_are_those_no_rung_can_resolve():
    """A spread within the configured rtol of the output's size, or a budget the configured
    tolerance misses, is unresolved; a spread well above both is not."""
    y = np.array([1.0, 2.0, 3.0, 4.0])
    flat = 1.11 + 1e-10 * y
    budget = {"a": 1e-3 * float(np.std(y)), "b": 1e-3 * float(np.std(flat)),
              "c": 1e-3 * float(np.std(y))}
    spread = {"a": y, "b": flat, "c": y}
    tight = {"a": y, "b": flat, "c": y}
    configured = {"a": y + 1e-6, "b": flat, "c": y + 0.1}
    got = points.unresolved(configured, tight, spread, budget, 1e-8)
    assert set(got) == {"b", "c"} and "within the configured rtol" in got["b"]
    assert "exceeds its budget" in got["c"] and math.isclose(budget["a"], 1.118e-3,
                                                                  rel_tol=1e-3)
