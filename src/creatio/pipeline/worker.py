"""A warm worker: each job runs in a process forked from one that has already imported the
libraries and loaded the compiled loops, so a job costs its computation, not a fresh
interpreter (about 1.5 s of imports and 0.3-0.7 s of numba cache loading per job here).

A worker listens on a Unix socket in a directory only its user can open. A client (a
``creatio task ...`` or ``creatio run ...`` command that finds one through ``CREATIO_WORKER``,
or a ``creatio worker start`` daemon of its checkout) sends its arguments, working directory,
environment and its three standard streams (the descriptors themselves, so a job's ``2>
log`` is the job's log); the worker forks, the child runs ``creatio.cli.main`` exactly as the
command would have run it, and the client exits with the child's status. Signals the client
receives are passed on to the child; a client that goes away takes its child with it.

The worker serves only what it would compute the same way as a fresh process: a client of
another checkout, another interpreter or ``sys.path``, an environment that differs in any
variable but the few of :data:`NEUTRAL_ENV` and :data:`CALL_TIME` (``LD_PRELOAD``,
``NUMBA_*``, ``SCIPY_ARRAY_API``, ... : a library may read any of them when it loads), or
other resource limits, niceness or CPU affinity (:func:`limits`: ``ulimit -t 3`` must stop
the job at 3 s, as it stops a process of its own) is refused and runs in its own process, as
does every client once a source of the package has changed
(creatio.pipeline.code.package_version; the worker then exits): a worker never computes a
result with older code. A job forked while conf/ differs by content from what the worker
composed composes again (creatio.pipeline.config.forget_if_changed). A job in a batch
scheduler (``SLURM_JOB_ID``, ...) never uses a worker; a worker that dies during a job has
that job stopped, and the command runs again in its own process. The analyses' timing jobs
pin thread counts in their environment and so always run alone.

A client that stalls or sends what is not a request costs only its own connection: each one
has :data:`REQUEST_DEADLINE` seconds to send its request, read as it arrives while the
worker serves the others, and anything malformed closes it.

Compiled loops: a child tells the worker which specialisations it loaded or compiled, and the
worker loads them from numba's cache between requests, so the next jobs inherit them; the
first job that needs a specialisation the cache lacks compiles it while any other job that
needs the same one waits for it (one compilation, not one per job).

``snakemake`` uses a shared worker for its jobs when it runs them locally (creatio.pipeline.
invocation): the one of this checkout and of the environment Snakemake gives its jobs
(:func:`shared_socket`), started on demand by the first invocation that finds none and kept
until it has been idle for :data:`SHARED_IDLE` seconds, so that the next invocation's jobs
start warm instead of waiting for a worker to import everything again; ``creatio worker
start`` starts the daemon of ``creatio run`` (the user's own environment), which stays until
it has been idle for ``--idle`` seconds; a plain ``creatio run`` that no worker served starts
that daemon itself once it has said its result (:func:`autostart`: idle after
``CREATIO_WORKER_IDLE`` s, default :data:`SHARED_IDLE`), so the next run is warm.
``CREATIO_WORKER=off`` runs every command in its own process and starts none.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from creatio.pipeline.code import package_version

__all__ = [
    "COMMANDS",
    "ENV",
    "NEUTRAL_ENV",
    "SHARED_IDLE",
    "Server",
    "autostart",
    "daemon_socket",
    "delegate",
    "ensure",
    "env_mismatch",
    "limits",
    "limits_mismatch",
    "main",
    "shared_socket",
    "start",
    "stop",
]

#: The variable that names a worker's socket for the commands (or ``off``).
ENV = "CREATIO_WORKER"
#: Commands a worker runs (`creatio task ...`, `creatio run ...`, `creatio calibrate ...`,
#: which `snakemake en05` runs as a job); the rest run in place.
COMMANDS = ("task", "run", "calibrate")
#: The only environment variables in which a client may differ from its worker (besides
#: :data:`CALL_TIME`): every other one may be read when a library or the dynamic loader
#: loads (``LD_PRELOAD``, ``NUMBA_*``, ``SCIPY_ARRAY_API``, ``NETCDF_PLUGIN_DIR``, ...), so
#: the worker compares them all. These change no result: the working directory (a job
#: takes the client's own), what the shell sets per command (``SHLVL``, ``_``), the
#: terminal (read when output is written), and the temporary directory, which Snakemake
#: sets per job and a job reads again (``tempfile.tempdir``).
NEUTRAL_ENV = frozenset(("PWD", "OLDPWD", "SHLVL", "_", "TERM", "COLUMNS", "LINES",
                         "TMPDIR", "TMP", "TEMP", "TEMPDIR"))
#: Seconds without a job after which the shared worker of Snakemake's jobs stops
#: (``CREATIO_WORKER_IDLE`` sets it).
SHARED_IDLE = 900.0
#: Read when a command runs, not at import: a worker serves any value of these.
CALL_TIME = (ENV, "CREATIO_DEBUG", "CREATIO_WORKER_IDLE", "CREATIO_FORK", "CREATIO_FIGURES")
#: Set in a batch scheduler's job (SLURM, PBS, LSF): such a job never uses a worker, even
#: one of the same user on the same node.
BATCH_JOB = ("SLURM_JOB_ID", "PBS_JOBID", "LSB_JOBID")
#: Seconds a client waits for a worker that is still starting before it runs alone.
START_WAIT = 60.0
#: Seconds a connection has to send its whole request (a client sends it at once); one
#: that stalls is closed, the others are served meanwhile.
REQUEST_DEADLINE = 5.0
#: The largest request a worker reads (a client's environment is a few kB).
MAX_MESSAGE = 1 << 22
#: Seconds a worker waits to hand a reply to a client that does not read it.
SEND_TIMEOUT = 5.0
_HEADER = struct.Struct("!I")
_PACKAGE = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------- both sides
def _send(sock: socket.socket, message: Mapping[str, Any], fds: Sequence[int] = ()) -> None:
    data = json.dumps(message).encode()
    payload = _HEADER.pack(len(data)) + data
    if fds:
        sent = socket.send_fds(sock, [payload], list(fds))
        if sent < len(payload):  # never an empty send: the peer may have answered and gone
            sock.sendall(payload[sent:])
    else:
        sock.sendall(payload)


def _recv(sock: socket.socket, maxfds: int = 0) -> tuple[dict[str, Any] | None, list[int]]:
    """One message (None at end of stream) and the descriptors that came with it."""
    fds: list[int] = []
    buf = b""
    while len(buf) < _HEADER.size:
        if maxfds and not fds:
            chunk, got, _, _ = socket.recv_fds(sock, 65536, maxfds)
            fds += got
        else:
            chunk = sock.recv(65536)
        if not chunk:
            for fd in fds:
                os.close(fd)
            return None, []
        buf += chunk
    (n,) = _HEADER.unpack(buf[:_HEADER.size])
    buf = buf[_HEADER.size:]
    while len(buf) < n:
        chunk = sock.recv(n - len(buf))
        if not chunk:
            for fd in fds:
                os.close(fd)
            return None, []
        buf += chunk
    return json.loads(buf[:n]), fds


def _private_dir() -> Path:
    """The directory of this user's worker sockets (mode 0700, owned by the user): nobody
    else can connect to a socket in it."""
    path = Path(tempfile.gettempdir()) / f"creatio-{os.getuid()}"
    path.mkdir(mode=0o700, exist_ok=True)
    st = path.lstat()
    if st.st_uid != os.getuid() or st.st_mode & 0o077 or not path.is_dir():
        raise PermissionError(f"{path} is not a private directory of this user")
    return path


def daemon_socket() -> Path:
    """The socket of this checkout's daemon (`creatio worker start`)."""
    key = hashlib.sha256(str(_PACKAGE).encode()).hexdigest()[:12]
    return _private_dir() / f"d-{key}.sock"


def _compared(env: Mapping[str, str]) -> dict[str, str]:
    """The variables of env a worker and its clients must agree on: all of them but
    :data:`NEUTRAL_ENV` and :data:`CALL_TIME`."""
    return {k: v for k, v in env.items() if k not in NEUTRAL_ENV and k not in CALL_TIME}


def shared_socket(env: Mapping[str, str]) -> Path:
    """The socket of the shared worker of this checkout for clients whose environment is env
    (Snakemake's jobs): one per checkout and per environment (but :data:`NEUTRAL_ENV` and
    :data:`CALL_TIME`), so that invocations from another environment get a worker of their
    own."""
    key = hashlib.sha256(str(_PACKAGE).encode() + b"\0" + json.dumps(
        sorted(_compared(env).items())).encode()).hexdigest()[:12]
    return _private_dir() / f"j-{key}.sock"


def _identity() -> dict[str, Any]:
    """What a client and its worker must share to compute the same way."""
    return {"package": str(_PACKAGE), "executable": sys.executable, "path": sys.path[1:]}


def env_mismatch(worker_env: Mapping[str, str], client_env: Mapping[str, str],
                 imported: Mapping[str, str] | None = None) -> str | None:
    """The first variable (but :data:`NEUTRAL_ENV` and :data:`CALL_TIME`) whose value
    differs between a worker's environment (as it started) and a client's, as ``NAME``
    (None: they agree). imported: what the worker's imports set where it was unset
    (netCDF4 sets ``HDF5_PLUGIN_PATH`` to its own plugins): a client that holds the same
    value (Snakemake's process imported netCDF4 too, and its later jobs inherit it)
    computes as a fresh process would, which sets it the same way."""
    names = {*_compared(worker_env), *_compared(client_env)}
    for name in sorted(names):
        mine, theirs = worker_env.get(name), client_env.get(name)
        if mine != theirs and not (mine is None and theirs is not None
                                   and (imported or {}).get(name) == theirs):
            return name
    return None


def limits() -> dict[str, Any]:
    """What the kernel limits a process by that a forked job would inherit from its worker
    instead of its caller: every resource limit (soft, hard; ``ulimit``), the niceness and
    the CPUs it may run on (``taskset``)."""
    import resource

    rlimits = {name: list(resource.getrlimit(getattr(resource, name)))
               for name in sorted(dir(resource)) if name.startswith("RLIMIT_")}
    out: dict[str, Any] = {"rlimits": rlimits, "nice": os.getpriority(os.PRIO_PROCESS, 0)}
    if hasattr(os, "sched_getaffinity"):
        out["affinity"] = sorted(os.sched_getaffinity(0))
    return out


def limits_mismatch(worker: Mapping[str, Any], client: Any) -> str | None:
    """How a client's limits (:func:`limits`) differ from its worker's, as
    ``RLIMIT_CPU 3 (the worker's unlimited)`` (None: they agree)."""
    if not isinstance(client, dict):
        return "limits (not sent)"

    def shown(value: Any) -> str:
        import resource

        if not (isinstance(value, list) and len(value) == 2):
            return str(value)
        soft, hard = ("unlimited" if v == resource.RLIM_INFINITY else str(v) for v in value)
        return soft if soft == hard else f"{soft} (hard {hard})"

    theirs = client.get("rlimits")
    for name, value in worker["rlimits"].items():
        other = theirs.get(name) if isinstance(theirs, dict) else None
        if other != value:
            return f"{name} {shown(other)} (the worker's {shown(value)})"
    for key in ("nice", "affinity"):
        if client.get(key) != worker.get(key):
            return f"{key} {client.get(key)} (the worker's {worker.get(key)})"
    return None


# ----------------------------------------------------------------------------- client
def _connect(path: Path, wait: float) -> socket.socket | None:
    """A connection to the worker at path, waiting up to `wait` s while it starts (its
    ``.starting`` file names a live process); None when there is none."""
    deadline = time.monotonic() + wait
    while True:
        # looked at before connecting: a worker listens before it removes its .starting
        # file, so a file gone before the attempt means no worker is coming
        coming = _starting(path)
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            sock.connect(str(path))
            return sock
        except OSError:
            sock.close()
        if not coming or time.monotonic() > deadline:
            return None
        time.sleep(0.02)


def delegate(argv: Sequence[str]) -> int | None:
    """Run a command in a worker and return its exit status, or None when no worker serves
    it (then the caller runs it in its own process)."""
    global _unserved
    _unserved = None
    name = os.environ.get(ENV, "")
    if name == "off" or not argv or argv[0] not in COMMANDS:
        return None
    if any(k in os.environ for k in BATCH_JOB):  # a cluster job computes on its node, alone
        return None
    try:
        path = Path(name) if name else daemon_socket()
    except OSError:
        return None
    _unserved = None if name else dict(os.environ)  # as it started, for autostart
    if not name and not path.exists():
        return None
    sock = _connect(path, START_WAIT if name else 0.0)
    if sock is None:
        return None
    with sock:
        request = {"argv": list(argv), "sys_argv": sys.argv, "cwd": os.getcwd(),
                   "env": dict(os.environ), "umask": _umask(), "limits": limits(),
                   **_identity()}
        try:
            sock.settimeout(START_WAIT)  # a worker that does not answer: run alone
            _send(sock, request, fds=[0, 1, 2])
            reply, _ = _recv(sock)
            sock.settimeout(None)
        except (OSError, ValueError):
            return None
        if not isinstance(reply, dict) or not ("refused" in reply or "pid" in reply):
            return None
        if "pid" in reply:
            _unserved = None
        if "refused" in reply:
            if os.environ.get("CREATIO_DEBUG"):
                print(f"creatio: worker refused the job: {reply['refused']}", file=sys.stderr)
            return None
        child = int(reply["pid"])
        handlers = {signum: signal.getsignal(signum) for signum in FORWARDED}
        try:
            code = _wait(sock, child)
        finally:
            for signum, handler in handlers.items():
                signal.signal(signum, handler)
        if code is None:  # the worker died mid-job: its job is stopped, the command reruns
            _end(child)
            print("creatio: the warm worker stopped during the job: it runs again in its "
                  "own process", file=sys.stderr)
        return code


#: The environment, as it started, of this process's own command when no daemon served it
#: with ``CREATIO_WORKER`` unset (:func:`delegate`): :func:`autostart` starts the daemon in
#: it (not in what the command's imports set since), so that the next runs match it.
_unserved: dict[str, str] | None = None


def autostart(argv: Sequence[str]) -> subprocess.Popen | None:
    """Start this checkout's daemon in the background once a `creatio run` that no worker
    served has said its result, so that the next run of the session is warm (the daemon
    warms up meanwhile; a run before it is ready runs alone): as Snakemake's invocations
    start their shared worker, it stops after ``CREATIO_WORKER_IDLE`` s idle (default
    :data:`SHARED_IDLE`). Never for a command a worker runs, another command or one with
    options (``--help``, ``-m``), with ``CREATIO_WORKER`` set, in a batch job, under a
    CPU-time limit (the daemon would inherit it), or where forking or passing descriptors
    is unavailable. Says so on stderr, in one line, when it starts one; returns the daemon
    started (None: none)."""
    import resource

    if (_unserved is None or list(argv[:1]) != ["run"] or any(a.startswith("-") for a in argv[1:])
            or os.environ.get(ENV) or any(k in os.environ for k in BATCH_JOB)
            or not (hasattr(os, "fork") and hasattr(socket, "send_fds")
                    and hasattr(socket, "AF_UNIX"))
            or resource.getrlimit(resource.RLIMIT_CPU)[0] != resource.RLIM_INFINITY):
        return None
    try:
        idle = float(os.environ.get("CREATIO_WORKER_IDLE", SHARED_IDLE))
    except ValueError:
        idle = SHARED_IDLE
    if not idle > 0:
        idle = SHARED_IDLE
    try:
        path = daemon_socket()
        proc = ensure(path, _unserved, idle, path.with_suffix(".log"))
    except OSError:
        return None
    if proc is not None:
        print(f"creatio: starting a warm worker for the next `creatio run` of this checkout "
              f"(pid {proc.pid}, stops after {idle:g} s idle; `creatio worker stop` stops it "
              "now; CREATIO_WORKER=off never starts one)", file=sys.stderr, flush=True)
    return proc


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: Signals a client passes on to its job.
FORWARDED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)


def _wait(sock: socket.socket, child: int) -> int | None:
    """The child's exit status, passing the signals this client gets on to it (None: the
    worker went away before it said)."""
    def forward(signum: int, _frame: Any) -> None:
        with contextlib.suppress(OSError):
            os.kill(child, signum)

    for signum in FORWARDED:
        signal.signal(signum, forward)
    while True:
        try:
            reply, _ = _recv(sock)
        except InterruptedError:
            continue
        except (OSError, ValueError):
            reply = None
        if not isinstance(reply, dict):
            return None
        if "exit" in reply:
            return int(reply["exit"])


def _end(child: int, grace: float = 5.0) -> None:
    """Stop the job of a worker that died (its own process group), so that nothing of it
    writes after the command's own run starts: SIGTERM, then SIGKILL after grace s."""
    def alive() -> bool:
        try:
            state = Path(f"/proc/{child}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            try:
                os.kill(child, 0)
            except ProcessLookupError:
                return False
            except PermissionError:  # another user's process now: not our job
                return False
            return True
        return state not in ("Z", "X")

    for signum, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, grace)):
        with contextlib.suppress(OSError):
            os.killpg(child, signum)
        deadline = time.monotonic() + wait
        while alive() and time.monotonic() < deadline:
            time.sleep(0.02)
        if not alive():
            return


# ----------------------------------------------------------------------------- server
#: The fields of a job's request and their types (anything else is malformed).
REQUEST_FIELDS: dict[str, type | tuple[type, ...]] = {
    "argv": list, "sys_argv": list, "cwd": str, "env": dict, "umask": int, "limits": dict,
    "package": str, "executable": str, "path": list}


def _malformed(request: Any) -> bool:
    """Whether a message is neither a control message nor a job's request whose fields
    have their types (a command's words and its environment are strings)."""
    if not isinstance(request, dict):
        return True
    if "control" in request:
        return request.get("control") not in ("status", "stop")
    if any(not isinstance(request.get(k), t) for k, t in REQUEST_FIELDS.items()):
        return True
    words = [*request["argv"], *request["sys_argv"], *request["env"], *request["env"].values()]
    return not all(isinstance(w, str) for w in words)


#: Imported before the first request: what the jobs of the workflow use.
WARM_MODULES = (
    "numpy", "scipy.linalg", "scipy.optimize", "xarray", "netCDF4", "numba", "matplotlib",
    "hydra", "omegaconf", "yaml", "creatio.pipeline.config",
    "creatio.pipeline.run", "creatio.pipeline.provenance", "creatio.pipeline.sweep",
    "creatio.pipeline.points", "creatio.pipeline.checks", "creatio.pipeline.index",
    "creatio.pipeline.calibrate",
)


def _warm(extra: Sequence[str] = ()) -> None:
    """Import what the jobs use (WARM_MODULES, and the caller's extra modules: the layers
    above this one, which it names) and fill the caches libraries build on first use
    (xarray's backends, matplotlib's fonts, Hydra's plugins and first composition): every
    forked job inherits them."""
    import importlib

    import matplotlib

    matplotlib.use("Agg")
    for module in (*WARM_MODULES, *extra):
        importlib.import_module(module)
    from creatio.reports.registry import writer
    from creatio.studies import registry

    for entry in registry.STUDIES.values():
        with contextlib.suppress(Exception):  # a study whose module cannot load fails alone
            entry.run_function()
            writer(entry.id)
    import matplotlib.font_manager
    import xarray as xr
    from hydra.core.plugins import Plugins

    xr.backends.list_engines()
    # the first index xarray builds imports its duck-array modules (pint, scipy, ...):
    # 0.07-0.1 s of every job that reads a dataset, paid here once
    xr.Dataset({"v": ("x", [0.0])}, coords={"x": [0.0]})
    matplotlib.font_manager.findfont("DejaVu Sans")
    Plugins.instance()
    from creatio.pipeline import config

    with contextlib.suppress(Exception):  # a conf/ that fails to compose fails in the job
        config.warm()
    install_compile_lock()


class Server:
    """The worker: warm, then fork a child per request until stopped, orphaned or idle."""

    def __init__(self, path: Path, entry: Callable[[list[str]], int], idle: float | None = None,
                 owner: int | None = None, deadline: float = REQUEST_DEADLINE,
                 warm: Sequence[str] = ()) -> None:
        self.path, self.entry, self.idle, self.owner = Path(path), entry, idle, owner
        self.env = dict(os.environ)  # as started: what import-time reads saw
        self.limits = limits()  # what a forked job inherits
        self.imported: dict[str, str] = {}  # what its imports set (see env_mismatch)
        self.deadline = deadline
        self.warm = tuple(warm)
        self.jobs: dict[int, dict[str, Any]] = {}  # child pid -> its client and report pipe
        #: connections whose request is still arriving: what came so far, and by when
        self.pending: dict[socket.socket, dict[str, Any]] = {}
        self.learned: list[tuple[str, str, Any, Any]] = []
        self.served = 0
        self.stopping = False
        self.inode: int | None = None  # of the socket file it bound (removes only its own)

    def serve(self) -> None:
        """Warm up, listen, and serve until stopped."""
        starting = self.path.with_name(self.path.name + ".starting")
        try:
            self.version = package_version()
            _warm(self.warm)
            self.imported = {k: v for k, v in os.environ.items() if k not in self.env}
            _freeze()
            self.known = {d: set(disp.signatures) for d, disp in _dispatchers()}
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
            self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.listener.bind(str(self.path))
            self.inode = self.path.stat().st_ino
            self.listener.listen(64)
            self.listener.setblocking(False)
        finally:
            with contextlib.suppress(FileNotFoundError):
                starting.unlink()
        self._loop()

    def _loop(self) -> None:
        wake_r, wake_w = os.pipe()
        os.set_blocking(wake_w, False)
        os.set_blocking(wake_r, False)
        signal.set_wakeup_fd(wake_w)
        signal.signal(signal.SIGCHLD, lambda *_: None)
        signal.signal(signal.SIGTERM, self._stop)
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the terminal's Ctrl-C is the clients'
        last = time.monotonic()
        try:
            while not (self.stopping and not self.jobs):
                watched: list[Any] = [wake_r]
                for job in self.jobs.values():
                    watched += [] if job["gone"] else [job["conn"]]
                    watched += [] if job["pipe"] is None else [job["pipe"]]
                if not self.stopping:
                    watched.append(self.listener)
                watched += list(self.pending)
                wait = 0.0 if self.learned else min(
                    [1.0, *(max(0.0, c["deadline"] - time.monotonic()) + 0.01
                            for c in self.pending.values())])
                ready, _, _ = select.select(watched, [], [], wait)
                if wake_r in ready:
                    with contextlib.suppress(BlockingIOError):
                        os.read(wake_r, 4096)
                for item in ready:
                    if item is self.listener:
                        self._accept()
                    elif item in self.pending:
                        self._read(item)
                    elif isinstance(item, socket.socket):
                        self._client_gone(item)
                    elif item != wake_r:
                        self._drain(item)
                self._expire()
                self._reap()
                if not ready and self.learned:
                    self._load_one()
                if self.jobs or self.pending or self.listener in ready:
                    last = time.monotonic()
                if self.owner is not None and os.getppid() != self.owner:
                    self.stopping = True  # its Snakemake is gone
                if self.idle is not None and time.monotonic() - last > self.idle:
                    self.stopping = True
                if self.stopping:
                    self._withdraw()
        finally:
            self.listener.close()
            for conn in list(self.pending):
                self._drop(conn)
            self._withdraw()

    def _withdraw(self) -> None:
        """Remove the socket file, so that no new client connects, if it is still this
        worker's (a successor may have bound a new one at the same path)."""
        if self.inode is None:
            return
        with contextlib.suppress(OSError):
            if self.path.stat().st_ino == self.inode:
                self.path.unlink()
        self.inode = None

    def _stop(self, *_: Any) -> None:
        self.stopping = True

    def _accept(self) -> None:
        """Take a new connection; its request is read as it arrives (:meth:`_read`)."""
        try:
            conn, _ = self.listener.accept()
        except OSError:  # gone before it was taken
            return
        conn.setblocking(False)
        self.pending[conn] = {"data": b"", "fds": [],
                              "deadline": time.monotonic() + self.deadline}

    def _drop(self, conn: socket.socket) -> None:
        """Close a connection whose request did not arrive whole, and what it sent."""
        state = self.pending.pop(conn, None)
        for fd in state["fds"] if state else []:
            with contextlib.suppress(OSError):
                os.close(fd)
        conn.close()

    def _expire(self) -> None:
        """Close the connections that missed their deadline (a stalled client)."""
        now = time.monotonic()
        for conn, state in list(self.pending.items()):
            if now > state["deadline"]:
                self._drop(conn)

    def _read(self, conn: socket.socket) -> None:
        """Read what a connection has sent; once its whole message is there, answer it.
        Anything malformed (too long, more than three descriptors, not a JSON object of
        the expected fields) closes that connection only."""
        state = self.pending[conn]
        try:
            chunk, fds, flags, _ = socket.recv_fds(conn, 65536, 3)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            self._drop(conn)
            return
        state["fds"] += fds
        state["data"] += chunk
        data = state["data"]
        if not chunk or flags & socket.MSG_CTRUNC or len(state["fds"]) > 3:
            self._drop(conn)  # gone before its request was whole, or sent what none sends
            return
        if len(data) < _HEADER.size:
            return
        (n,) = _HEADER.unpack(data[:_HEADER.size])
        if n > MAX_MESSAGE or len(data) > _HEADER.size + n:
            self._drop(conn)
            return
        if len(data) < _HEADER.size + n:
            return
        try:
            request = json.loads(data[_HEADER.size:])
        except (ValueError, RecursionError):  # not JSON, or nested past the parser's depth
            request = None
        if _malformed(request):
            self._drop(conn)
            return
        del self.pending[conn]
        conn.settimeout(SEND_TIMEOUT)  # replies are small: a client that never reads them
        fds = state["fds"]
        try:
            if "control" in request:
                for fd in fds:
                    os.close(fd)
                self._control(conn, request["control"])
            else:
                self._serve_one(conn, request, fds)
        except Exception as e:  # noqa: BLE001 - one request's failure is not the worker's
            print(f"creatio worker: a request failed: {type(e).__name__}: {e}",
                  file=sys.stderr, flush=True)
            with contextlib.suppress(OSError):
                conn.close()

    def _serve_one(self, conn: socket.socket, request: Mapping[str, Any],
                   fds: list[int]) -> None:
        """Refuse a request or fork its job."""
        reason = self._refusal(request, fds)
        if reason is not None:
            for fd in fds:
                os.close(fd)
            with contextlib.suppress(OSError):
                _send(conn, {"refused": reason})
            conn.close()
            return
        report_r, report_w = os.pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # the job: never returns to the worker's loop
            code = 1
            try:
                os.close(report_r)
                self.listener.close()
                conn.close()
                for other in self.pending:
                    other.close()
                for job in self.jobs.values():
                    job["conn"].close()
                    if job["pipe"] is not None:
                        os.close(job["pipe"])
                code = _child(self.entry, request, fds, report_w, self.known)
            finally:
                os._exit(code)
        os.close(report_w)
        os.set_blocking(report_r, False)
        for fd in fds:
            os.close(fd)
        self.served += 1
        self.jobs[pid] = {"conn": conn, "pipe": report_r, "data": b"", "exit": None,
                          "gone": False}
        try:
            _send(conn, {"pid": pid})
        except OSError:
            self._kill(pid)

    def _refusal(self, request: Mapping[str, Any], fds: Sequence[int]) -> str | None:
        """Why this worker would not compute the request as its own process would (None:
        it would)."""
        if len(fds) != 3:
            return "the client's standard streams did not arrive"
        mine = _identity()
        for key in ("package", "executable", "path"):
            if request.get(key) != mine[key]:
                return f"another {key} ({request.get(key)!r}, the worker's {mine[key]!r})"
        name = env_mismatch(self.env, request.get("env", {}), self.imported)
        if name is not None:
            return f"the environment differs in {name}"
        limit = limits_mismatch(self.limits, request.get("limits"))
        if limit is not None:
            return f"the caller's limits differ: {limit}"
        if package_version() != self.version:  # older code never computes a result
            self.stopping = True
            return "the sources changed since the worker started (it stops)"
        return None

    def _control(self, conn: socket.socket, what: str) -> None:
        """Answer `status` (and `stop`, which stops the worker) with the worker's state."""
        with conn:
            if what == "stop":
                self.stopping = True
            with contextlib.suppress(OSError):
                _send(conn, {"pid": os.getpid(), "jobs": len(self.jobs), "served": self.served,
                             "package": str(_PACKAGE), "stopping": self.stopping,
                             "version": self.version})

    def _reap(self) -> None:
        """Collect the children that exited: learn what each loaded, tell its client."""
        for pid in list(self.jobs):
            try:
                done, status = os.waitpid(pid, os.WNOHANG)
            except ChildProcessError:  # reaped elsewhere: its status is unknown
                done, status = pid, 1 << 8
            if done == 0:
                continue
            job = self.jobs.pop(pid)
            code = os.waitstatus_to_exitcode(status)
            if job["pipe"] is not None:  # its writer is closed: read to the end
                os.set_blocking(job["pipe"], True)
                while chunk := os.read(job["pipe"], 65536):
                    job["data"] += chunk
                os.close(job["pipe"])
            self._learn(job["data"])
            with contextlib.suppress(OSError):
                _send(job["conn"], {"exit": 128 - code if code < 0 else code})
            job["conn"].close()

    def _client_gone(self, conn: socket.socket) -> None:
        """A client's connection is readable only when it went away (a killed job): its
        child is stopped too."""
        for pid, job in self.jobs.items():
            if job["conn"] is conn:
                job["gone"] = True
                self._kill(pid)

    def _kill(self, pid: int) -> None:
        with contextlib.suppress(OSError):
            os.killpg(pid, signal.SIGTERM)

    def _drain(self, fd: int) -> None:
        """Read what a child has said so far about what it loaded."""
        for job in self.jobs.values():
            if job["pipe"] == fd:
                try:
                    while chunk := os.read(fd, 65536):
                        job["data"] += chunk
                except BlockingIOError:
                    return
                os.close(fd)  # the end: the child closed it
                job["pipe"] = None
                return

    def _learn(self, data: bytes) -> None:
        import pickle

        if not data:
            return
        try:
            items = pickle.loads(data)  # from the worker's own child, over its own pipe
        except Exception:  # noqa: BLE001 - a child killed mid-write said nothing usable
            return
        for key, sigs in items:
            for sig in sigs:
                if sig not in self.known.get(key, set()) and (key, sig) not in self.learned:
                    self.learned.append((key, sig))

    def _load_one(self) -> None:
        """Load one learned specialisation from numba's cache (never compile it here: a
        compilation belongs to the job that needs it)."""
        from creatio.dynamics.jit import load_cached

        key, sig = self.learned.pop(0)
        disp = dict(_dispatchers()).get(key)
        if disp is None or sig in self.known.get(key, set()):
            return
        self.known.setdefault(key, set()).add(sig)
        with contextlib.suppress(Exception):
            load_cached(disp, sig)
        _freeze()


def _freeze() -> None:
    """Move everything the worker holds out of the garbage collector's reach (gc.freeze): a
    forked job's collections then scan only what the job allocates, not the worker's whole
    inherited heap (and do not copy its pages by touching them). A cold compilation in a job
    collects some 30 times: 26.0 s against 29.6 s unfrozen here (one pair, load 1)."""
    import gc

    gc.collect()
    gc.freeze()


def _dispatchers() -> Iterator[tuple[str, Any]]:
    """Every numba dispatcher of creatio's modules, by a name that finds it again: module
    attributes and the entries of a module-level table (dict, list, tuple)."""
    from numba.core.dispatcher import Dispatcher

    for name, module in list(sys.modules.items()):
        if not name.startswith("creatio.") or module is None:
            continue
        for attr, value in list(vars(module).items()):
            if isinstance(value, Dispatcher):
                yield f"{name}:{attr}", value
            elif isinstance(value, dict | list | tuple):
                items = value.items() if isinstance(value, dict) else enumerate(value)
                with contextlib.suppress(Exception):
                    for k, v in items:
                        if isinstance(v, Dispatcher):
                            yield f"{name}:{attr}[{k!r}]", v


def _child(entry: Callable[[list[str]], int], request: Mapping[str, Any], fds: Sequence[int],
           report: int, known: Mapping[str, set]) -> int:
    """In the forked job: become the client's process (streams, directory, environment,
    arguments), run the command (entry: creatio.cli.main), tell the worker which
    specialisations it loaded."""
    import io
    import pickle

    code = 1
    try:
        os.setpgid(0, 0)
        for target, fd in enumerate(fds):
            os.dup2(fd, target)
            os.close(fd)
        os.chdir(request["cwd"])
        os.umask(int(request["umask"]))
        os.environ.clear()
        os.environ.update(request["env"])
        time.tzset()
        tempfile.tempdir = None  # read TMPDIR again (Snakemake sets it per job)
        for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT, signal.SIGCHLD):
            signal.signal(signum, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.set_wakeup_fd(-1)
        # streams as a fresh interpreter would open them on these descriptors
        sys.stdin = io.TextIOWrapper(io.FileIO(0, "r", closefd=False),
                                     encoding=sys.stdin.encoding, errors=sys.stdin.errors)
        sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False),
                                      encoding=sys.stdout.encoding, errors=sys.stdout.errors,
                                      line_buffering=os.isatty(1))
        sys.stderr = io.TextIOWrapper(io.FileIO(2, "w", closefd=False),
                                      encoding=sys.stderr.encoding, errors="backslashreplace",
                                      line_buffering=True)
        sys.argv = list(request["sys_argv"])
        from creatio.pipeline.config import forget_if_changed

        forget_if_changed()  # conf/ edited since the worker composed: compose again
        try:
            code = entry(list(request["argv"]))
        except SystemExit as e:  # a Hydra app exits
            if e.code is None or isinstance(e.code, int):
                code = e.code or 0
            else:
                print(e.code, file=sys.stderr)
                code = 1
        except KeyboardInterrupt:
            code = 130
    finally:
        with contextlib.suppress(Exception):
            import logging

            logging.shutdown()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        with contextlib.suppress(Exception):
            new = [(key, [s for s in disp.signatures if s not in known.get(key, set())])
                   for key, disp in _dispatchers()]
            os.write(report, pickle.dumps([(k, s) for k, s in new if s]))
        with contextlib.suppress(OSError):
            os.close(report)
    return code if isinstance(code, int) else 1


# ----------------------------------------------------------------------------- compile lock
_compiling = threading.local()


def install_compile_lock() -> None:
    """One compilation of a specialisation across processes: a process about to compile
    (or load) a signature a dispatcher lacks first takes a file lock named by the function
    and signature in numba's cache directory, so that a second job needing it waits and
    then loads it from the cache instead of compiling it again. Only the outermost
    compilation of a thread locks (the callees it compiles do not), so locks never nest."""
    import fcntl

    from numba.core import sigutils
    from numba.core.dispatcher import Dispatcher

    if getattr(Dispatcher.compile, "_creatio_locked", False):
        return
    compile_ = Dispatcher.compile

    def compile(self: Any, sig: Any) -> Any:  # noqa: A001 - numba's method name
        depth = getattr(_compiling, "depth", 0)
        where = _lock_dir()
        try:
            args, _ = sigutils.normalize_signature(sig)
            known = tuple(args) in self.overloads
        except Exception:  # noqa: BLE001 - numba will say what is wrong with sig
            known = True
        _compiling.depth = depth + 1
        try:
            if depth or known or where is None:
                return compile_(self, sig)
            name = f"{self.py_func.__module__}.{self.py_func.__qualname__}{tuple(args)}"
            path = where / (hashlib.sha256(name.encode()).hexdigest()[:24] + ".lock")
            fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o600)  # a lock: never any content
            try:
                fcntl.flock(fd, fcntl.LOCK_EX)  # released when fd closes, or the process dies
                return compile_(self, sig)
            finally:
                os.close(fd)
        finally:
            _compiling.depth = depth

    compile._creatio_locked = True  # type: ignore[attr-defined]
    Dispatcher.compile = compile


def _lock_dir() -> Path | None:
    """Where the compile locks live (beside numba's cache), or None when it cannot be
    written (then nothing locks)."""
    root = os.environ.get("NUMBA_CACHE_DIR")
    if not root:
        return None
    path = Path(root) / ".locks"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return path if os.access(path, os.W_OK) else None


# ----------------------------------------------------------------------------- lifecycle
def _mark_starting(path: Path, pid: int) -> None:
    """The ``.starting`` file beside a socket: the pid of the worker that will listen on it
    (clients wait for it while that process lives)."""
    target = path.with_name(path.name + ".starting")
    tmp = target.with_name(f".{target.name}.tmp-{os.getpid()}")
    tmp.write_text(str(pid))
    os.replace(tmp, target)


#: What Snakemake's shell sets for a job of ``threads`` threads (snakemake/shell.py): a
#: worker for Snakemake's jobs starts with them at 1, the threads of every creatio rule but
#: the analyses', whose timing jobs then differ in NUMBA_NUM_THREADS and run alone.
SNAKEMAKE_THREADS = ("OMP_NUM_THREADS", "GOTO_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                     "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


def snakemake_job_env(threads: int = 1) -> dict[str, str]:
    """This process's environment as Snakemake's shell gives it to a job of `threads`."""
    return {**os.environ, **dict.fromkeys(SNAKEMAKE_THREADS, str(threads))}


def start(path: Path, *, idle: float | None = None, owner: int | None = None,
          log: Path | None = None, wait: bool = False,
          env: Mapping[str, str] | None = None, deadline: float | None = None
          ) -> subprocess.Popen:
    """Start a worker at path (a process of its own; a daemon when owner is None), its
    output appended to log, in env (default: this process's environment): the worker
    serves only clients whose environment equals env (but :data:`NEUTRAL_ENV`) and whose
    limits equal this process's. deadline: seconds a connection has to send its request
    (default :data:`REQUEST_DEADLINE`)."""
    _mark_starting(path, os.getpid())
    args = [sys.executable, "-m", "creatio.cli", "worker", "serve", str(path)]
    if idle is not None:
        args += ["--idle", str(idle)]
    if deadline is not None:
        args += ["--deadline", str(deadline)]
    if owner is not None:
        args += ["--owner", str(owner)]
    out = (os.open(log, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600) if log is not None
           else subprocess.DEVNULL)
    try:
        proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=out, stderr=out,
                                start_new_session=owner is None,
                                env={k: v for k, v in (env or os.environ).items() if k != ENV})
    finally:
        if log is not None:
            os.close(out)
    _mark_starting(path, proc.pid)
    if wait:
        sock = _connect(path, START_WAIT)
        if sock is None:
            stop(proc)
            raise RuntimeError(f"the worker at {path} did not start (see {log})")
        sock.close()
    return proc


def ensure(path: Path, env: Mapping[str, str], idle: float, log: Path
           ) -> subprocess.Popen | None:
    """Make sure a worker of the current code serves at path (the shared worker of
    Snakemake's jobs): None when one already does, else the daemon started now (it warms up
    while the caller goes on; clients wait for it). A lock beside the socket makes two
    invocations that start at once share one worker."""
    import fcntl

    lock = os.open(path.with_name(path.name + ".lock"), os.O_CREAT | os.O_RDWR, 0o600)
    try:
        fcntl.flock(lock, fcntl.LOCK_EX)
        coming = _starting(path)  # before asking: a worker listens, then removes the file
        state = control(path, "status")
        if state is not None and not state.get("stopping"):
            if state.get("version") == package_version():
                return None
            control(path, "stop")  # older code: it finishes its jobs, a new one serves
        elif state is None and coming:
            return None  # a worker that another invocation started is warming up
        return start(path, idle=idle, log=log, env=env)
    finally:
        os.close(lock)


def _starting(path: Path) -> bool:
    """Whether the ``.starting`` file beside path names a live process."""
    try:
        os.kill(int(path.with_name(path.name + ".starting").read_text()), 0)
    except (OSError, ValueError):
        return False
    return True


def control(path: Path, what: str, timeout: float = 10.0) -> dict[str, Any] | None:
    """Ask the worker at path for its status, or to stop (None: no worker answers within
    timeout s)."""
    sock = _connect(path, 0.0)
    if sock is None:
        return None
    with sock:
        sock.settimeout(timeout)
        try:
            _send(sock, {"control": what})
            reply, _ = _recv(sock)
        except (OSError, ValueError):
            return None
    return reply if isinstance(reply, dict) else None


def stop(proc: subprocess.Popen | None, timeout: float = 10.0) -> None:
    """Stop a worker this process started (it finishes the jobs it runs)."""
    if proc is None or proc.poll() is not None:
        return
    proc.terminate()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def main(argv: Sequence[str], entry: Callable[[list[str]], int] | None = None,
         warm: Sequence[str] = ()) -> int:
    """`creatio worker start|stop|status`, and the worker process itself (`serve`), which
    runs each request's arguments through entry (creatio.cli.main), having imported warm
    (the modules of layers above this one that entry's jobs use)."""
    from creatio.errors import Parser

    ap = Parser(prog="creatio worker",
                description="Start, stop or list the warm workers of this checkout: processes "
                            "that have imported the libraries and loaded the compiled loops, "
                            "so that a job costs its computation.")
    sub = ap.add_subparsers(dest="what", required=True, metavar="{start,stop,status}")
    s = sub.add_parser("start", help="start this checkout's daemon (creatio run uses it)")
    s.add_argument("--idle", type=float, default=1800.0,
                   help="seconds without a job before it stops (default 1800)")
    sub.add_parser("stop", help="stop this checkout's workers (the daemon, Snakemake's)")
    sub.add_parser("status", help="which of this checkout's workers run, and their jobs")
    v = sub.add_parser("serve")  # the worker process itself: no help, so not listed
    v.add_argument("socket", type=Path)
    v.add_argument("--idle", type=float, default=None)
    v.add_argument("--owner", type=int, default=None)
    v.add_argument("--deadline", type=float, default=REQUEST_DEADLINE)
    args = ap.parse_args(argv)
    if args.what == "serve":
        if entry is None:
            raise ValueError("a worker needs the command it runs (creatio worker serve)")
        Server(args.socket, entry, args.idle, args.owner, args.deadline, warm).serve()
        return 0
    path = daemon_socket()
    state = control(path, "status")
    if args.what == "start":
        if state is not None:
            print(f"creatio worker: already running (pid {state['pid']}) at {path}")
            return 0
        log = path.with_suffix(".log")
        proc = start(path, idle=args.idle, log=log, wait=True)
        print(f"creatio worker: pid {proc.pid} at {path}: `creatio run` of this checkout runs "
              f"in it; it stops after {args.idle:g} s idle "
              "(creatio worker stop); log: " + str(log))
        return 0
    shared = _shared_workers()
    if state is None and not shared:
        print("creatio worker: none running for this checkout")
        return 0 if args.what == "stop" else 1
    if args.what == "stop":
        for where, st in ([(path, state)] if state is not None else []) + shared:
            control(where, "stop")
            print(f"creatio worker: pid {st['pid']} stops")
        return 0
    if state is not None:
        print(f"creatio worker: pid {state['pid']} at {path}: {state['jobs']} job(s) running, "
              f"{state['served']} served")
    for where, st in shared:
        print(f"creatio worker: pid {st['pid']} at {where} (Snakemake's jobs): {st['jobs']} "
              f"job(s) running, {st['served']} served")
    return 0


def _shared_workers() -> list[tuple[Path, dict[str, Any]]]:
    """The shared workers of Snakemake's jobs of this checkout that answer (any environment)."""
    found = []
    for path in sorted(_private_dir().glob("j-*.sock")):
        state = control(path, "status")
        if state is not None and state.get("package") == str(_PACKAGE):
            found.append((path, state))
    return found
