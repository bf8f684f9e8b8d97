"""Run a resolved config: its datasets with provenance, and its report. One path for all.

Every study, of every kind, is run the same way: the registry names its dataset parts and
its run function (config -> Dataset); provenance is attached here, once; the dataset is
written atomically; the registry's report writer derives the report from the datasets.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from creatio.pipeline.config import Resolved, output_root

__all__ = ["FIGURES", "compute_dataset", "compute_parts", "draw_after", "figures_after",
           "run_resolved", "run_study", "write_report"]

log = logging.getLogger("creatio")


def run_study(resolved: Resolved, part: str | None = None, **args: Any) -> Any:
    """Compute one dataset of a study with provenance attached: the part named `part`, or
    the one whose arguments are `args` (``dt=0.001``), or else the study's first part."""
    from creatio.pipeline.provenance import provenance

    entry = resolved.entry
    parts = entry.parts(resolved.obj)
    if part is not None:
        p = entry.part(resolved.obj, part)
    elif args:
        matches = [q for q in parts if dict(q.args) == args]
        if not matches:
            raise KeyError(f"{resolved.id} has no dataset with {args}")
        p = matches[0]
    else:
        p = parts[0]
    ds = entry.run_function()(resolved.obj, **p.args)
    title = getattr(resolved.obj.study, "title", "") or resolved.id
    ds.attrs = {**provenance(resolved.id, resolved.yaml, resolved.sha256, title), **ds.attrs}
    if entry.kind.name == "sphere":  # absurd own checks: status checks_failed, with why
        from creatio.pipeline.checks import mark

        mark(ds)
    return ds


def compute_dataset(resolved: Resolved, out: Path, part: str | None = None) -> Path:
    """Run one dataset of a study and write it atomically to out."""
    from creatio.store.netcdf import write_dataset

    t0 = time.perf_counter()
    ds = run_study(resolved, part)
    write_dataset(ds, out)
    status = ds.attrs.get("status")
    log.info("%s%s: wrote %s in %.2f s%s", resolved.id, f" [{part}]" if part else "", out,
             time.perf_counter() - t0, f" (status {status})" if status else "")
    return out


def write_report(study: str, outdir: Path, datasets: Sequence[Path],
                 later: list[Callable[[], None]] | None = None) -> dict[str, Path]:
    """Derive a study's report files from its datasets (the registry's report writer). A
    sphere study whose own checks are absurd (creatio.pipeline.checks) gets no report:
    ChecksFailed, one line naming each check. later: a list that receives the figures a
    writer leaves for later (creatio.reports.common.figures_later) instead of drawing them;
    None draws everything now."""
    from creatio.studies import registry

    entry = registry.get(study)
    if entry.kind.name == "sphere":
        from creatio.pipeline.checks import ChecksFailed, run_problems
        from creatio.store.netcdf import read_dataset

        runs = [read_dataset(Path(p))[0] for p in datasets]
        try:
            problems = run_problems(runs)
        finally:
            for ds in runs:
                ds.close()
        if problems:
            raise ChecksFailed(f"{study}: the run's own checks are absurd, no report written: "
                               f"{'; '.join(problems)} (bounds: creatio.pipeline.checks)")
    from creatio.reports.common import figures_later
    from creatio.reports.registry import writer

    queued = len(later) if later is not None else 0
    with figures_later(later):
        paths = writer(study)([Path(p) for p in datasets], outdir)
    follow = " (its figures follow)" if later is not None and len(later) > queued else ""
    log.info("%s: report %s%s", study, ", ".join(str(p) for p in paths.values()), follow)
    return paths


#: The variable that says when `creatio run` draws its report's figures: ``after`` (the
#: default: the result is said first, the figures are drawn in a process of their own) or
#: ``now`` (before the command returns: for a script that reads them right after).
FIGURES = "CREATIO_FIGURES"


def figures_after() -> bool:
    """Whether `creatio run` draws its figures after it has said its result: not when
    :data:`FIGURES` is ``now``, nor in a batch job (whose end would stop the drawing), nor
    where this platform cannot fork."""
    from creatio.pipeline.worker import BATCH_JOB

    return (os.environ.get(FIGURES, "after") != "now" and hasattr(os, "fork")
            and not any(k in os.environ for k in BATCH_JOB))


def draw_after(tasks: Sequence[Callable[[], None]], data_dir: Path, log_path: Path) -> None:
    """Draw queued figures (each saved atomically) in a process of its own, in a session of
    its own with no terminal, that outlives this one: the command exits, and its caller has
    its status, while they are drawn; then that process refreshes the index, which lists a
    figure once it is there. Its output goes to log_path, removed when all went well (kept,
    naming the failure, when not). Where forking is unsafe (other threads) they are drawn
    here, now."""
    if not tasks:
        return
    if not hasattr(os, "fork") or threading.active_count() > 1:
        for task in tasks:
            task()
        return
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    if os.fork():
        return
    code = 1
    try:
        os.setsid()
        log_path.parent.mkdir(parents=True, exist_ok=True)
        null = os.open(os.devnull, os.O_RDONLY)
        out = os.open(log_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(null, 0)
        os.dup2(out, 1)
        os.dup2(out, 2)
        os.closerange(3, 1 << 16)  # nothing of the caller's pipes, sockets or worker kept
        from creatio.pipeline.index import refresh_index
        from creatio.store.forked import run_all

        run_all(list(tasks))
        refresh_index(data_dir)
        log_path.unlink(missing_ok=True)
        code = 0
    except BaseException:  # noqa: BLE001 - said in the log, which stays
        import traceback

        with contextlib.suppress(OSError):  # to the log itself, whatever sys.stderr wraps
            os.write(2, traceback.format_exc().encode(errors="backslashreplace"))
    finally:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        os._exit(code)


#: The kinds whose parts may compute at once: not the analyses, whose datasets are timings
#: (each measured alone, as their rules run them), nor EN-05's uncertainty study.
PARALLEL_KINDS = ("sphere", "kinematic", "material")


def compute_parts(resolved: Resolved, directory: Path, names: Sequence[str]) -> list[Path]:
    """Every named part of a study written to directory/<name>.nc. A sphere or kinematic
    study's parts are dealt in turn to one process per free core (creatio.store.forked:
    this one and forked children, which inherit its imports and compiled loops): EN-02's two
    timesteps then take the time of the longer one. The datasets are those each part gives
    alone, whatever the split."""
    from creatio.store.forked import cores, run_all

    outs = [directory / f"{name}.nc" for name in names]
    pairs = list(zip(names, outs, strict=True))
    alone = resolved.entry.kind.name not in PARALLEL_KINDS
    n = 1 if alone else max(1, min(cores(), len(pairs)))
    groups = [pairs[k::n] for k in range(n)]

    def task(group: list[tuple[str, Path]]) -> None:
        for name, out in group:
            compute_dataset(resolved, out, name)

    run_all([lambda g=g: task(g) for g in groups])
    return outs


def run_resolved(resolved: Resolved, data_dir: Path = Path("data"),
                 figures: str = "now") -> Path:
    """Everything `snakemake all` does for one study, in this process; a run folder gets its
    overrides.json (the keys its config changes) and the index lists it. figures ``after``:
    the report's figures are drawn after this returns, in a process of its own
    (:func:`draw_after`; its log ``.figures.log`` in the report's folder while it draws)."""
    from creatio.pipeline.config import resolve
    from creatio.pipeline.index import record_run, refresh_index

    root = output_root(resolved, data_dir)
    if root != data_dir:
        log.info("%s: overridden config %s -> %s", resolved.id, resolved.key, root)
        record_run(root, "study", resolved.id, resolved.data, resolve(resolved.id).data,
                   None, resolved.sha256, data_dir)
    entry = resolved.entry
    outs = compute_parts(resolved, Path(entry.dataset_dir(str(root))),
                         [p.name for p in entry.parts(resolved.obj)])
    if entry.sampled:  # datasets the workflow makes in batch jobs, here in this process
        from creatio.pipeline.points import run_study_sample

        outs += run_study_sample(resolved, root)
    later: list[Callable[[], None]] | None = [] if figures == "after" else None
    report_dir = root / entry.kind.report_dir
    write_report(resolved.id, report_dir, outs, later)
    page = refresh_index(data_dir)
    if page is not None:
        log.info("results: %s (creatio ls lists them)", page)
    if later:
        draw_after(later, data_dir, report_dir / f".{resolved.id}.figures.log")
    return root
