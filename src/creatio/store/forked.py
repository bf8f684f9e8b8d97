"""Independent output files written at once, each in a process forked from this one.

A report draws three figures and a scene's animation a hundred frames, each independent of
the others and a few tenths of a second of matplotlib each: on a machine with a free core
the work is split among forked children (they inherit every import, font cache and array,
so a child costs its drawing only). What a child writes is what this process would have
written: the same code on the same data. Where forking is unsafe or useless (no fork, one
core, other threads running, such as Snakemake's ``run:`` threads) everything runs here, in
order. A task whose child fails is run again here, so that its error is raised as it would
have been without children.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable, Sequence

__all__ = ["cores", "run_all"]

#: prctl's option that sends a signal to a process when its parent dies (Linux).
PR_SET_PDEATHSIG = 1


def die_with_parent(parent: int) -> None:
    """Have the Linux kernel kill this forked child when its parent dies (a parent killed at
    its caller's `ulimit -t` takes its children along instead of leaving them to finish and
    write); elsewhere nothing happens."""
    import signal

    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(1)


def cores() -> int:
    """How many processors this process may run on (1 where forking is unsafe or absent)."""
    if not hasattr(os, "fork") or threading.active_count() > 1 or os.environ.get(
            "CREATIO_FORK") == "off":
        return 1
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def run_all(tasks: Sequence[Callable[[], None]]) -> None:
    """Run every task (each writes its own files): the first here, the others at the same
    time in forked children when cores() > 1 (the caller makes a few tasks, about one per
    core); return when all are done. A task that fails in its child runs again here,
    raising its own error."""
    if cores() < 2 or len(tasks) < 2:
        for task in tasks:
            task()
        return
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    children: list[int] = []
    parent = os.getpid()
    try:
        for task in tasks[1:]:
            pid = os.fork()
            if pid == 0:  # the child: its task, then out without the parent's exit handlers
                code = 1
                try:
                    die_with_parent(parent)
                    task()
                    code = 0
                except BaseException:  # noqa: BLE001, S110 - the parent runs it again, raising
                    pass
                finally:
                    for stream in (sys.stdout, sys.stderr):
                        try:
                            if stream is not None:
                                stream.flush()
                        except Exception:  # noqa: BLE001, S110 - nothing left to say it with
                            pass
                    os._exit(code)
            children.append(pid)
        tasks[0]()
        failed = []
        for k, pid in enumerate(children, start=1):
            _, status = os.waitpid(pid, 0)
            if os.waitstatus_to_exitcode(status) != 0:
                failed.append(k)
    except BaseException:
        _end(children)
        raise
    for k in failed:
        tasks[k]()


def _end(children: Sequence[int]) -> None:
    """Stop and collect the children after this process's own task failed."""
    import signal

    for pid in children:
        try:
            os.kill(pid, signal.SIGTERM)
        except OSError:
            pass
    for pid in children:
        try:
            os.waitpid(pid, 0)
        except ChildProcessError:
            pass
