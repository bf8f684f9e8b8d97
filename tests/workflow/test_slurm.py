"""The workflow through `--executor slurm` (profiles/slurm) gives what it gives locally.

Runs only where a SLURM cluster answers: `scripts/local-slurm.sh status` succeeds (the
one-node test cluster of docs/cluster.md is up), or CREATIO_SLURM=1 is set and `sinfo`
works (any other cluster whose nodes see this directory, e.g. a login node of a real one;
then set CREATIO_SLURM_PARTITION / CREATIO_SLURM_ACCOUNT as for profiles/slurm). Otherwise
every test here is skipped.

`run_both(tmp_path, TARGET, ...)` runs one snakemake target twice, locally with `-c 2` and
through SLURM, into two fresh directories; a new comparison is a few lines on top of it:

    def test_sweep_through_slurm_equals_local(slurm_cluster, tmp_path):
        runs = run_both(tmp_path, "sweep", "--config", 'sweep=["sphere.mu=0,0.15"]',
                        "study=en02", 'overrides=["phases.T=2.0"]')
        for local, slurm in runs.pairs("data/sweeps/*/sweep.nc"):
            with xr.open_dataset(local) as a, xr.open_dataset(slurm) as b:
                xr.testing.assert_equal(a, b)  # not _identical: history/date_created differ

On a real cluster the two run directories must be on a filesystem the compute nodes see:
`pytest -m slurm --basetemp=/shared/scratch/creatio-tests`.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SNAKEFILE = ROOT / "Snakefile"
PROFILE = ROOT / "profiles" / "slurm"
LOCAL_SLURM = ROOT / "scripts" / "local-slurm.sh"
SNAKEMAKE = [sys.executable, "-m", "snakemake"]
TIMEOUT = 900  # seconds for one snakemake run

pytestmark = pytest.mark.slurm


def slurm_unavailable() -> str | None:
    """Why the SLURM tests cannot run here (None: they can)."""
    if os.environ.get("CREATIO_SLURM") == "1":
        if shutil.which("sinfo") is None:
            return "CREATIO_SLURM=1 but there is no sinfo on PATH"
        r = subprocess.run(["sinfo"], capture_output=True, text=True, timeout=60)
        return None if r.returncode == 0 else f"CREATIO_SLURM=1 but sinfo fails: {r.stderr}"
    if shutil.which("sinfo") is None:
        return "no SLURM here (bring the test cluster up: scripts/local-slurm.sh up)"
    r = subprocess.run(
        ["bash", str(LOCAL_SLURM), "status"], capture_output=True, text=True, timeout=120
    )
    if r.returncode != 0:
        return f"scripts/local-slurm.sh status failed: {r.stderr.strip()}"
    return None


@pytest.fixture(scope="module")
def slurm_cluster():
    reason = slurm_unavailable()
    if reason:
        pytest.skip(reason)
    pytest.importorskip(
        "snakemake_executor_plugin_slurm",
        reason="snakemake-executor-plugin-slurm is not installed in this environment",
    )


@dataclass
class Runs:
    """The two working directories of one target, and the SLURM jobs of the SLURM run."""

    local: Path
    slurm: Path
    slurm_jobs: dict[str, str]  # SLURM job id -> rule name

    def pairs(self, pattern: str) -> list[tuple[Path, Path]]:
        """(local, slurm) files matching a glob; both runs must have made the same ones."""
        local = sorted(p.relative_to(self.local) for p in self.local.glob(pattern))
        slurm = sorted(p.relative_to(self.slurm) for p in self.slurm.glob(pattern))
        assert local == slurm, f"{pattern}: local made {local}, SLURM made {slurm}"
        assert local, f"{pattern}: no such file in either run"
        return [(self.local / p, self.slurm / p) for p in local]


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("SNAKEMAKE_PROFILE", None)  # only the profile each run names
    env.pop("SLURM_JOB_ID", None)  # pytest itself inside a SLURM job
    return env


def _snakemake(args: list[str], workdir: Path, timeout: float) -> str:
    """Run snakemake in workdir; its whole output, or a failure that shows it."""
    cmd = [*SNAKEMAKE, "-s", str(SNAKEFILE), "-d", str(workdir), *args]
    proc = subprocess.Popen(
        cmd,
        cwd=workdir,
        env=_environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        # Ctrl-C makes Snakemake scancel its SLURM jobs; if it does not stop, kill it and
        # cancel them by the run's job name.
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, _ = proc.communicate()
            run_id = re.search(r"SLURM run ID: (\S+)", out)
            if run_id and shutil.which("scancel"):
                subprocess.run(["scancel", "--name", run_id.group(1)], check=False)
        pytest.fail(f"timed out after {timeout} s: {' '.join(cmd)}\n{out[-6000:]}")
    if proc.returncode != 0:
        logs = "\n".join(
            f"--- {p}\n{p.read_text(errors='replace')[-2000:]}"
            for p in sorted(workdir.glob(".snakemake/slurm_logs/**/*.log"))
        )
        pytest.fail(
            f"exit {proc.returncode}: {' '.join(cmd)}\n{out[-6000:]}\n{logs}", pytrace=False
        )
    return out


def run_both(tmp_path: Path, *args: str, timeout: float = TIMEOUT) -> Runs:
    """`snakemake ARGS` locally (-c 2) into tmp_path/local and via profiles/slurm into
    tmp_path/slurm; checks that the SLURM run really submitted its jobs to SLURM."""
    local, slurm = tmp_path / "local", tmp_path / "slurm"
    local.mkdir()
    slurm.mkdir()
    _snakemake(["-c", "2", "--workflow-profile", "none", *args], local, timeout)
    # The profile polls squeue 5 s after a submission, then every 15, 25, ... s; 1 s here
    # roughly halves a test's time on an idle cluster. Logs kept for the checks below.
    slurm_args = [
        "--workflow-profile", str(PROFILE),
        "--slurm-init-seconds-before-status-checks", "1",
        "--slurm-keep-successful-logs",
    ]  # fmt: skip
    out = _snakemake([*slurm_args, *args], slurm, timeout)
    submitted = re.findall(r"has been submitted with SLURM jobid (\d+)", out)
    assert submitted, f"the SLURM run submitted no job to SLURM:\n{out[-6000:]}"
    # The plugin logs each job to .snakemake/slurm_logs/rule_<rule>/<wildcards>/<jobid>.log.
    jobs = {
        p.stem: p.relative_to(slurm / ".snakemake" / "slurm_logs").parts[0].removeprefix("rule_")
        for p in slurm.glob(".snakemake/slurm_logs/**/*.log")
    }
    assert sorted(jobs) == sorted(submitted), f"SLURM logs {jobs} vs submitted {submitted}"
    return Runs(local=local, slurm=slurm, slurm_jobs=jobs)


def test_ct02_through_slurm_equals_local(slurm_cluster, tmp_path):
    runs = run_both(tmp_path, "all", "--config", 'studies=["ct02"]')
    assert "study_dataset" in runs.slurm_jobs.values()
    for local, slurm in runs.pairs("data/reports/ct02.json"):
        assert json.loads(slurm.read_text()) == json.loads(local.read_text())
    for local, slurm in runs.pairs("data/reports/*.csv"):
        assert slurm.read_bytes() == local.read_bytes(), local.name


def test_status_fails_loudly_when_down(tmp_path):
    """`status` names the failing check; runs everywhere (no cluster needed)."""
    if slurm_unavailable() is None:
        pytest.skip("the cluster is up")
    r = subprocess.run(["bash", str(LOCAL_SLURM), "status"], capture_output=True, text=True)
    assert r.returncode != 0
    assert "local-slurm: FAILED:" in r.stderr


def test_sweep_through_slurm_equals_local(slurm_cluster, tmp_path):
    """A small EN-02 sweep: its batch jobs go through SLURM; the aggregate equals local."""
    import xarray as xr

    runs = run_both(tmp_path, "sweep", "--config", 'sweep=["sphere.mu=0,0.15,0.3"]',
                    "study=en02", 'overrides=["phases.T=2.0"]', "sweep_batch=2")
    assert list(runs.slurm_jobs.values()).count("sweep_batch") == 2
    for local, slurm in runs.pairs("data/sweeps/*/sweep.nc"):
        with xr.open_dataset(local) as a, xr.open_dataset(slurm) as b:
            xr.testing.assert_equal(a, b)  # not _identical: history, date_created differ


def test_override_text_never_reaches_a_shell_through_slurm(slurm_cluster, tmp_path):
    """Every SLURM job re-invokes Snakemake through three shells (sbatch --wrap on the
    submitting host, the batch script, srun on the node) with the invocation's --config:
    `$(...)`, backticks and `;` in an override stay text in the title of both runs."""
    import xarray as xr

    title = "$(touch injected) `touch pwned`; touch pwned2 'quoted' \"twice\""
    entry = "overrides=['study.title=''" + title.replace("'", "\\''") + "''']"
    runs = run_both(tmp_path, "all", "--config", entry, 'studies=["ct02"]')
    assert "study_dataset" in runs.slurm_jobs.values()
    planted = [p for p in tmp_path.rglob("*") if p.name in ("injected", "pwned", "pwned2")]
    assert planted == [] and not any((ROOT / f).exists() for f in ("injected", "pwned"))
    for local, slurm in runs.pairs("data/runs/*/studies/ct02/ct02.nc"):
        with xr.open_dataset(local) as a, xr.open_dataset(slurm) as b:
            assert a.attrs["title"] == b.attrs["title"] == title
