"""`creatio run` at the cost of its computation (creatio.pipeline.run, issue 37): a report's
figures left for later are the figures drawn at once, byte for byte; they are drawn by a
process of its own after the caller returned, which leaves its log only when it failed; a
first `creatio run` that no worker served starts the checkout's daemon, which serves the
next one."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from creatio.pipeline import worker
from creatio.pipeline.run import draw_after, write_report

REPO = Path(__file__).resolve().parents[2]
EN02 = sorted((REPO / "data" / "studies" / "en02").glob("en02_dt*.nc"))
CLI = [sys.executable, "-m", "creatio.cli"]

forks = pytest.mark.skipif(not hasattr(os, "fork"), reason="the figures are drawn in a fork")


def _until(done, timeout: float = 120.0) -> bool:
    """Whether done() turned true within timeout s."""
    deadline = time.monotonic() + timeout
    while not done():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


@pytest.mark.skipif(len(EN02) != 2, reason="needs data/studies/en02 (snakemake all)")
def test_a_report_whose_figures_are_left_for_later_is_the_report_drawn_at_once(tmp_path):
    """EN-02's writer queues its three figures (and the history CSV drawn with one): the
    JSON, markdown and HTML are written first, and once the queue is drawn every file is
    the one the writer makes drawing at once, byte for byte."""
    now, later = tmp_path / "now", tmp_path / "later"
    drawn = write_report("en02", now, EN02)
    queue: list = []
    left = write_report("en02", later, EN02, later=queue)
    assert left == {k: later / p.name for k, p in drawn.items()}
    assert sorted(p.name for p in later.iterdir()) == ["en02.html", "en02.json", "en02.md"]
    assert len(queue) == 3
    for task in queue:
        task()
    names = sorted(p.name for p in now.iterdir())
    assert names == sorted(p.name for p in later.iterdir())
    assert {"en02.png", "en02_trajectory.png", "en02_convergence.png"} <= set(names)
    for name in names:
        assert (now / name).read_bytes() == (later / name).read_bytes(), name


@forks
def test_figures_drawn_after_are_drawn_by_a_process_of_its_own_once_the_caller_returned(
        tmp_path):
    """draw_after returns at once: its task, which waits for a file made only after the call
    returned, still draws, in another process and session; its log is gone once all went
    well."""
    if threading.active_count() > 1:
        pytest.skip("other threads: draw_after draws in place")
    go, out = tmp_path / "go", tmp_path / "drawn.json"
    log = tmp_path / "reports" / ".x.figures.log"

    def task() -> None:
        waited = _until(go.exists, 60.0)
        tmp = out.with_suffix(".tmp")
        tmp.write_text(json.dumps({"pid": os.getpid(), "sid": os.getsid(0), "go": waited}))
        tmp.rename(out)

    draw_after([task], tmp_path / "data", log)
    assert not out.exists()  # it waits for go, which only this process makes, now
    go.touch()
    assert _until(out.exists)
    drawn = json.loads(out.read_text())
    assert drawn["go"] and drawn["pid"] != os.getpid() and drawn["sid"] != os.getsid(0)
    assert _until(lambda: not log.exists())


@forks
def test_figures_that_fail_to_draw_leave_their_log_naming_the_failure(tmp_path):
    """A task that raises keeps the log, which names its error."""
    if threading.active_count() > 1:
        pytest.skip("other threads: draw_after draws in place")
    log = tmp_path / "reports" / ".x.figures.log"

    def task() -> None:
        raise ValueError("no ink in the plotter")

    draw_after([task], tmp_path / "data", log)
    assert _until(lambda: log.exists() and "ValueError: no ink in the plotter"
                  in log.read_text())


class _Started:
    pid = 4242


@pytest.mark.parametrize(("argv", "env", "started"), [
    (["run", "study=en02", "sphere.mu=0.21"], {}, True),
    (["run", "study=en02"], {"SLURM_JOB_ID": "7"}, False),
    (["run", "study=en02", "--help"], {}, False),
    (["run", "-m", "study=en02", "sphere.mu=0.1,0.2"], {}, False),
    (["task", "dataset", "en02", "x.nc"], {}, False),
])
def test_a_run_no_worker_served_starts_the_daemon_in_the_environment_it_started_with(
        monkeypatch, capsys, argv, env, started):
    """autostart starts the checkout's daemon for a plain `creatio run` that no worker
    served, in the environment the command started with, idle as CREATIO_WORKER_IDLE says,
    and says so in one line; never for another command, one with options or a batch job."""
    calls = []

    def ensure(path, job_env, idle, log):
        calls.append((path, job_env, idle, log))
        return _Started()

    monkeypatch.setattr(worker, "ensure", ensure)
    monkeypatch.setattr(worker, "_unserved", {"HOME": "/home/u", "PATH": "/bin"})
    monkeypatch.delenv(worker.ENV, raising=False)
    monkeypatch.setenv("CREATIO_WORKER_IDLE", "120")
    for name in worker.BATCH_JOB:
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    proc = worker.autostart(argv)
    err = capsys.readouterr().err
    if not started:
        assert proc is None and calls == [] and err == ""
        return
    path = worker.daemon_socket()
    assert calls == [(path, {"HOME": "/home/u", "PATH": "/bin"}, 120.0,
                      path.with_suffix(".log"))]
    assert isinstance(proc, _Started) and len(err.splitlines()) == 1
    assert "pid 4242" in err and "120 s idle" in err and "creatio worker stop" in err


def test_a_run_a_worker_served_or_told_off_starts_no_daemon(monkeypatch, tmp_path):
    """delegate remembers the environment of a run that found no daemon (autostart then
    starts one in it); with CREATIO_WORKER=off or a socket named, it starts none."""
    calls = []
    monkeypatch.setattr(worker, "ensure", lambda *a: calls.append(a) or _Started())
    monkeypatch.setattr(worker, "daemon_socket", lambda: tmp_path / "none.sock")
    for name in worker.BATCH_JOB:
        monkeypatch.delenv(name, raising=False)
    for value in ("off", str(tmp_path / "other.sock")):
        monkeypatch.setenv(worker.ENV, value)
        assert worker.delegate(["run", "study=en02"]) is None
        assert worker.autostart(["run", "study=en02"]) is None
    assert calls == []
    monkeypatch.delenv(worker.ENV)
    monkeypatch.setenv("CREATIO_WORKER_IDLE", "not a number")
    assert worker.delegate(["run", "study=en02"]) is None
    assert worker.autostart(["run", "study=en02"]) is not None
    assert [(c[1], c[2]) for c in calls] == [(dict(os.environ), worker.SHARED_IDLE)]


@pytest.mark.long
@forks
def test_a_first_run_starts_the_daemon_the_next_is_served_and_its_figures_follow(tmp_path):
    """The issue's session: the first `creatio run` runs alone, says in one line that a warm
    worker starts, and returns with its JSON written while its figures follow (the index
    lists them once drawn); the second run is served by that worker and says nothing of
    it. The daemon is stopped at the end."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in (worker.ENV, "PYTEST_CURRENT_TEST",
                                                          *worker.BATCH_JOB)}
    env.update(TMPDIR=str(tmp), CREATIO_WORKER_IDLE="120", CREATIO_FIGURES="after")
    path = tmp / f"creatio-{os.getuid()}" / worker.daemon_socket().name
    pid = None

    def run(mu: str) -> subprocess.CompletedProcess:
        return subprocess.run([*CLI, "run", "study=en02", f"sphere.mu={mu}"], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=900)

    try:
        first = run("0.21")
        assert first.returncode == 0, first.stderr
        said = re.fullmatch(r"creatio: starting a warm worker .*\(pid (\d+), stops after "
                            r"120 s idle; `creatio worker stop` stops it now; .*\)\n",
                            first.stderr)
        assert said, first.stderr
        pid = int(said.group(1))
        assert "(its figures follow)" in first.stdout
        run_dir = tmp_path / re.search(r"-> (data/runs/\w+)", first.stdout).group(1)
        reports = run_dir / "reports"
        assert (reports / "en02.json").is_file()
        figures = [reports / f"en02{s}.png" for s in ("", "_trajectory", "_convergence")]
        assert _until(lambda: all(p.is_file() for p in figures), 600.0)
        assert _until(lambda: not (reports / ".en02.figures.log").exists())
        index = tmp_path / "data" / "index.html"
        assert _until(lambda: f"{run_dir.name}/reports/en02.png" in index.read_text())
        sock = worker._connect(path, worker.START_WAIT)
        assert sock is not None
        sock.close()
        second = run("0.22")
        assert second.returncode == 0, second.stderr
        assert second.stderr == ""
        state = worker.control(path, "status")
        assert state is not None and state["pid"] == pid and state["served"] == 1, state
    finally:
        if pid is not None:
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGTERM)
