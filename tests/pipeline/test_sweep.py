"""Parameter sweeps in batches: product expansion, batches equal to one run per point,
refused points, reuse of computed points, bounded planning, resumable batches."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr

from creatio.errors import ConfigError
from creatio.pipeline import config as pipeline_config
from creatio.pipeline.config import resolve
from creatio.pipeline.run import run_study
from creatio.pipeline.sweep import parse_axes, plan_sweep, run_batch, write_sweep
from creatio.reports import summary

REPO = Path(__file__).resolve().parents[2]
BASE = ["phases.T=2.0"]  # a 2 s cycle: every point takes milliseconds


def test_product_is_expanded_with_hydra_grammar(tmp_path):
    """2 x 3 axes give 6 points with every combination, in row-major order, in batches."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.15", "phases.T=range(2,5)"], BASE,
                      data_dir=str(tmp_path), batch_size=4)
    assert plan.axes == (("sphere.mu", ("0", "0.15")), ("phases.T", ("2", "3", "4")))
    assert plan.n_points == 6 and plan.n_batches == 2
    assert [plan.overrides(i) for i in range(3)] == [
        ("sphere.mu=0", "phases.T=2"), ("sphere.mu=0", "phases.T=3"),
        ("sphere.mu=0", "phases.T=4")]
    # dealt out in turn: batch k holds every n_batches-th point from k, each point once
    assert [list(plan.batch_range(k)) for k in range(2)] == [[0, 2, 4], [1, 3, 5]]
    assert plan.batches[1].endswith("/batches/b4-00001.nc")
    default = plan_sweep("en02", ["sphere.mu=0,0.15", "phases.T=range(2,5)"], BASE,
                         data_dir=str(tmp_path))
    assert default.name == plan.name and default.n_batches == 1  # batches of 20 at least
    many = plan_sweep("en02", ["sphere.mu=range(0,1,0.001)"], BASE, data_dir=str(tmp_path))
    assert many.n_points == 1000 and (many.n_batches, many.batch_size) == (8, 125)
    forty = plan_sweep("en02", ["phases.T=range(1,41)"], BASE, data_dir=str(tmp_path))
    assert (forty.n_points, forty.n_batches, forty.batch_size) == (40, 2, 20)
    more = plan_sweep("en02", ["phases.T=range(1,42)"], BASE, data_dir=str(tmp_path))
    assert (more.n_points, more.n_batches, more.batch_size) == (41, 2, 21)


def test_bad_sweeps_are_refused():
    """No axis, a key swept twice, an unknown key, a broken base config, too many points."""
    with pytest.raises(ConfigError, match="at least one"):
        parse_axes([])
    with pytest.raises(ConfigError, match="swept twice"):
        parse_axes(["sphere.mu=0,1", "sphere.mu=2,3"])
    with pytest.raises(ConfigError, match="sphere.muu.*unknown key"):
        plan_sweep("en02", ["sphere.muu=0,0.1"], BASE)
    with pytest.raises(ConfigError, match="geometry.A.*base config of the sweep"):
        plan_sweep("en02", ["sphere.mu=0,0.1"], ["geometry.A=0.9"])
    with pytest.raises(ConfigError, match="1,000,000 points.*sweep_max_points"):
        plan_sweep("en02", ["sphere.mu=range(0,1000)", "phases.T=range(1,1001)"], BASE)


def test_base_overrides_are_judged_with_each_point(tmp_path):
    """dt = 5 ms is unstable at the default mu = 0.15 but fine at mu = 0 and 0.05."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.05"], ["solver.dt=0.005", "phases.T=2.0"],
                      data_dir=str(tmp_path))
    ds = xr.load_dataset(write_sweep(plan, compute_missing=True)["nc"])
    assert "invalid" not in set(ds.status.values)


def test_batched_points_equal_one_run_per_point(tmp_path):
    """Each batched point (one composition, values varied in place; T swept, so the study
    duration that follows it too) gives exactly the figures of its own composed run."""
    plan = plan_sweep("en02", ["sphere.mu=0.05,0.1", "phases.T=2,3"],
                      ["study.outputs=[trajectory]"], data_dir=str(tmp_path), batch_size=3)
    ds = xr.load_dataset(write_sweep(plan, compute_missing=True)["nc"])
    for i in range(plan.n_points):
        overrides = plan.overrides(i)
        alone = summary(run_study(resolve("en02", [*plan.base, *overrides])))
        point = ds.isel(sphere__mu=i // 2, phases__T=i % 2)
        assert point.status.item() == alone["status"]
        for key, value in alone.items():
            if isinstance(value, float) and not math.isnan(value):
                assert float(point[key]) == value, (overrides, key)
    assert float(ds.angular_displacement_deg.sel(sphere__mu=0.1, phases__T=3.0)) != float(
        ds.angular_displacement_deg.sel(sphere__mu=0.1, phases__T=2.0))


def test_kinematic_studies_can_be_swept(tmp_path):
    """A CT-02 sweep aggregates its scalar figures with status ok."""
    plan = plan_sweep("ct02", ["geometry.A=0.1,0.18"], ["study.inclinations_deg=[0,90]"],
                      data_dir=str(tmp_path / "data"))
    ds = xr.load_dataset(write_sweep(plan, compute_missing=True)["nc"])
    assert list(ds.status.values) == ["ok", "ok"]
    assert float(ds.j_min.sel(geometry__A=0.1)) == pytest.approx(0.68 - 0.1)


def test_a_refused_point_is_kept_not_run(tmp_path):
    """mu = 0.4 is beyond the RK4 friction limit at dt = 2 ms: recorded with its reason and
    the limit it broke, not run."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.4"], BASE, data_dir=str(tmp_path),
                      batch_size=2)
    batch = xr.load_dataset(run_batch(plan, 0))
    assert batch.attrs["computed"] == 1 and batch.attrs["refused"] == 1
    ds = xr.load_dataset(write_sweep(plan)["nc"])
    assert list(ds.status.values) == ["contact_lost", "invalid"]
    assert "stability limit" in str(ds.message.values[1])
    assert float(ds.dt_s[1]) > float(ds.stability_limit_dt_s[1])
    assert math.isnan(float(ds.cumulative_spin_deg[1]))


def test_adding_points_computes_only_the_new_ones(tmp_path):
    """A second sweep with one more value reuses every point the first computed."""
    first = plan_sweep("en02", ["sphere.mu=0,0.15"], BASE, data_dir=str(tmp_path),
                       batch_size=10)
    write_sweep(first, compute_missing=True)
    more = plan_sweep("en02", ["sphere.mu=0,0.1,0.15"], BASE, data_dir=str(tmp_path),
                      batch_size=10)
    assert more.name != first.name
    batch = xr.load_dataset(run_batch(more, 0))
    assert (batch.attrs["computed"], batch.attrs["reused"]) == (1, 2)
    a = xr.load_dataset(first.outputs[0])
    b = xr.load_dataset(write_sweep(more)["nc"])
    assert float(a.final_radius_m.sel(sphere__mu=0.15)) == float(
        b.final_radius_m.sel(sphere__mu=0.15))


def test_planning_a_large_sweep_composes_nothing_per_point(monkeypatch, tmp_path):
    """Planning 10^5 points composes as often as planning 4 (no caches: every composition
    counted): the axis keys and the first point are checked, nothing per point."""
    calls = []
    compose = pipeline_config.compose
    monkeypatch.setattr(pipeline_config, "compose",
                        lambda *a, **k: calls.append(a) or compose(*a, **k))
    monkeypatch.setattr(pipeline_config, "_resolve", pipeline_config._resolve.__wrapped__)
    monkeypatch.setenv("CREATIO_CONFIG_CACHE", "off")
    small = plan_sweep("en02", ["sphere.mu=range(0,2)", "phases.T=range(1,3)"], BASE,
                       data_dir=str(tmp_path))
    few = len(calls)
    plan = plan_sweep("en02", ["sphere.mu=range(0,500)", "phases.T=range(1,201)"], BASE,
                      data_dir=str(tmp_path))
    assert small.n_points == 4 and plan.n_points == 100_000 and plan.n_batches == 400
    assert len(calls) - few == few <= 3


def test_planning_a_sweep_imports_no_compiler():
    code = ("import sys; from creatio.pipeline.sweep import plan_sweep; "
            "plan_sweep('en02', ['sphere.mu=range(0,300)', 'phases.T=range(1,301)']); "
            "print('numba' in sys.modules, 'xarray' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "False"]


def test_an_interrupted_sweep_leaves_no_aggregate_and_resumes(tmp_path):
    """Batches are written whole (atomically); the aggregate needs them all; resuming runs
    only the missing ones."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.05,0.1"], BASE, data_dir=str(tmp_path),
                      batch_size=1)
    done = run_batch(plan, 0)
    stamp = done.stat().st_mtime_ns
    with pytest.raises(FileNotFoundError):
        write_sweep(plan)
    assert not Path(plan.outputs[0]).exists()
    ds = xr.load_dataset(write_sweep(plan, compute_missing=True)["nc"])
    assert done.stat().st_mtime_ns == stamp
    assert list(ds.status.values) == ["contact_lost"] * 3


def snakemake(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    """The project's Snakefile run in workdir."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(workdir),
         "-c", "2", *args], capture_output=True, text=True, timeout=900,
    )


def test_sweep_workflow_batches_and_reruns_only_new_points(tmp_path):
    """Two batch jobs for six points, one coordinate per key, statuses kept; with one more
    value the new batches compute only the new points."""
    sweep = 'sweep=["sphere.mu=0,0.15,0.4","study.initial.R=0.43,0.6"]'
    args = ("sweep", "--config", "study=en02", sweep, 'overrides=["phases.T=2.0"]',
            "sweep_batch=3")
    proc = snakemake(tmp_path, *args)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = proc.stdout + proc.stderr
    assert re.search(r"sweep_batch\s+2\n", out)
    (nc,) = (tmp_path / "data" / "sweeps").glob("en02-*/sweep.nc")
    ds = xr.load_dataset(nc)
    assert dict(ds.sizes) == {"sphere__mu": 3, "study__initial__R": 2}
    assert list(ds.sphere__mu.values) == [0.0, 0.15, 0.4]
    assert set(ds.status.sel(sphere__mu=0.4).values) == {"invalid"}
    assert all("stability limit" in m for m in ds.message.sel(sphere__mu=0.4).values)
    assert ds.status.sel(sphere__mu=0.15, study__initial__R=0.43).item() == "contact_lost"
    assert ds.cumulative_spin_deg.sel(sphere__mu=0.0).max() == 0.0  # no friction, no spin
    assert (nc.parent / "sweep.md").stat().st_size > 0
    assert (nc.parent / "sweep.png").stat().st_size > 0
    more = 'sweep=["sphere.mu=0,0.1,0.15,0.4","study.initial.R=0.43,0.6"]'
    proc = snakemake(tmp_path, "sweep", "--config", "study=en02", more,
                     'overrides=["phases.T=2.0"]', "sweep_batch=4")
    assert proc.returncode == 0, proc.stderr[-2000:]
    last = _last_lines(tmp_path)
    assert len(last) == 2  # 8 points in batches of 4
    computed = sum(int(re.search(r"(\d+) computed", ln).group(1)) for ln in last)
    reused = sum(int(re.search(r"(\d+) reused", ln).group(1)) for ln in last)
    assert (computed, reused) == (2, 4)  # the two mu = 0.1 points; four valid ones reused


def _last_lines(root: Path) -> list[str]:
    """The last progress line of each batch log of the second sweep (its b4- batches)."""
    lines = []
    for path in sorted((root / "data" / "sweeps").glob("*/logs/b4-*.log")):
        progress = [ln for ln in path.read_text().splitlines() if "points," in ln]
        lines.append(progress[-1])
    return lines


def test_hydra_multirun_gives_the_same_aggregate(tmp_path):
    """`creatio run -m` runs the sweep's batches in one process and writes the same aggregate,
    leaving no directory per point."""
    proc = subprocess.run(
        [sys.executable, "-m", "creatio.cli", "run", "-m", "study=en02", "sphere.mu=0,0.4",
         "phases.T=2.0"], cwd=tmp_path, capture_output=True, text=True, timeout=900,
        env={**os.environ},
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    name = plan_sweep("en02", ["sphere.mu=0,0.4"], BASE).name
    ds = xr.load_dataset(tmp_path / "data" / "sweeps" / name / "sweep.nc")
    assert list(ds.status.values) == ["contact_lost", "invalid"]
    assert "points," in proc.stderr  # progress
    assert not (tmp_path / "data" / "runs").exists() and not (tmp_path / "multirun").exists()
