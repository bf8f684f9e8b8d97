"""Parameter sweeps: product expansion, aggregation, refused points, incremental reruns."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr

from creatio.errors import ConfigError
from creatio.pipeline.sweep import parse_axes, plan_sweep

REPO = Path(__file__).resolve().parents[2]
BASE = ["phases.T=2.0"]  # a 2 s cycle: every point takes milliseconds


def test_product_is_expanded_with_hydra_grammar():
    """2 x 3 axes give 6 points with every combination, in row-major order."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.15", "phases.T=range(2,5)"], BASE)
    assert plan.axes == (("sphere.mu", ("0", "0.15")), ("phases.T", ("2", "3", "4")))
    assert len(plan.points) == 6
    assert [p.overrides for p in plan.points[:3]] == [
        ("sphere.mu=0", "phases.T=2"), ("sphere.mu=0", "phases.T=3"),
        ("sphere.mu=0", "phases.T=4")]
    assert len({p.resolved.sha256 for p in plan.points}) == 6
    assert all("/runs/" in p.dataset for p in plan.points)


def test_bad_sweeps_are_refused():
    """No axis, a key swept twice, or a broken base config: clear ConfigErrors."""
    with pytest.raises(ConfigError, match="at least one"):
        parse_axes([])
    with pytest.raises(ConfigError, match="swept twice"):
        parse_axes(["sphere.mu=0,1", "sphere.mu=2,3"])
    with pytest.raises(ConfigError, match="every point was refused.*geometry.A"):
        plan_sweep("en02", ["sphere.mu=0,0.1"], ["geometry.A=0.9"])


def test_base_overrides_are_judged_with_each_point():
    """dt = 5 ms is unstable at the default mu = 0.15 but fine at mu = 0 and 0.05."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.05"], ["solver.dt=0.005", "phases.T=2.0"])
    assert all(p.valid for p in plan.points)


def test_kinematic_studies_can_be_swept(tmp_path):
    """A CT-02 sweep aggregates its scalar figures with status ok."""
    from creatio.pipeline.sweep import write_sweep

    plan = plan_sweep("ct02", ["geometry.A=0.1,0.18"], ["study.inclinations_deg=[0,90]"],
                      data_dir=str(tmp_path / "data"))
    from creatio.pipeline.run import compute_dataset

    for p in plan.points:
        compute_dataset(p.resolved, Path(p.dataset))
    ds = xr.load_dataset(write_sweep(plan)["nc"])
    assert list(ds.status.values) == ["ok", "ok"]
    assert float(ds.j_min.sel(geometry__A=0.1)) == pytest.approx(0.68 - 0.1)


def test_a_refused_point_is_kept_not_run():
    """mu = 0.4 is beyond the RK4 friction limit at dt = 2 ms: recorded, no job."""
    plan = plan_sweep("en02", ["sphere.mu=0,0.4"], BASE)
    ok, refused = plan.points
    assert ok.valid and not refused.valid
    assert "stability limit" in refused.error
    assert plan.datasets == [ok.dataset]


def snakemake(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    """The project's Snakefile run in workdir."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(workdir),
         "-c", "2", *args], capture_output=True, text=True, timeout=900,
    )


def test_sweep_workflow_aggregates_and_reruns_only_new_points(tmp_path):
    """One job per point, one coordinate per key, statuses kept; one new point = one job."""
    sweep = 'sweep=["sphere.mu=0,0.15,0.4","study.initial.R=0.43,0.6"]'
    args = ("sweep", "--config", "study=en02", sweep, 'overrides=["phases.T=2.0"]')
    proc = snakemake(tmp_path, *args)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = proc.stdout + proc.stderr
    assert re.search(r"study_dataset\s+4\n", out)  # 2 x 3 points, the two mu = 0.4 refused
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
    dry = snakemake(tmp_path, "sweep", "-n", "--config", "study=en02", more,
                    'overrides=["phases.T=2.0"]')
    assert dry.returncode == 0, dry.stderr[-2000:]
    text = dry.stdout + dry.stderr
    assert re.search(r"study_dataset\s+2\n", text)  # the new mu value, at both radii
    assert "sweep_aggregate        1" in text


def test_hydra_multirun_gives_the_same_aggregate(tmp_path):
    """`creatio run -m` runs the points with Hydra and writes the same sweep aggregate."""
    proc = subprocess.run(
        [sys.executable, "-m", "creatio.cli", "run", "-m", "study=en02", "sphere.mu=0,0.4",
         "phases.T=2.0"], cwd=tmp_path, capture_output=True, text=True, timeout=900,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    name = plan_sweep("en02", ["sphere.mu=0,0.4"], BASE).name
    ds = xr.load_dataset(tmp_path / "data" / "sweeps" / name / "sweep.nc")
    assert list(ds.status.values) == ["contact_lost", "invalid"]
