"""Every script of scripts/ runs: each in its fast mode, as a user would start it (the quick
modes measure nothing worth keeping; they catch a script that no longer runs, as
bench_en02.py did when the driver's specialisations changed)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _run(*args: str, timeout: float = 1800) -> str:
    """Run a script from the repository root; its stdout (the run must succeed)."""
    proc = subprocess.run([*args], cwd=REPO, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ))
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def test_bench_en02_quick() -> None:
    out = _run(sys.executable, "scripts/bench_en02.py", "--quick")
    assert "this process: first simulate" in out
    assert out.count("status ok") == 4 and "RHS evals" in out


def test_bench_kinematics_quick() -> None:
    out = _run(sys.executable, "scripts/bench_kinematics.py", "--quick")
    assert "ct02: median" in out and "en01: median" in out and "over 1 runs" in out


def test_radau_orders_quick() -> None:
    out = _run(sys.executable, "scripts/radau_orders.py", "--quick")
    assert out.count("| 1e-06 |") == 12 and "scipy Radau" not in out


def test_radau_thet_one_setting() -> None:
    out = _run(sys.executable, "scripts/radau_thet.py", "--studies", "en02", "--methods",
               "radau9", "--thet", "0.001", "--dense", "false", "--rtol", "1e-6",
               "--repeats", "1")
    rows = [line.split() for line in out.splitlines()[1:]]
    assert len(rows) == 1 and rows[0][:5] == ["en02", "radau9", "0.001", "False", "1e-06"]
    assert 0.0 < float(rows[0][5]) < 1e-5  # the error, m


def test_local_slurm_parses_and_refuses_an_unknown_command() -> None:
    """The script parses (bash -n); without a command it prints its usage and exits 2 (up,
    down and status need root and a cluster: tests/workflow/test_slurm.py runs them)."""
    _run("bash", "-n", "scripts/local-slurm.sh")
    proc = subprocess.run(["bash", "scripts/local-slurm.sh"], cwd=REPO, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2 and "usage:" in proc.stderr


@pytest.mark.slow
def test_bench_against_quick() -> None:
    """Exports HEAD beside this tree and times one round of each (compiles both)."""
    out = _run(sys.executable, "scripts/bench_against.py", "HEAD", "--quick")
    assert "en02:rk4" in out and "now/then" in out


@pytest.mark.slow
def test_bench_workflow_quick() -> None:
    out = _run(sys.executable, "scripts/bench_workflow.py", "--quick")
    assert "snakemake all -n (creatio planning inside)" in out


@pytest.mark.slow
def test_scene_costs_one_repeat(tmp_path: Path) -> None:
    out = _run(sys.executable, "scripts/scene_costs.py", "--repeats", "1", "--out",
               str(tmp_path / "costs.md"))
    assert (tmp_path / "costs.md").exists() and out.strip()


@pytest.mark.slow
def test_target_cpu_counts_the_workers_jobs() -> None:
    """A cheap target (CT-02's dataset, one job) with the shared worker: the worker started
    for the run, so its warm-up and the job it forked are counted beside the invocation."""
    out = _run(sys.executable, "scripts/target_cpu.py", "data/studies/ct02/ct02.nc")
    line = next(x for x in out.splitlines() if x.startswith("worker run 1: CPU"))
    worker = float(line.split("worker ")[2].split(",")[0])
    jobs = float(line.split("its jobs ")[1].split(")")[0])
    assert worker > 0.5 and jobs > 0.0, out
    assert "worker median CPU" in out
