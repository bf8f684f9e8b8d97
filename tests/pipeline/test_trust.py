"""Trust (issue 28): no user text reaches a shell, no stale result is reused, no unbounded
expansion, every refusal one line. Each class has the issue's example and one more of it."""

from __future__ import annotations

import base64
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]


def snakemake(workdir: Path, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """The project's Snakefile in workdir (-c 1), run from workdir (a file an injected
    command touched would land there)."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(workdir),
         "-c", "1", *args],
        capture_output=True, text=True, timeout=timeout, cwd=workdir,
        env={**os.environ, "CREATIO_DEBUG": ""},
    )


def creatio(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None
            ) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "creatio.cli", *args], capture_output=True,
                          text=True, cwd=cwd,
                          env={**os.environ, "CREATIO_DEBUG": "", **(env or {})})


def one_line(proc: subprocess.CompletedProcess, code: int, words: str) -> None:
    """The process failed with `code` and one line of stderr containing `words`."""
    assert proc.returncode == code, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    lines = [ln for ln in proc.stderr.strip().splitlines() if ln.startswith("creatio")]
    assert len(lines) == 1 and words in lines[0], proc.stderr[-3000:]


# ------------------------------------------------------------- class 1: shell injection
# (the --config entry as typed, the title the study gets, the files it must not create)
INJECTIONS = {
    "issue-example": ("overrides=['study.title=''$(touch injected)''']",
                      "$(touch injected)", ("injected",)),
    "backticks-semicolon-newline": (
        'overrides=["study.title=\'`touch pwned`; touch pwned2 #\\n$(touch pwned3)\'"]',
        "`touch pwned`; touch pwned2 #\n$(touch pwned3)", ("pwned", "pwned2", "pwned3")),
}


@pytest.mark.parametrize("name", list(INJECTIONS))
def test_override_text_never_reaches_a_shell(tmp_path, name):
    """Snakemake re-invokes itself through /bin/sh for the `run:` config rules (and for every
    job on a cluster), writing --config with repr(): `$(...)` in an override ran. The title
    now arrives verbatim in the config, the dataset and the report; no command ran."""
    entry, title, planted = INJECTIONS[name]
    proc = snakemake(tmp_path, "all", "--config", entry, 'studies=["ct02"]')
    assert proc.returncode == 0, proc.stderr[-3000:]
    for where in (tmp_path, tmp_path / "data", REPO):
        assert not any((where / f).exists() for f in planted), f"injected into {where}"
    (config,) = tmp_path.glob("data/runs/*/configs/ct02.yaml")
    assert yaml.safe_load(config.read_text())["study"]["title"] == title
    import xarray as xr

    (dataset,) = tmp_path.glob("data/runs/*/studies/ct02/ct02.nc")
    with xr.open_dataset(dataset) as ds:
        assert ds.attrs["title"] == title


@pytest.mark.parametrize(("entry", "title"), [
    ("overrides=[\"study.title='a b'\"]", "a b"),
    # YAML single quotes ('' is one '), inside them Hydra's quoted string (\' is one ')
    ("overrides=['study.title=''it\\''s \"a b\"''']", "it's \"a b\""),
])
def test_quoted_values_work_end_to_end(tmp_path, entry, title):
    """`study.title='a b'` failed with a shell syntax error; quotes of both kinds pass."""
    proc = snakemake(tmp_path, "all", "--config", entry, 'studies=["ct02"]',
                     "--until", "study_config")
    assert proc.returncode == 0, proc.stderr[-3000:]
    (config,) = tmp_path.glob("data/runs/*/configs/ct02.yaml")
    assert yaml.safe_load(config.read_text())["study"]["title"] == title


def test_re_invoked_jobs_get_only_shell_inert_config_text():
    """What Snakemake writes into a re-invoked job's command line is one entry of URL-safe
    base64 (no quote, `$`, backtick, `;`, space or newline), which decodes to exactly the
    config the invocation parsed."""
    from types import SimpleNamespace

    from snakemake.cli import parse_config

    from creatio.pipeline.planning import PASSED_CONFIG, pass_config_safely

    typed = ["overrides=['study.title=''$(touch x)''', \"a=`b`;\\nc\"]", "studies=[ct02]"]
    settings = SimpleNamespace(config_args=list(typed))
    main = parse_config(typed)
    pass_config_safely(settings, dict(main))
    (passed,) = settings.config_args
    key, _, text = passed.partition("=")
    assert key == PASSED_CONFIG and set(text) <= set(
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_=")
    job_config = parse_config(settings.config_args)  # what the re-invoked job parses
    job_settings = SimpleNamespace(config_args=list(settings.config_args))
    pass_config_safely(job_settings, job_config)
    assert job_config == main and job_settings.config_args == settings.config_args
    assert json.loads(base64.urlsafe_b64decode(text)) == typed


def test_sweep_values_with_shell_text_stay_text(tmp_path):
    """A sweep's axes reach its batch jobs' command line: values holding `$(...)`, `;` and
    backticks are points like any other (titles of two ct02 points), and run nothing."""
    import xarray as xr

    proc = snakemake(tmp_path, "sweep", "--config", "study=ct02",
                     "sweep=[\"study.title='$(touch a)','b;`touch c`'\"]")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert not any((tmp_path / f).exists() for f in ("a", "c"))
    (path,) = tmp_path.glob("data/sweeps/*/sweep.nc")
    with xr.open_dataset(path) as ds:
        assert list(ds.study__title.values) == ["$(touch a)", "b;`touch c`"]
        assert list(ds.status.values) == ["ok", "ok"]


# ------------------------------------------------------------------ class 3: stale results
def _counts(path: Path) -> dict[str, int]:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return {k: int(ds.attrs[k]) for k in ("computed", "reused", "refused")}


def test_sweep_points_are_reused_only_by_the_same_code(tmp_path, monkeypatch):
    """The issue's case: after a code change a wider sweep mixed old rows with new ones. A
    point is reused only from a batch that recorded the current datasets code version."""
    from creatio.pipeline import sweep

    data = str(tmp_path / "data")
    base = ["phases.T=2.0"]
    narrow = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2"], base, data, batch_size=2)
    assert _counts(sweep.run_batch(narrow, 0)) == {"computed": 2, "reused": 0, "refused": 0}
    wide = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2,0.3"], base, data, batch_size=3)
    assert _counts(sweep.run_batch(wide, 0)) == {"computed": 1, "reused": 2, "refused": 0}
    monkeypatch.setattr(sweep, "_code", lambda: "0123456789ab")  # new code
    wider = sweep.plan_sweep("en02", ["sphere.mu=0.05,0.1,0.2,0.3"], base, data, batch_size=4)
    assert _counts(sweep.run_batch(wider, 0)) == {"computed": 4, "reused": 0, "refused": 0}


def test_multirun_recomputes_batches_of_other_code(tmp_path, monkeypatch):
    """`creatio run -m` (write_sweep with compute_missing) reused any batch file present;
    one of other code is computed again, a current one kept."""
    from creatio.pipeline import sweep

    monkeypatch.chdir(tmp_path)
    plan = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2"], ["phases.T=2.0"], batch_size=2)
    sweep.write_sweep(plan, compute_missing=True)
    batch = Path(plan.batch_file(0))
    first = batch.stat().st_mtime_ns
    sweep.write_sweep(plan, compute_missing=True)
    assert batch.stat().st_mtime_ns == first  # same code: kept
    monkeypatch.setattr(sweep, "_code", lambda: "0123456789ab")
    sweep.write_sweep(plan, compute_missing=True)
    assert batch.stat().st_mtime_ns != first
    assert _counts(batch) == {"computed": 2, "reused": 0, "refused": 0}
