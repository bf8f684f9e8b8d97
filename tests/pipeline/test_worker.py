"""The warm worker (creatio.pipeline.worker): a job forked from it writes the same bytes of
data as a fresh process, and a worker that is absent, stale, killed mid-job or asked from a
SLURM job never gives a result it should not: the command then runs in its own process."""

from __future__ import annotations

import contextlib
import copy
import json
import os
import re
import resource
import shutil
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.pipeline import config, worker
from creatio.pipeline.code import package_version
from creatio.store.yamlio import load_yaml

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="the worker forks")

CLI = [sys.executable, "-m", "creatio.cli"]
REPO = Path(__file__).resolve().parents[2]


def _environ() -> dict[str, str]:
    """This process's environment but what pytest changes between a test's phases (a
    worker started by a fixture serves the test's clients)."""
    return {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}


@pytest.fixture
def warm(tmp_path):
    """A worker of this test (stops with it), at a socket in tmp_path."""
    path = tmp_path / "w.sock"
    proc = worker.start(path, owner=os.getpid(), log=tmp_path / "worker.log", wait=True,
                        env=_environ())
    yield path
    worker.stop(proc)


def _run(args, env, cwd, **kw):
    return subprocess.run([*CLI, *args], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=600, **kw)


def _same_data(a: Path, b: Path) -> None:
    """Every variable and coordinate of a and b equal bit for bit (NaN where NaN)."""
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        assert sorted(x.variables) == sorted(y.variables)
        for name in x.variables:
            u, v = x[name].values, y[name].values
            assert u.dtype == v.dtype and u.shape == v.shape, name
            if u.dtype.kind == "f":
                assert np.array_equal(u.view(np.uint64 if u.itemsize == 8 else np.uint32),
                                      v.view(np.uint64 if v.itemsize == 8 else np.uint32)), name
            else:
                assert np.array_equal(u, v), name


@pytest.mark.parametrize("study", ["ct02", "en02"])
def test_a_job_in_the_worker_writes_the_same_data_as_its_own_process(warm, tmp_path, study):
    """The issue's required test: the warm job path against one process per job."""
    env = {**_environ(), worker.ENV: str(warm)}
    before = worker.control(warm, "status")["served"]
    served = _run(["task", "dataset", study, str(tmp_path / "warm.nc")], env, tmp_path)
    assert served.returncode == 0, served.stderr
    assert worker.control(warm, "status")["served"] == before + 1  # the worker ran it
    alone = _run(["task", "dataset", study, str(tmp_path / "alone.nc")],
                 {**_environ(), worker.ENV: "off"}, tmp_path)
    assert alone.returncode == 0, alone.stderr
    _same_data(tmp_path / "warm.nc", tmp_path / "alone.nc")


def test_a_calibration_in_the_worker_writes_the_same_data_as_its_own_process(warm, tmp_path):
    """`creatio calibrate` (a job of `snakemake en05`) served by the worker: the example
    track's fit, its dataset bit for bit as one process alone writes it."""
    from creatio.pipeline.calibrate import EXAMPLE_OVERRIDES, EXAMPLE_TRACK

    args = ["calibrate", "study=en02", f"track={EXAMPLE_TRACK}", "fit=[sphere.mu,sphere.eps]",
            *EXAMPLE_OVERRIDES]
    env = {**_environ(), worker.ENV: str(warm)}
    before = worker.control(warm, "status")["served"]
    served = _run([*args, f"out={tmp_path / 'warm'}"], env, tmp_path)
    assert served.returncode == 0, served.stderr
    assert worker.control(warm, "status")["served"] == before + 1  # the worker ran it
    alone = _run([*args, f"out={tmp_path / 'alone'}"], {**_environ(), worker.ENV: "off"},
                 tmp_path)
    assert alone.returncode == 0, alone.stderr
    _same_data(tmp_path / "warm" / "calibration.nc", tmp_path / "alone" / "calibration.nc")


def test_an_absent_worker_or_a_slurm_job_runs_in_its_own_process(tmp_path, monkeypatch):
    """No socket, no starting worker: the command runs alone at once (delegate says None);
    a SLURM job never asks a worker, even a live one."""
    monkeypatch.setenv(worker.ENV, str(tmp_path / "none.sock"))
    t0 = time.monotonic()
    assert worker.delegate(["task", "dataset", "ct02", "x.nc"]) is None
    assert time.monotonic() - t0 < 1.0
    path = tmp_path / "w.sock"
    proc = worker.start(path, owner=os.getpid(), log=tmp_path / "worker.log", wait=True,
                        env=_environ())
    try:
        monkeypatch.setenv(worker.ENV, str(path))
        monkeypatch.setenv("SLURM_JOB_ID", "17")
        assert worker.delegate(["task", "dataset", "ct02", str(tmp_path / "x.nc")]) is None
        assert worker.control(path, "status")["served"] == 0
        assert not (tmp_path / "x.nc").exists()
    finally:
        worker.stop(proc)


def test_a_worker_that_listens_between_the_clients_looks_is_found(tmp_path, monkeypatch):
    """A worker binds, listens, then removes its .starting file: a client whose connection
    attempt fails just before the worker listens, and who then finds the file gone, must
    still connect (the race that made a warm-up of 2.5 s look like a failed start)."""
    path = tmp_path / "w.sock"
    starting = path.with_name(path.name + ".starting")
    starting.write_text(str(os.getpid()))
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    read_text = Path.read_text

    def worker_comes_up(self: Path, *args, **kwargs):
        if self == starting and listener.fileno() >= 0 and not path.exists():
            listener.bind(str(path))  # the worker's last steps, in its order
            listener.listen(1)
            starting.unlink()
        return read_text(self, *args, **kwargs)

    monkeypatch.setattr(Path, "read_text", worker_comes_up)
    with listener:
        sock = worker._connect(path, wait=5.0)
        assert sock is not None
        sock.close()
    assert worker._connect(path, wait=5.0) is None  # none listens and none is coming


def test_a_worker_with_other_code_or_another_environment_serves_no_one(tmp_path):
    """The worker compares the package's code version (creatio.pipeline.code) at every
    request with the one it started with: a difference refuses the job and stops the worker;
    a variable read at import that differs refuses the job."""
    server = worker.Server(tmp_path / "s.sock", entry=lambda argv: 0)
    server.version = package_version()
    request = {**worker._identity(), "env": dict(os.environ), "limits": worker.limits()}
    assert server._refusal(request, [0, 1, 2]) is None
    server.version = "0" * 12  # started before an edit of the sources
    assert "sources changed" in server._refusal(request, [0, 1, 2])
    assert server.stopping
    server = worker.Server(tmp_path / "s.sock", entry=lambda argv: 0)
    server.version = package_version()
    request["env"] = {**os.environ, "NUMBA_BOUNDSCHECK": "1"}
    assert server._refusal(request, [0, 1, 2]) == "the environment differs in NUMBA_BOUNDSCHECK"
    assert worker.env_mismatch({"CREATIO_DEBUG": "1"}, {}) is None  # read when it runs


def test_package_version_follows_the_sources(tmp_path):
    """Any source of the package changes the version, so a worker started before the edit
    refuses the jobs after it."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    v = package_version(pkg)
    assert package_version(pkg) == v
    (pkg / "sub" / "b.py").write_text("y = 3\n")
    assert package_version(pkg) != v


#: An EN-02 job of a few seconds (its run at dt = 5e-5 s), long enough to be interrupted.
LONG_JOB = ("--override", "solver.dt=0.00005")


def _served_job(path: Path, tmp_path: Path, out: Path) -> subprocess.Popen:
    """A client whose job (LONG_JOB) runs in the worker at path, once the worker forked it."""
    before = worker.control(path, "status")["served"]
    proc = subprocess.Popen([*CLI, "task", "dataset", "en02", str(out), *LONG_JOB],
                            cwd=tmp_path,
                            env={**_environ(), worker.ENV: str(path), "CREATIO_DEBUG": ""},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while worker.control(path, "status")["served"] == before:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    return proc


def test_a_worker_killed_mid_job_stops_the_job_and_the_command_runs_alone(tmp_path):
    """SIGKILL of the worker while its job computes: the client stops that job and runs the
    command in its own process; the dataset is the one a process alone writes."""
    path = tmp_path / "w.sock"
    proc = worker.start(path, owner=os.getpid(), log=tmp_path / "worker.log", wait=True,
                        env=_environ())
    out = tmp_path / "killed.nc"
    client = _served_job(path, tmp_path, out)
    time.sleep(0.3)
    proc.kill()
    proc.wait()
    _, err = client.communicate(timeout=600)
    assert client.returncode == 0, err
    assert "the warm worker stopped during the job" in err
    alone = _run(["task", "dataset", "en02", str(tmp_path / "alone.nc"), *LONG_JOB],
                 {**_environ(), worker.ENV: "off"}, tmp_path)
    assert alone.returncode == 0, alone.stderr
    _same_data(out, tmp_path / "alone.nc")


def test_ctrl_c_of_a_served_job_exits_130_in_one_line(warm, tmp_path):
    """The client passes SIGINT on to its job: 130 and creatio's one line, as alone."""
    client = _served_job(warm, tmp_path, tmp_path / "x.nc")
    time.sleep(0.5)
    client.send_signal(signal.SIGINT)
    _, err = client.communicate(timeout=120)
    assert client.returncode == 130, err
    assert len(err.strip().splitlines()) == 1 and "interrupted" in err, err
    assert not (tmp_path / "x.nc").exists()


def test_snakemake_jobs_run_in_the_shared_worker_across_invocations(tmp_path):
    """A local `snakemake all` runs its jobs in the shared worker of the environment
    Snakemake gives a one-thread job (started on demand), so its dataset and report jobs
    are served (none refused); the next invocation finds the same worker, warm; what both
    write equals one process per job."""
    base = {**_environ(), "CREATIO_DEBUG": "1", "CREATIO_WORKER_IDLE": "120"}
    base.pop(worker.ENV, None)
    shared = worker.shared_socket({**base, **dict.fromkeys(worker.SNAKEMAKE_THREADS, "1")})

    def snakemake(work: Path, worker_env: str | None, overrides: str = "[]") -> str:
        env = dict(base)
        if worker_env:
            env[worker.ENV] = worker_env
        done = subprocess.run(
            [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(work),
             "-c", "2", "all", "--config", 'studies=["en02"]', f"overrides={overrides}"],
            cwd=work, env=env, capture_output=True, text=True, timeout=900)
        assert done.returncode == 0, done.stderr[-3000:]
        return "".join(p.read_text() for p in sorted((work / "data" / "logs").rglob("*.log")))

    warm, alone = tmp_path / "warm", tmp_path / "alone"
    warm.mkdir(), alone.mkdir()
    logs = snakemake(warm, None)
    assert "wrote" in logs and "refused" not in logs, logs
    state = worker.control(shared, "status")
    assert state is not None and state["served"] >= 3, state  # 2 datasets, 1 report
    snakemake(warm, None, '["sphere.mu=0.2"]')  # the next invocation: the same worker
    again = worker.control(shared, "status")
    assert again["pid"] == state["pid"] and again["served"] >= state["served"] + 3, again
    snakemake(alone, "off")
    snakemake(alone, "off", '["sphere.mu=0.2"]')
    for nc in sorted((alone / "data").rglob("*.nc")):
        _same_data(warm / nc.relative_to(alone), nc)


def test_a_refused_value_in_the_worker_is_one_line_and_exit_2(warm, tmp_path):
    """A failure of a served job is what it is alone: creatio's one line, status 2."""
    env = {**_environ(), worker.ENV: str(warm), "CREATIO_DEBUG": ""}
    before = worker.control(warm, "status")["served"]
    done = _run(["task", "dataset", "en02", str(tmp_path / "x.nc"), "--override",
                 "sphere.mu=-1"], env, tmp_path)
    assert worker.control(warm, "status")["served"] == before + 1
    alone = _run(["task", "dataset", "en02", str(tmp_path / "x.nc"), "--override",
                  "sphere.mu=-1"], {**env, worker.ENV: "off"}, tmp_path)
    assert done.returncode == alone.returncode == 2
    assert done.stderr == alone.stderr and len(done.stderr.splitlines()) == 1, done.stderr
    assert not (tmp_path / "x.nc").exists()


def test_creatio_run_without_hydra_options_runs_as_the_hydra_app(tmp_path):
    """`creatio run` with overrides only runs the config its check composed, without Hydra's
    app (which composes it twice more): the same lines on stdout and stderr, the same
    datasets bit for bit and the same report files as with a Hydra option (hydra.job.name),
    which takes Hydra's path (the plain run's figures drawn before it returns, as Hydra's)."""
    env = {**_environ(), worker.ENV: "off", "CREATIO_FIGURES": "now"}
    out = {}
    for name, extra in (("plain", []), ("hydra", ["hydra.job.name=x"])):
        (tmp_path / name).mkdir()
        done = _run(["run", "study=ct02", "geometry.A=0.1", *extra], env, tmp_path / name)
        assert done.returncode == 0, done.stderr
        out[name] = (re.sub(r"in [\d.]+ s", "in X s", done.stdout), done.stderr)
    assert out["plain"] == out["hydra"] and "wrote" in out["plain"][0], out
    plain, hydra = tmp_path / "plain" / "data", tmp_path / "hydra" / "data"
    files = sorted(p.relative_to(plain) for p in plain.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(hydra) for p in hydra.rglob("*") if p.is_file())
    for rel in files:
        if rel.suffix == ".nc":
            _same_data(plain / rel, hydra / rel)
        elif rel.suffix in (".png", ".csv", ".md", ".json") and "index" not in rel.name:
            assert (plain / rel).read_bytes() == (hydra / rel).read_bytes(), rel
    bad = _run(["run", "study=ct02", "geometry.A=0.9"], env, tmp_path)
    assert bad.returncode == 2 and len(bad.stderr.splitlines()) == 1, bad.stderr


def test_the_shared_worker_is_found_or_started_and_older_code_is_replaced(tmp_path,
                                                                         monkeypatch):
    """ensure() starts a worker where none answers, finds it the next time, and replaces
    one that runs other code (it finishes and leaves the new one's socket in place)."""
    path = tmp_path / "j.sock"
    env = dict(os.environ)
    first = worker.ensure(path, env, 60.0, tmp_path / "j.log")
    assert first is not None
    sock = worker._connect(path, worker.START_WAIT)
    assert sock is not None
    sock.close()
    try:
        assert worker.ensure(path, env, 60.0, tmp_path / "j.log") is None  # found, warm
        assert worker.control(path, "status")["pid"] == first.pid
        monkeypatch.setattr(worker, "package_version", lambda: "changed")
        second = worker.ensure(path, env, 60.0, tmp_path / "j.log")
        assert second is not None and second.pid != first.pid
        first.wait(timeout=60)  # the older worker stops
        sock = worker._connect(path, worker.START_WAIT)
        assert sock is not None  # and the new one's socket is still there
        sock.close()
        assert worker.control(path, "status")["pid"] == second.pid
        worker.stop(second)
    finally:
        worker.stop(first)
    assert worker.shared_socket(env) != worker.shared_socket({**env, "OMP_NUM_THREADS": "7"})
    assert worker.shared_socket(env) == worker.shared_socket({**env, "CREATIO_DEBUG": "1"})


# ----------------------------------------------------------------------------- issue 38
@contextlib.contextmanager
def _own_worker(tmp_path: Path, env: dict[str, str] | None = None,
                deadline: float | None = None):
    """A worker of this test at a socket in tmp_path, stopped whatever happens."""
    path = tmp_path / "own.sock"
    proc = worker.start(path, owner=os.getpid(), log=tmp_path / "own.log", wait=True,
                        env=env or _environ(), deadline=deadline)
    try:
        yield path
    finally:
        worker.stop(proc)


def _served(path: Path) -> int:
    return worker.control(path, "status")["served"]


@pytest.mark.long
def test_a_caller_with_other_limits_runs_in_its_own_process(warm, tmp_path):
    """`ulimit -t 1`: a forked job would inherit the worker's CPU limit, so the worker
    refuses and the command runs alone, where the kernel stops it after 1 s of CPU time, as
    it stops any process of its own (a fresh interpreter needs more to import the
    libraries)."""
    def one_cpu_second() -> None:
        resource.setrlimit(resource.RLIMIT_CPU, (1, 1))

    before = _served(warm)
    out = tmp_path / "x.nc"
    done = subprocess.run([*CLI, "task", "dataset", "en02", str(out), *LONG_JOB], cwd=tmp_path,
                          env={**_environ(), worker.ENV: str(warm), "CREATIO_DEBUG": "1"},
                          preexec_fn=one_cpu_second, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode in (-signal.SIGXCPU, -signal.SIGKILL), done.stderr
    assert "worker refused the job: the caller's limits differ: RLIMIT_CPU 1 (the worker's" \
        in done.stderr, done.stderr
    assert _served(warm) == before and not out.exists()


def test_limits_that_differ_are_named():
    """Every rlimit (soft and hard), the niceness and the CPU affinity are compared: the
    first that differs is named with both values."""
    mine = worker.limits()
    assert worker.limits_mismatch(mine, copy.deepcopy(mine)) is None
    nicer = {**mine, "nice": mine["nice"] + 5}
    assert worker.limits_mismatch(mine, nicer) == f"nice {mine['nice'] + 5} (the worker's " \
                                                  f"{mine['nice']})"
    small = copy.deepcopy(mine)
    small["rlimits"]["RLIMIT_AS"] = [150 << 20, 150 << 20]
    assert worker.limits_mismatch(mine, small).startswith("RLIMIT_AS 157286400 (the worker's")
    if "affinity" in mine:
        assert worker.limits_mismatch(mine, {**mine, "affinity": [0, 99999]}).startswith(
            "affinity [0, 99999]")
    assert worker.limits_mismatch(mine, None) == "limits (not sent)"


def _edit_keeping_stamp(path: Path, old: bytes, new: bytes) -> None:
    """Replace old by new (the same length) in path and put its modification time back, as
    cp -p, rsync -a or tar x do."""
    st = path.stat()
    data = path.read_bytes()
    assert data.count(old) == 1 and len(old) == len(new)
    path.write_bytes(data.replace(old, new))
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert path.stat().st_mtime_ns == st.st_mtime_ns and path.stat().st_size == st.st_size


def test_conf_is_compared_by_content_not_by_its_modification_time(tmp_path, monkeypatch):
    """An edit of conf/ whose size and modification time are unchanged is an edit: the
    stamp a warm worker compares (forget_if_changed) and the config cache's key both
    change, and an entry composed while conf/ changed is not filed under the old key."""
    conf = tmp_path / "conf"
    shutil.copytree(config.CONF_DIR, conf)
    monkeypatch.setattr(config, "CONF_DIR", conf)
    monkeypatch.setenv("CREATIO_CONFIG_CACHE", str(tmp_path / "cache"))
    monkeypatch.setitem(config._WARM, "stamp", config._conf_stamp())
    spec = config._cache_spec("en02", ("phases.T=26",))
    resolved = config.validate(config.compose("en02", ["phases.T=26"]))
    assert resolved.data["sphere"]["mu"] == 0.15
    assert not config.forget_if_changed()
    _edit_keeping_stamp(conf / "sphere" / "notebook.yaml", b"mu: 0.15", b"mu: 0.30")
    config._store(config._cache_path(spec), spec, resolved)  # composed before the edit
    assert not config._cache_path(spec).exists()
    assert config._cache_spec("en02", ("phases.T=26",)) != spec
    assert config.forget_if_changed()
    assert config.validate(config.compose("en02", ["phases.T=26"])).data["sphere"]["mu"] == 0.3


def _mu(nc: Path) -> float:
    with xr.open_dataset(nc) as ds:
        return load_yaml(ds.attrs["config_yaml"])["sphere"]["mu"]


@pytest.mark.long
def test_an_edit_of_conf_with_its_time_restored_is_seen_by_worker_and_cache(tmp_path):
    """The issue's commands: conf/sphere/notebook.yaml edited (mu 0.15 to 0.30, same size)
    and its modification time restored. A job the worker serves writes mu = 0.3; a process
    of its own writes 0.3 too (and caches it); restored the same way, the same command
    alone writes 0.15 under another config hash, and the worker's next job 0.15."""
    conf = tmp_path / "conf"
    shutil.copytree(config.CONF_DIR, conf)
    env = {**_environ(), "CREATIO_CONF_DIR": str(conf), "CREATIO_DEBUG": "",
           "CREATIO_CONFIG_CACHE": str(tmp_path / "cache")}
    env.pop(worker.ENV, None)
    notebook = conf / "sphere" / "notebook.yaml"
    alone = {**env, worker.ENV: "off"}

    def dataset(name: str, t: str, run_env: dict[str, str]) -> Path:
        out = tmp_path / name
        done = _run(["task", "dataset", "en02", str(out), "--override", f"phases.T={t}"],
                    run_env, tmp_path)
        assert done.returncode == 0, done.stderr
        return out

    with _own_worker(tmp_path, env) as path:
        served = {**env, worker.ENV: str(path)}
        _edit_keeping_stamp(notebook, b"mu: 0.15", b"mu: 0.30")
        assert _mu(dataset("w1.nc", "26", served)) == 0.3
        assert _served(path) == 1
        edited = dataset("a1.nc", "26.5", alone)
        assert _mu(edited) == 0.3
        _edit_keeping_stamp(notebook, b"mu: 0.30", b"mu: 0.15")
        restored = dataset("a2.nc", "26.5", alone)
        assert _mu(restored) == 0.15
        with xr.open_dataset(edited) as a, xr.open_dataset(restored) as b:
            assert a.attrs["config_sha256"] != b.attrs["config_sha256"]
        assert _mu(dataset("w2.nc", "26", served)) == 0.15
        assert _served(path) == 2


def test_the_whole_environment_is_compared_but_a_short_neutral_list():
    """Any variable a library or the loader may read when it loads refuses the job
    (LD_PRELOAD, SCIPY_ARRAY_API, NETCDF_PLUGIN_DIR, one no list names); what changes no
    result (the working directory, the shell's per-command variables, the temporary
    directory Snakemake sets per job) does not, nor what the worker's own imports set
    where it was unset (HDF5_PLUGIN_PATH, set by netCDF4 in Snakemake's process too). A
    Snakemake job's environment is served by the worker started for it."""
    base = {"HOME": "/h", "PATH": "/bin"}
    for name in ("LD_PRELOAD", "SCIPY_ARRAY_API", "NETCDF_PLUGIN_DIR", "ANY_OTHER_NAME"):
        assert worker.env_mismatch(base, {**base, name: "1"}) == name
        assert worker.env_mismatch({**base, name: "1"}, base) == name
    assert worker.env_mismatch(base, {**base, "PATH": "/usr/bin:/bin"}) == "PATH"
    per_job = {"PWD": "/w", "OLDPWD": "/", "SHLVL": "2", "_": "/usr/bin/creatio",
               "TERM": "dumb", "TMPDIR": "/tmp/job", "TMP": "/tmp/job", "TEMP": "/tmp/job",
               "TEMPDIR": "/tmp/job", worker.ENV: "/s.sock", "CREATIO_DEBUG": "1"}
    assert worker.env_mismatch(base, {**base, **per_job}) is None
    plugins = {"HDF5_PLUGIN_PATH": "/netCDF4/plugins"}
    assert worker.env_mismatch(base, {**base, **plugins}, imported=plugins) is None
    assert worker.env_mismatch(base, {**base, "HDF5_PLUGIN_PATH": "/elsewhere"},
                               imported=plugins) == "HDF5_PLUGIN_PATH"
    server = worker.Server(Path("unused.sock"), entry=lambda argv: 0)
    server.version = package_version()
    server.env = {k: v for k, v in worker.snakemake_job_env(1).items() if k != worker.ENV}
    job = {**worker.snakemake_job_env(1), **per_job}
    request = {**worker._identity(), "env": job, "limits": worker.limits()}
    assert server._refusal(request, [0, 1, 2]) is None
    request["env"] = worker.snakemake_job_env(4)  # an analysis's timing job: alone
    assert server._refusal(request, [0, 1, 2]).startswith("the environment differs in")
    assert worker.shared_socket(job) == worker.shared_socket(server.env)


@pytest.mark.long
def test_a_client_in_another_environment_runs_alone(warm, tmp_path):
    """The issue's command: a client whose SCIPY_ARRAY_API differs from the worker's is
    refused (one line under CREATIO_DEBUG) and its job runs in its own process."""
    before = _served(warm)
    env = {**_environ(), worker.ENV: str(warm), "CREATIO_DEBUG": "1", "SCIPY_ARRAY_API": "1"}
    done = _run(["task", "dataset", "ct02", str(tmp_path / "x.nc")], env, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "creatio: worker refused the job: the environment differs in SCIPY_ARRAY_API\n" \
        in done.stderr
    assert _served(warm) == before and (tmp_path / "x.nc").exists()


def _message(sock: socket.socket, body: bytes) -> bytes:
    """Send one framed message; what the worker answers before it closes (b'': nothing)."""
    sock.sendall(struct.pack("!I", len(body)) + body)
    sock.settimeout(10)
    return sock.recv(65536)


@pytest.mark.long
def test_a_stalled_or_malformed_client_costs_only_its_own_connection(tmp_path):
    """A client that stalls mid-header leaves the others served and is closed at its
    deadline; a message that is not JSON, not an object, or claims 1 GiB closes its own
    connection, and the worker keeps answering."""
    with _own_worker(tmp_path, deadline=1.0) as path:
        stalled = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        stalled.connect(str(path))
        stalled.sendall(b"\x00\x00")  # half a header, then nothing
        t0 = time.monotonic()
        assert worker.control(path, "status", timeout=5.0)["served"] == 0
        assert time.monotonic() - t0 < 0.9  # answered while the stalled one waits
        for body in (b"{not json", b"[1, 2]", b'{"control": 5}', b'{"argv": "run"}',
                     b"[" * 100_000):
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as bad:
                bad.connect(str(path))
                assert _message(bad, body) == b"", body
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as huge:
            huge.connect(str(path))
            huge.sendall(struct.pack("!I", 1 << 30))
            huge.settimeout(10)
            assert huge.recv(16) == b""
        stalled.settimeout(10)
        assert stalled.recv(16) == b""  # closed at its deadline
        assert time.monotonic() - t0 < 5.0
        stalled.close()
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as good:
            good.connect(str(path))
            reply = json.loads(_message(good, json.dumps({"control": "status"}).encode())[4:])
        assert reply["pid"] == worker.control(path, "status")["pid"]
