"""End to end: the Snakemake workflow into a temporary directory, reruns keyed by config."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from creatio.pipeline.config import resolve

REPO = Path(__file__).resolve().parents[2]
CONTRACT = {
    "ct02": {"fd_error", "observed_order", "j_identity_error", "normal_tangent_dot", "j_min",
             "seam_closure", "feature_velocity_error", "feature_acceleration_error",
             "pitch_error"},
    "en01": {"fd_error", "observed_order", "j_identity_error", "normal_tangent_dot", "j_min",
             "normal_length_error", "pattern_max_rate_rad_s", "pattern_max_rate_time_s",
             "pattern_travel_deg", "pattern_fd_error"},
}


def snakemake(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    """Run the project's Snakefile with workdir as the working directory."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(workdir),
         "-c", "2", *args],
        capture_output=True, text=True, timeout=900,
    )


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    """A workflow run of the kinematic studies with default configs."""
    wd = tmp_path_factory.mktemp("wf")
    proc = snakemake(wd, "all", "--config", 'studies=["ct02","en01"]')
    assert proc.returncode == 0, proc.stderr[-3000:]
    return wd


@pytest.mark.parametrize("study", ["ct02", "en01"])
def test_reports_follow_the_contract(workdir, study):
    """Default reports at stable paths with every contract key; h keys as in the tables."""
    rep = workdir / "data" / "reports"
    data = json.loads((rep / f"{study}.json").read_text())
    assert CONTRACT[study] <= set(data)
    assert list(data["fd_error"]) == ["c_R", "c_alpha", "c_t"]
    assert "0.01" in data["fd_error"]["c_R"] and "1e-05" in data["fd_error"]["c_R"]
    for ext in (".md", ".png", "_fd_error.csv"):
        assert (rep / f"{study}{ext}").stat().st_size > 0
    assert (workdir / "data" / "studies" / study / f"{study}.nc").is_file()
    assert not any(p.name.startswith(".") for p in (rep.parent / "studies" / study).iterdir())
    assert f"reports/{study}.html" in (workdir / "data" / "index.html").read_text()


def test_nothing_reruns_when_nothing_changed(workdir):
    """A second invocation with the same config has nothing to do."""
    proc = snakemake(workdir, "all", "-n", "--config", 'studies=["ct02","en01"]')
    assert proc.returncode == 0
    assert "Nothing to be done" in proc.stdout + proc.stderr


def test_override_reruns_exactly_the_changed_study(workdir):
    """study.feature_h is CT-02's: only its two jobs run, into runs/<hash>; EN-01 untouched."""
    default = workdir / "data" / "reports" / "ct02.json"
    before = default.stat().st_mtime_ns
    override = 'overrides=["study.feature_h=2e-4"]'
    dry = snakemake(workdir, "all", "-n", "--config", 'studies=["ct02","en01"]', override)
    assert dry.returncode == 0, dry.stderr[-2000:]
    out = dry.stdout + dry.stderr
    assert re.search(r"study_dataset\s+1\n", out) and re.search(r"kinematic_report\s+1\n", out)
    proc = snakemake(workdir, "all", "--config", 'studies=["ct02","en01"]', override)
    assert proc.returncode == 0, proc.stderr[-2000:]
    key = resolve("ct02", ["study.feature_h=2e-4"]).key
    assert f"data/runs/{key}" in proc.stderr  # the path is announced
    assert (workdir / "data" / "runs" / key / "reports" / "ct02.json").is_file()
    assert default.stat().st_mtime_ns == before
    # the hash-named folder says what made it, and the index lists it with its overrides
    record = json.loads((workdir / "data" / "runs" / key / "overrides.json").read_text())
    assert record["overrides"] == ["study.feature_h=2e-4"] and record["name"] == "ct02"
    assert record["changes"] == {"study.feature_h": [1e-4, 2e-4]}
    assert "creatio: results listed in data/index.html" in proc.stderr
    page = (workdir / "data" / "index.html").read_text()
    assert f"runs/{key}/ct02" in page and "study.feature_h=2e-4" in page


def test_an_override_equal_to_the_default_reruns_nothing(workdir):
    """Jobs rerun on a change of resolved config, not of how the overrides are spelled."""
    proc = snakemake(workdir, "all", "-n", "--config", 'studies=["ct02","en01"]',
                     'overrides=["study.feature_h=1e-4", "geometry.A=0.18"]')
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Nothing to be done" in proc.stdout + proc.stderr


def test_bad_override_fails_before_any_job(workdir):
    """An invalid value stops the workflow at parse time with the config message."""
    proc = snakemake(workdir, "all", "-n", "--config", 'studies=["ct02"]',
                     'overrides=["geometry.A=0.9"]')
    assert proc.returncode != 0
    out = proc.stdout + proc.stderr
    assert "geometry.A=0.9" in out and "0 <= A < R0" in out
    assert "Traceback" not in out and "InputFunctionException" not in out


def test_a_dataset_lost_behind_its_report_is_made_again(workdir):
    """A killed forced rerun deletes the outputs of the jobs it started while their reports
    stay: the datasets are targets themselves, so the next run makes them again."""
    lost = workdir / "data" / "studies" / "en01" / "en01.nc"
    kept, stat = lost.read_bytes(), lost.stat()
    lost.unlink()
    try:
        dry = snakemake(workdir, "all", "-n", "--config", 'studies=["ct02","en01"]')
        out = dry.stdout + dry.stderr
        assert dry.returncode == 0, out[-2000:]
        assert re.search(r"study_dataset\s+1\n", out) and "Missing output files: " \
            "data/studies/en01/en01.nc" in out
    finally:  # as it was, times included (the tests after this one expect nothing to do)
        lost.write_bytes(kept)
        os.utime(lost, ns=(stat.st_atime_ns, stat.st_mtime_ns))


def test_jobs_read_their_config_from_a_file_and_reasons_stay_short(workdir):
    """Each study's resolved config is a file that its dataset jobs read; no job parameter
    carries the YAML, so a rerun reason (which prints changed parameters) stays one line."""
    assert (workdir / "data" / "configs" / "ct02.yaml").read_text() == resolve("ct02").yaml
    dry = snakemake(workdir, "all", "-n", "-p", "--config", 'studies=["ct02"]',
                    'overrides=["study.feature_h=3e-4"]')
    assert dry.returncode == 0, dry.stderr[-2000:]
    key = resolve("ct02", ["study.feature_h=3e-4"]).key
    out = dry.stdout + dry.stderr
    assert f"--config-file data/runs/{key}/configs/ct02.yaml" in out
    assert max(len(line) for line in out.splitlines()) < 400
    assert "feature_h: 0.0003" not in out


@pytest.mark.parametrize(("config", "words"), [
    ("studie=x", "studie='x': unknown --config key (did you mean studies?)"),
    ("sweep_batch=0", "sweep_batch=0: 0 is less than the minimum of 1"),
    ("atol=abc", "atol='abc': 'abc' is not of type 'number'"),
    ("tol=3", "tol=3: must be a string or a list of strings"),
])
def test_the_workflow_config_is_validated_against_its_schema(tmp_path, config, words):
    proc = snakemake(tmp_path, "all", "-n", "--config", config)
    assert proc.returncode == 2
    assert words in proc.stderr and "Traceback" not in proc.stderr


def test_code_versions_follow_the_sources_of_each_kind_of_output(tmp_path):
    """A rule's code parameter changes when, and only when, a source it depends on changes."""
    import shutil

    from creatio.pipeline.planning import code_version

    package = tmp_path / "creatio"
    shutil.copytree(Path(__file__).resolve().parents[2] / "src" / "creatio", package,
                    ignore=shutil.ignore_patterns("__pycache__"))
    before = {k: code_version(k, package) for k in ("datasets", "reports", "scenes")}
    assert before["datasets"] == code_version("datasets")  # location-independent
    with (package / "reports" / "common.py").open("a") as fh:
        fh.write("# changed\n")
    code_version.cache_clear()
    after = {k: code_version(k, package) for k in before}
    assert after["reports"] != before["reports"]
    assert after["datasets"] == before["datasets"] and after["scenes"] == before["scenes"]
    with (package / "model" / "surface.py").open("a") as fh:
        fh.write("# changed\n")
    code_version.cache_clear()
    assert code_version("datasets", package) != before["datasets"]


def test_dynamic_study_runs_both_timesteps_into_its_hash_dir(tmp_path):
    """A 2 s EN-02 cycle: dt and dt/3 jobs (an inexact dt), then the report's contract."""
    override = ["phases.T=2.0", "solver.refine=3"]
    proc = snakemake(tmp_path, "all", "--config", 'studies=["en02"]',
                     'overrides=["phases.T=2.0", "solver.refine=3"]')
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    root = tmp_path / "data" / "runs" / resolve("en02", override).key
    assert (root / "studies" / "en02" / "en02_dt0.002.nc").is_file()
    assert (root / "studies" / "en02" / f"en02_dt{0.002 / 3!r}.nc").is_file()
    data = json.loads((root / "reports" / "en02.json").read_text())
    assert {"angular_displacement_deg", "initial_radius_m", "final_radius_m",
            "min_normal_reaction_N", "max_slip_speed_m_s", "cumulative_spin_deg",
            "cavity_tracking_error_m", "min_edge_clearance_m", "timestep_difference_m",
            "energy_residual_J", "dt_s", "status"} <= set(data)
    assert data["dt_s"] == [0.002, 0.002 / 3]
    for name in ("en02.md", "en02.png", "en02_history.csv", "en02_trajectory.png",
                 "en02_convergence.png"):
        assert (root / "reports" / name).stat().st_size > 0
    assert not (tmp_path / "data" / "reports").exists()  # defaults untouched


def test_job_commands_name_the_interpreter_relative_to_the_working_directory(tmp_path):
    """The report's job parameters showed the clone's absolute .venv path: run from a
    directory holding the environment (the clone itself, here a link to its .venv), the
    commands name it relative (`.venv/bin/python -m creatio.cli`)."""
    venv = Path(sys.executable).parent.parent
    if not (venv / "pyvenv.cfg").is_file():
        pytest.skip("not running from a virtual environment")
    (tmp_path / ".venv").symlink_to(venv)
    proc = subprocess.run(
        [str(tmp_path / ".venv" / "bin" / "python"), "-m", "snakemake", "-s",
         str(REPO / "Snakefile"), "-n", "-p", "-c", "1", "all", "--config",
         'studies=["ct02"]'],
        cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    jobs = [ln for ln in (proc.stdout + proc.stderr).splitlines() if "creatio.cli" in ln]
    assert any('".venv/bin/python" -m creatio.cli task dataset ct02' in ln
               for ln in jobs), jobs
    assert not any(str(venv) in ln or str(tmp_path) in ln for ln in jobs), jobs
