"""One Snakemake invocation's plan: what the Snakefile and the rules of workflows/ read.

The Snakefile stays thin (config, validation, includes, target rules); the planners live
here: the studies of `all` and `beyond`, the analyses, the sweeps, EN-05, and the order in
which a job re-invoked on its own (a ``run:`` job, a cluster job), which parses the workflow
anew without its targets, looks for the configuration that writes its output. The command
the rules run (``CREATIO``), the shared warm worker its local jobs use and the priority
that lets the one job that compiles the loop start first are here too.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from pathlib import Path
from typing import Any

from creatio.pipeline.planning import (
    JobConfigs,
    StudyRuns,
    SweepRegistry,
    analysis_ids,
    beyond_studies,
    beyond_targets,
    wildcard_pattern,
)

__all__ = ["Invocation", "job_command", "preload"]

#: Command-line flags of a Snakemake invocation that runs no job.
NO_RUN_FLAGS = frozenset(("-n", "--dry-run", "--dryrun", "--lint", "--summary",
                          "--detailed-summary", "--dag", "--rulegraph", "--filegraph",
                          "--d3dag", "--list-rules", "-l", "--version", "-h", "--help",
                          "--unlock", "--cleanup-metadata", "--delete-all-output",
                          "--delete-temp-output", "--touch", "-t", "--containerize"))
#: The worked sweep of conf/sweeps/, planned for a job re-invoked alone.
WORKED_SWEEP = "en02_mu"


def job_command(executable: str | Path | None = None, cwd: Path | None = None) -> str:
    """The command a rule runs creatio with: this interpreter, relative to the working
    directory when it lives there (.venv/bin/python), so that the report's job parameters
    show no clone's absolute path."""
    py = Path(executable or sys.executable)
    cwd = cwd or Path.cwd()
    py = py.relative_to(cwd) if py.is_relative_to(cwd) else py
    return f'"{py}" -m creatio.cli'


class Invocation:
    """Every planner of one invocation, planned on first use (a sweep never plans `all`)."""

    def __init__(self, config: dict[str, Any], basedir: str | Path) -> None:
        from creatio.pipeline.points import En05Runs

        self.config = config
        self.command = job_command()
        self.study_ids = wildcard_pattern(folder="studies")
        self.analysis_ids = wildcard_pattern(folder="benchmarks")
        self.jobs = JobConfigs()
        self.runs = StudyRuns(self.jobs, config.get("overrides"), config.get("studies"))
        self.analyses = StudyRuns(self.jobs, None, analysis_ids())
        self.sweeps = SweepRegistry(self.jobs, basedir)
        # --config studies=[...] selects among beyond's studies too
        self.beyond = StudyRuns(self.jobs, config.get("overrides"),
                                beyond_studies(config.get("studies")))
        self.en05 = En05Runs(self.jobs, config.get("overrides"))
        # A job re-invoked alone asks these in turn: EN-05 first (the planners after it
        # refuse overrides only EN-05 has), beyond last (what no other planner knows).
        self.jobs.fallbacks += [self.en05.fallback, lambda: self.runs.plans,
                                lambda: self.analyses.plans, self._ad_hoc_sweep,
                                self._worked_sweep, lambda: self.beyond.plans]
        self.sweeps.fallbacks += [self._ad_hoc_sweep, self._worked_sweep]
        self._compiler: tuple[str, str, str | None] | None = None  # see dataset_priority
        self._worker: Any = None  # the shared worker's process, when this invocation started it
        self._path: Path | None = None  # the socket of the worker its jobs use
        #: Held by the run: blocks of the rules, which run in threads of Snakemake's process
        #: (profiles/default): Hydra's composition is not thread-safe.
        self.lock = threading.Lock()

    # ------------------------------------------------------------------ targets
    def sweep_targets(self) -> list[str]:
        """The aggregate of `snakemake sweep --config study=ID 'sweep=[...]'`."""
        c = self.config
        return self.sweeps.outputs(c.get("study", ""), c.get("sweep", []), c.get("overrides", []),
                                   c.get("sweep_batch"), c.get("sweep_max_points"))

    def beyond_targets(self) -> list[str]:
        """The files of `snakemake beyond`."""
        return beyond_targets(self.beyond, self.config.get("studies"))

    def _ad_hoc_sweep(self) -> list[str] | None:
        return self.sweep_targets() if self.config.get("sweep") else None

    def _worked_sweep(self) -> list[str]:
        return self.sweeps.worked(WORKED_SWEEP)

    # ------------------------------------------------------------------ scheduling
    def dataset_priority(self, study: str, root: str, name: str | None = None) -> int:
        """The Snakemake priority of a study's config job (name None) or dataset job. One
        sphere dataset job, the first asked about, and its config job get 2: on a cold
        numba cache it compiles the loop every sphere job of the run waits for (one
        compilation: creatio.pipeline.worker's compile lock), so it starts first; the
        kinematic studies' jobs (no compiled loop) get 1, so that the other core runs them
        meanwhile instead of a second sphere job that would only wait for the first one's
        compilation; the rest 0. (Priorities are per job: a config job needs its own.)"""
        from creatio.studies import registry

        entry = registry.STUDIES.get(study)
        if entry is None or entry.kind.name != "sphere":
            return 1 if entry is not None and entry.kind.name == "kinematic" else 0
        if self._compiler is None:
            self._compiler = (root, study, name)
        first_root, first_study, first_name = self._compiler
        if (root, study) != (first_root, first_study):
            return 0
        if name is not None and first_name is None:
            self._compiler = (root, study, name)
            first_name = name
        return 2 if name is None or name == first_name else 0

    # ------------------------------------------------------------------ warm worker
    def prestart_worker(self, workflow: Any) -> None:
        """Find or start the worker while Snakemake builds the DAG (a new one's imports then
        overlap the planning instead of delaying the first job) when the command line asks
        for a run: not a dry run, lint, report or listing. start_worker, at onstart, keeps
        it or stops one started for nothing once Snakemake knows where the jobs run."""
        if workflow.exec_mode.name != "DEFAULT" or set(sys.argv[1:]) & NO_RUN_FLAGS:
            return
        if any(a.startswith(("--report", "--list", "--lint", "--executor")) or a == "-e"
               for a in sys.argv[1:]):
            return
        self._start()

    def start_worker(self, workflow: Any) -> None:
        """Run this invocation's jobs in the shared warm worker (creatio.pipeline.worker)
        when they run on this machine: the one of this checkout and of the environment
        Snakemake gives a one-thread job, started now if none serves (it outlives the
        invocation until it has been idle for ``CREATIO_WORKER_IDLE`` s, default 900, so
        that the next invocation's jobs start warm). Jobs on a cluster,
        ``CREATIO_WORKER=off``, or a system without fork and descriptor passing keep a
        process each."""
        if not workflow.local_exec or workflow.dryrun or workflow.exec_mode.name != "DEFAULT":
            self.stop_worker()
        elif self._path is None:
            self._start()
        if not workflow.dryrun and workflow.exec_mode.name == "DEFAULT":
            preload()

    def _start(self) -> None:
        from creatio.pipeline import worker

        if os.environ.get(worker.ENV) == "off" or not _can_fork():
            return
        env = worker.snakemake_job_env(threads=1)
        try:
            idle = float(os.environ.get("CREATIO_WORKER_IDLE", worker.SHARED_IDLE))
        except ValueError:
            idle = worker.SHARED_IDLE
        try:
            path = worker.shared_socket(env)
            self._worker = worker.ensure(path, env, idle, path.with_suffix(".log"))
        except OSError as e:  # no private directory, no socket: a process per job
            print(f"creatio: no warm worker ({e}): a process per job", file=sys.stderr)
            return
        self._path = path
        os.environ[worker.ENV] = str(path)

    def stop_worker(self) -> None:
        """No worker for this invocation's jobs: one it started for them is stopped (one
        that another invocation started, or that this one found, keeps serving)."""
        from creatio.pipeline import worker

        if self._worker is not None and self._path is not None:
            worker.control(self._path, "stop")
            worker.stop(self._worker)
        self._worker = self._path = None
        os.environ.pop(worker.ENV, None)

    def release_worker(self) -> None:
        """At the end of the invocation: its jobs are done; the shared worker keeps serving
        the next invocations until it has been idle long enough. Snakemake's scheduler
        leaves a timer (threading.Timer, its job rate limiter's re-evaluation, 1 s by
        default) that the interpreter waits for before it exits: with every job done it
        has nothing left to wake, so it is cancelled (up to 1 s of every invocation)."""
        from creatio.pipeline import worker

        self._worker = self._path = None
        os.environ.pop(worker.ENV, None)
        for thread in threading.enumerate():
            if isinstance(thread, threading.Timer):
                thread.cancel()


#: Modules Snakemake's process imports only once jobs run: pandas when the first job finishes
#: (its persistence hashes job parameters with it wherever it is installed). Not netCDF4:
#: importing it sets HDF5_PLUGIN_PATH, which every later job would inherit, and a worker
#: refuses a job whose variables read at import differ from its own.
PRELOAD = ("pandas",)


def preload() -> threading.Thread:
    """Import :data:`PRELOAD` in a background thread while the first jobs run, instead of
    in the scheduler's thread when the first job finishes, where the import (0.1-0.25 s)
    delays every job after it."""

    def load() -> None:
        import importlib

        for name in PRELOAD:
            with contextlib.suppress(ImportError):
                importlib.import_module(name)

    thread = threading.Thread(target=load, name="creatio-preload", daemon=True)
    thread.start()
    return thread


def _can_fork() -> bool:
    import socket

    return hasattr(os, "fork") and hasattr(socket, "send_fds") and hasattr(socket, "AF_UNIX")
