"""creatio.store.forked: files written in forked children are the files this process would
write, and a task that fails in its child raises its own error here."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from creatio.store import forked

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="children are forked")


def _write(path: Path, k: int) -> None:
    path.write_text(f"{k} {os.getpid()}\n")


def test_every_task_runs_once_and_the_others_in_children(tmp_path, monkeypatch):
    monkeypatch.setattr(forked, "cores", lambda: 2)
    paths = [tmp_path / f"{k}.txt" for k in range(3)]
    forked.run_all([lambda p=p, k=k: _write(p, k) for k, p in enumerate(paths)])
    pids = [int(p.read_text().split()[1]) for p in paths]
    assert [int(p.read_text().split()[0]) for p in paths] == [0, 1, 2]
    assert pids[0] == os.getpid() and os.getpid() not in pids[1:] and len(set(pids)) == 3


def test_one_core_runs_everything_here_in_order(tmp_path, monkeypatch):
    monkeypatch.setattr(forked, "cores", lambda: 1)
    order = []
    forked.run_all([lambda k=k: order.append(k) for k in range(3)])
    assert order == [0, 1, 2]


def test_a_task_failing_in_its_child_raises_its_error_here(tmp_path, monkeypatch):
    monkeypatch.setattr(forked, "cores", lambda: 2)
    calls = tmp_path / "calls"

    def bad() -> None:
        with calls.open("a") as fh:
            fh.write(f"{os.getpid()}\n")
        raise ValueError("the task's own error")

    with pytest.raises(ValueError, match="the task's own error"):
        forked.run_all([lambda: None, bad])
    pids = [int(x) for x in calls.read_text().split()]
    assert len(pids) == 2 and pids[1] == os.getpid() != pids[0]  # child, then here


def test_a_sphere_report_is_the_same_bytes_with_children_or_without(tmp_path, monkeypatch,
                                                                    repo):
    """The figures drawn in children equal those drawn in order in this process."""
    from creatio.pipeline.config import resolve
    from creatio.pipeline.run import compute_dataset
    from creatio.reports.sphere import write_report

    r = resolve("en02", ["phases.T=10", "study.duration=10"], only_applicable=True)
    data = [compute_dataset(r, tmp_path / f"{p.name}.nc", p.name) for p in r.entry.parts(r.obj)]
    out = {}
    for n in (1, 2):
        monkeypatch.setattr(forked, "cores", lambda n=n: n)
        out[n] = write_report(data, tmp_path / f"cores{n}")
    assert out[1].keys() == out[2].keys()
    for key, path in out[1].items():
        assert path.read_bytes() == out[2][key].read_bytes(), key


def test_a_studys_parts_computed_in_children_are_those_computed_in_order(tmp_path,
                                                                        monkeypatch):
    """creatio run's parts (compute_parts: EN-02's two timesteps in two processes) give the
    datasets one process gives computing them in turn: every variable and every attribute
    but the creation time."""
    from creatio.pipeline.config import resolve
    from creatio.pipeline.run import compute_parts
    from creatio.store.netcdf import read_dataset

    r = resolve("en02", ["phases.T=10", "study.duration=10"], only_applicable=True)
    names = [p.name for p in r.entry.parts(r.obj)]
    assert len(names) == 2
    out = {}
    for n in (1, 2):
        monkeypatch.setattr(forked, "cores", lambda n=n: n)
        (tmp_path / f"cores{n}").mkdir()
        out[n] = compute_parts(r, tmp_path / f"cores{n}", names)
    assert [p.name for p in out[1]] == [p.name for p in out[2]] == [f"{n}.nc" for n in names]
    for one, two in zip(out[1], out[2], strict=True):
        a, b = read_dataset(one)[0], read_dataset(two)[0]
        for ds in (a, b):
            for key in ("date_created", "history"):
                ds.attrs.pop(key, None)
        assert a.identical(b), one.name


def test_an_analysiss_timed_parts_are_computed_alone_in_turn(tmp_path, monkeypatch):
    """An analysis's datasets are timings: its parts run in this process one after the
    other, while a sphere study's are dealt to two processes."""
    from types import SimpleNamespace

    from creatio.pipeline import run

    def fake(resolved, out, name):  # what compute_dataset would write, and who wrote it
        Path(out).write_text(f"{name} {os.getpid()}\n")
        return out

    monkeypatch.setattr(forked, "cores", lambda: 2)
    monkeypatch.setattr(run, "compute_dataset", fake)
    pids = {}
    for kind in ("analysis", "sphere"):
        resolved = SimpleNamespace(entry=SimpleNamespace(kind=SimpleNamespace(name=kind)))
        (tmp_path / kind).mkdir()
        outs = run.compute_parts(resolved, tmp_path / kind, ["a", "b", "c"])
        assert [p.read_text().split()[0] for p in outs] == ["a", "b", "c"]
        pids[kind] = [int(p.read_text().split()[1]) for p in outs]
    assert pids["analysis"] == [os.getpid()] * 3
    assert pids["sphere"][0] == pids["sphere"][2] == os.getpid() != pids["sphere"][1]


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="Linux's prctl")
def test_children_die_with_a_parent_killed_by_its_limits(tmp_path):
    """A parent killed outright (as `ulimit -t` kills it) takes its forked children along:
    the child's task, still sleeping, never writes its file."""
    import signal
    import subprocess
    import sys
    import time

    done, pids = tmp_path / "child-wrote", tmp_path / "pids"
    script = f"""
import os, time
from creatio.store import forked
forked.cores = lambda: 2
def child():
    open({str(pids)!r}, "a").write(f"{{os.getpid()}}\\n")
    time.sleep(2)
    open({str(done)!r}, "w").write("too late")
def parent():
    time.sleep(60)
forked.run_all([parent, child])
"""
    proc = subprocess.Popen([sys.executable, "-c", script])
    deadline = time.monotonic() + 30
    while not (pids.exists() and pids.read_text().strip()) and time.monotonic() < deadline:
        time.sleep(0.05)
    child_pid = int(pids.read_text().split()[0])
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    status = Path(f"/proc/{child_pid}/status")
    for _ in range(100):  # the kernel delivers the child's SIGKILL at once (a zombie is dead)
        try:
            if "\nState:\tZ" in status.read_text():
                break
        except (FileNotFoundError, ProcessLookupError):
            break
        time.sleep(0.05)
    else:
        pytest.fail(f"child {child_pid} outlived its killed parent")
    time.sleep(2.5)
    assert not done.exists()
