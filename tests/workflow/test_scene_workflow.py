"""An explorable scene through Snakemake: its family in batch jobs, computed once; a changed
axis computes only its new members (the rest come from data/scenes/members/)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from creatio.scenes.plan import SceneRuns

REPO = Path(__file__).resolve().parents[2]
SHORT = "phases.T=12"  # a 12 s cycle: 6,000 RK4 steps a member


def snakemake(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(workdir),
         "-c", "2", *args], capture_output=True, text=True, timeout=900)


def _build(workdir: Path, axis: str) -> tuple[Path, subprocess.CompletedProcess]:
    overrides = [SHORT, f"scene.axes.sphere.mu={axis}", "scene.axes.phases.T=null"]
    plan = SceneRuns(overrides, ["en02"]).plans["en02"]
    target = f"{plan.root}/scenes/en02/scene.nc"
    config = ["--config", f"overrides={overrides!r}".replace("'", '"'), 'scenes=["en02"]']
    return workdir / target, snakemake(workdir, target, *config)


def test_a_family_is_computed_once_and_a_changed_axis_computes_only_the_new(tmp_path):
    from creatio.store.netcdf import read_dataset

    nc, proc = _build(tmp_path, "0.1,0.2,0.4")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stderr.count("rule scene_family_batch:") == 2  # 5 members in 2 batch jobs
    ds, _ = read_dataset(nc)
    assert list(ds.family_sphere__mu.values) == [0.1, 0.15, 0.2, 0.4]
    assert (ds.attrs["family_computed"], ds.attrs["family_reused"],
            ds.attrs["family_refused"]) == (3, 0, 1)
    again = snakemake(tmp_path, str(nc.relative_to(tmp_path)), "-n", "--config",
                      f'overrides=["{SHORT}","scene.axes.sphere.mu=0.1,0.2,0.4",'
                      '"scene.axes.phases.T=null"]', 'scenes=["en02"]')
    assert again.returncode == 0 and "Nothing to be done" in again.stdout + again.stderr
    nc2, proc = _build(tmp_path, "0.1,0.2,0.25,0.4")
    assert proc.returncode == 0, proc.stderr[-3000:]
    ds2, _ = read_dataset(nc2)
    assert (ds2.attrs["family_computed"], ds2.attrs["family_reused"],
            ds2.attrs["family_refused"]) == (1, 3, 1)
    assert len(list((tmp_path / "data" / "scenes" / "members").glob("*.nc"))) == 4
