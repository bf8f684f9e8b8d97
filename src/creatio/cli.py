"""`creatio` command line: dispatch only (Hydra apps for users, plain tasks for Snakemake).

    creatio run [study=ID | analysis=ID] [KEY=VALUE ...]   run one study (a Hydra app)
    creatio probe [alpha=DEG R=R t=T KEY=VALUE]          surface quantities at one point
    creatio calibrate study=ID track=CSV fit=[KEYS]      fit a study to a measured track
    creatio release VERSION | verify | list             freeze the default outputs
    creatio diff A B                                     compare datasets, dirs or releases
    creatio ls | open NAME                               what is built, and where
    creatio worker start | stop | status                 a warm process the jobs fork from
    creatio task dataset|report|sweep|compare            one workflow step (the Snakefile's)
    creatio task scene library|dataset|page|media        one step of a scene (scenes.smk)
    creatio --version
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from creatio.errors import ConfigError, Parser

log = logging.getLogger("creatio")

USAGE = """usage: creatio COMMAND [ARGS]

commands:
  run     run one study or analysis and write its datasets and report (Hydra app)
            creatio run study=en02 sphere.mu=0.3      creatio run --help
            creatio run -m study=en02 sphere.mu=0,0.15,0.3   (a sweep, then its aggregate)
            creatio run analysis=stability_map           (analyses: {analyses})
  probe   position, velocity, normal and J at one surface point (Hydra app)
            creatio probe alpha=30 R=0.5 t=1.0 phases.gamma.phi0=45 phases.gamma.unit=deg
  calibrate  fit a study's parameters to a measured track (least squares on the centre)
            creatio calibrate study=en02 track=track.csv 'fit=[sphere.mu,sphere.eps]' phases.T=10
  release make, verify or list versioned releases of the default outputs
            creatio release 0.2.0    creatio release verify latest    creatio release list
  diff    compare datasets, data directories or releases (exit 0 same, 1 differs, 2 error)
            creatio diff latest data    creatio diff 0.1.0 0.2.0 --json    creatio diff --help
  ls      every built study, run, sweep, scene and benchmark: overrides, status, file to open
            creatio ls    creatio ls --json    (the same list: data/index.html)
  open    the file to open of one result (its path; --browser opens it)
            creatio open en02    creatio open sweeps/en02-c781    creatio open scenes/compare
  worker  a warm process that runs `creatio run` and the workflow's jobs without a fresh
          interpreter each (start, stop, status; CREATIO_WORKER=off: none)
            creatio worker start    creatio worker status    creatio worker stop
  task    one workflow step, as the Snakefile calls it
            creatio task dataset ct02 OUT.nc [--part NAME] [--override K=V ...]
            creatio task sweep-batch --study en02 --sweep sphere.mu=0,0.1 --batch 0
            creatio task report ct02 OUTDIR DATASET.nc [DATASET.nc ...]
            creatio task compare OUTDIR EN02.nc EN02R.nc
            creatio task scene dataset en02 OUT.nc [--override K=V ...] [--reuse en02=NC]
            creatio task en05 pilot|batch|sobol|track --config-file CONFIG.yaml   (EN-05's steps)

Studies: {studies} (snakemake all); {beyond} (snakemake beyond); en05 (snakemake en05).
Configs live in {conf}.
"""


# ------------------------------------------------------------------------------ hydra apps
# The groups a user picks options from (conf/<group>/<option>.yaml), per command; schema,
# scene and sweeps are the pipeline's own and stay out of --help.
USER_GROUPS = {
    "creatio run": ("study", "analysis", "solver", "geometry", "phases", "sphere", "structure"),
    "creatio probe": ("geometry", "phases"),
}


def _groups_help(app: str) -> str:
    """The user-selectable config groups of a command and their options, for --help."""
    from creatio.pipeline.config import CONF_DIR

    lines = []
    for group in USER_GROUPS.get(app, USER_GROUPS["creatio run"]):
        options = sorted(p.stem for p in (CONF_DIR / group).glob("*.yaml"))
        if options:
            lines.append(f"{group}: {', '.join(options)}")
    return "\n".join(lines)


def _hydra_app(config_name: str, task, study: str | None = None) -> None:
    import hydra
    from omegaconf import OmegaConf

    from creatio.pipeline.config import CONF_DIR, register_schemas

    register_schemas(*([study] if study else []))
    if not OmegaConf.has_resolver("creatio_groups"):
        OmegaConf.register_new_resolver("creatio_groups", _groups_help)
    hydra.main(config_path=str(CONF_DIR), config_name=config_name, version_base="1.3")(task)()


def _run_task(cfg) -> None:
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    from creatio.pipeline.config import validate
    from creatio.pipeline.run import run_resolved

    try:
        resolved = validate(cfg)
    except ConfigError as e:
        if HydraConfig.get().mode == RunMode.MULTIRUN:  # one refused point: record, go on
            log.warning("creatio run: point refused: %s", e)
            return
        print(f"creatio run: {e}", file=sys.stderr)
        sys.exit(2)
    try:
        run_resolved(resolved)
    except Exception as e:  # Hydra would print its own traceback: one line instead
        if os.environ.get("CREATIO_DEBUG"):
            raise
        message, code = describe(e)
        if HydraConfig.get().mode == RunMode.MULTIRUN and code != 130:  # record, go on
            log.warning("creatio run: point failed: %s", message)
            return
        print(f"creatio run: {message}", file=sys.stderr)
        sys.exit(code)


#: Hydra's job logging of `creatio run` (conf/config.yaml: hydra/job_logging: stdout).
HYDRA_STDOUT_LOGGING = {
    "version": 1,
    "formatters": {"simple": {"format": "%(message)s"}},
    "handlers": {"console": {"class": "logging.StreamHandler", "formatter": "simple",
                             "stream": "ext://sys.stdout"}},
    "root": {"level": "INFO", "handlers": ["console"]},
    "disable_existing_loggers": False,
}


def _run_plain(args: Sequence[str]) -> int:
    """`creatio run` without Hydra's own options (--help, --cfg, -m, hydra.*): the config
    _prevalidate has just composed and validated (memoised), run as the Hydra app runs it,
    with the same logging, without Hydra composing it twice more (0.3-0.5 s)."""
    import logging.config

    from creatio.pipeline.config import resolve
    from creatio.pipeline.run import figures_after, run_resolved

    logging.config.dictConfig(HYDRA_STDOUT_LOGGING)
    study, rest = _selected(args)
    try:  # the result is said, then the figures are drawn (CREATIO_FIGURES=now: before)
        run_resolved(resolve(study, rest), figures="after" if figures_after() else "now")
    except (Exception, KeyboardInterrupt) as e:  # the Hydra app's one line (_run_task)
        if os.environ.get("CREATIO_DEBUG"):  # Ctrl-C too, in Python or in a compiled loop
            raise
        message, code = describe(e)
        print(f"creatio run: {message}", file=sys.stderr)
        return code
    from creatio.pipeline.worker import autostart

    autostart(["run", *args])  # no worker served this run: one warms up for the next
    return 0


def _multirun(args: Sequence[str]) -> int:
    """`creatio run -m`: the sweep's batches in this process (progress on stderr, points
    computed before reused), then the aggregate `snakemake sweep` writes."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    from creatio.pipeline.sweep import grammar_error, plan_sweep, write_sweep

    items = [a for a in args if not a.startswith("-") and not a.startswith("hydra")]
    parser = OverridesParser.create()
    try:
        parsed = parser.parse_overrides(items)
    except Exception as e:  # noqa: BLE001 - Hydra's grammar errors, re-worded
        for item in items:  # the override it refuses, and what is wrong with it
            try:
                parser.parse_overrides([item])
            except Exception as one:  # noqa: BLE001 - the culprit
                key, _, value = item.partition("=")
                print(f"creatio run: {ConfigError(key, value, grammar_error(item, one))}",
                      file=sys.stderr)
                return 2
        print(f"creatio run: invalid override: {str(e).splitlines()[0]}", file=sys.stderr)
        return 2
    study = next((o.get_value_element_as_str() for o in parsed
                  if o.get_key_element() in ("study", "analysis")), "ct02")
    sweep = [a for a, o in zip(items, parsed, strict=True) if o.is_sweep_override()]
    base = [a for a, o in zip(items, parsed, strict=True)
            if not o.is_sweep_override() and o.get_key_element() not in ("study", "analysis")]
    try:
        if not sweep:
            from creatio.pipeline.config import resolve
            from creatio.pipeline.run import run_resolved

            run_resolved(resolve(study, base))
            return 0
        plan = plan_sweep(study, sweep, base)
        paths = write_sweep(plan, compute_missing=True)
    except ConfigError as e:
        print(f"creatio run: {e}", file=sys.stderr)
        return 2
    log.info("sweep aggregate: %s", ", ".join(str(p) for p in paths.values()))
    return 0


def _probe_task(cfg) -> None:
    from creatio.pipeline.config import validate
    from creatio.reports.probe import probe_table
    from creatio.studies.schema import ProbeConfig

    try:
        p = validate(cfg, schema=ProbeConfig).obj
    except ConfigError as e:
        print(f"creatio probe: {e}", file=sys.stderr)
        sys.exit(2)
    print(probe_table(p))


def _selected(overrides: Sequence[str]) -> tuple[str, list[str]]:
    """(study id, the other overrides) from `study=ID` or `analysis=ID` (default ct02)."""
    study, rest = "ct02", []
    for a in overrides:
        key, _, value = a.partition("=")
        if key in ("study", "analysis"):
            study = value
        else:
            rest.append(a)
    return study, rest


def _prevalidate(args: Sequence[str], config_name: str) -> None:
    """Refuse bad overrides with creatio's own message before Hydra starts: interpolations
    always (Hydra's own options print or resolve the config: --cfg job --resolve printed
    ${oc.env:HOME} resolved), every other rule when Hydra's options are absent."""
    from creatio.pipeline.config import (
        compose,
        override_error,
        refuse_interpolations,
        resolve,
        validate,
    )
    from creatio.studies.schema import ProbeConfig

    try:
        refuse_interpolations([a for a in args if not a.startswith("-")])
    except ConfigError as e:
        print(f"creatio {'probe' if config_name == 'probe' else 'run'}: {e}", file=sys.stderr)
        sys.exit(2)
    if any(a.startswith("-") for a in args):  # --help, --cfg, -m: Hydra's business
        return
    overrides = [a for a in args if not a.startswith("hydra")]
    try:
        bare = [a for a in overrides if "=" not in a]
        if bare:
            from creatio.studies import registry

            entry = registry.STUDIES.get(bare[0])
            hint = (f"pick it with {entry.group}={bare[0]}" if entry is not None
                    else "an override is KEY=VALUE, e.g. sphere.mu=0.3")
            raise ConfigError(bare[0], "", hint)
        if config_name == "probe":
            refuse_interpolations(overrides)
            try:
                cfg = compose("", overrides, config_name="probe")
            except Exception as e:  # noqa: BLE001 - Hydra override refusal: name the key
                raise override_error("", overrides, e, config_name="probe") from None
            validate(cfg, schema=ProbeConfig)
        else:
            study, rest = _selected(overrides)
            resolve(study, rest)
    except ConfigError as e:
        print(f"creatio {'probe' if config_name == 'probe' else 'run'}: {e}", file=sys.stderr)
        sys.exit(2)


def _study_ids() -> list[str]:
    from creatio.studies import registry

    return list(registry.STUDIES)


def _primary(args: Sequence[str]) -> str:
    """The primary config of `creatio run`: the one of the selected study's group."""
    from creatio.pipeline.config import PRIMARY
    from creatio.studies import registry

    study, _ = _selected([a for a in args if not a.startswith("-")])
    entry = registry.STUDIES.get(study)
    return PRIMARY[entry.group] if entry is not None else "config"


# ------------------------------------------------------------------------------ tasks
def _task(argv: Sequence[str]) -> int:
    from creatio.studies import registry

    ap = Parser(prog="creatio task", description="One workflow step.")
    sub = ap.add_subparsers(dest="step", required=True)
    d = sub.add_parser("dataset", help="compute one study dataset")
    d.add_argument("study", choices=list(registry.STUDIES))
    d.add_argument("out", type=Path)
    d.add_argument("--part", default=None,
                   help="the dataset part (its file stem; default: the study's first)")
    d.add_argument("--override", action="append", default=[], metavar="KEY=VALUE")
    d.add_argument("--config-file", type=Path, default=None,
                   help="a resolved config (YAML file) to run instead of composing conf/")
    d.add_argument("--config-yaml", default=None,
                   help="the same, as YAML text (what the Snakefile passes)")
    r = sub.add_parser("report", help="derive a study's report from its datasets")
    r.add_argument("study", choices=list(registry.STUDIES))
    r.add_argument("outdir", type=Path)
    r.add_argument("datasets", type=Path, nargs="+")
    w = sub.add_parser("sweep", help="aggregate a sweep's batches")
    b = sub.add_parser("sweep-batch", help="compute one batch of a sweep's points")
    for parser in (w, b):
        parser.add_argument("--study", required=True, choices=list(registry.STUDIES))
        parser.add_argument("--sweep", action="append", required=True,
                            metavar="KEY=V1,V2,...")
        parser.add_argument("--override", action="append", default=[], metavar="KEY=VALUE")
        parser.add_argument("--batch-size", type=int, default=None,
                            help="points per batch (default: about 8 batches, at most 250)")
        parser.add_argument("--max-points", type=int, default=None,
                            help="the sweep's size limit (default 200000)")
    b.add_argument("--batch", type=int, required=True, help="the batch's number (from 0)")
    b.add_argument("--out", type=Path, default=None, help="the batch file (default: its path)")
    c = sub.add_parser("compare", help="EN-02 vs EN-02R comparison from both datasets")
    c.add_argument("outdir", type=Path)
    c.add_argument("datasets", type=Path, nargs=2)
    args = ap.parse_args(argv)
    try:
        if args.step == "dataset":
            from creatio.pipeline.run import compute_dataset

            resolved = _task_config(args)
            if args.part is not None:
                try:
                    resolved.entry.part(resolved.obj, args.part)
                except KeyError as e:
                    raise ConfigError("--part", args.part, str(e.args[0])) from None
            compute_dataset(resolved, args.out, args.part)
        elif args.step in ("sweep", "sweep-batch"):
            from creatio.pipeline.sweep import MAX_POINTS, plan_sweep, run_batch, write_sweep

            plan = plan_sweep(args.study, args.sweep, args.override,
                              batch_size=args.batch_size,
                              max_points=args.max_points or MAX_POINTS, check_first=False)
            if args.step == "sweep":
                paths = write_sweep(plan)
                log.info("sweep: %s", ", ".join(str(p) for p in paths.values()))
            else:
                if not 0 <= args.batch < plan.n_batches:
                    raise ConfigError("--batch", args.batch,
                                      f"must lie in [0, {plan.n_batches - 1}]")
                run_batch(plan, args.batch, args.out)
        elif args.step == "report":
            from creatio.pipeline.run import write_report

            write_report(args.study, args.outdir, args.datasets)
        else:
            from creatio.reports.sphere import write_comparison

            paths = write_comparison(args.datasets, args.outdir)
            log.info("comparison: %s", ", ".join(str(p) for p in paths.values()))
    except ConfigError as e:
        print(f"creatio task: {e}", file=sys.stderr)
        return 2
    return 0


def _task_config(args: argparse.Namespace):
    """The resolved config of a task: a config file, or conf/ with overrides."""
    from creatio.pipeline.config import resolve, validate
    from creatio.store.regular import read_text

    text = read_text(args.config_file) if args.config_file else args.config_yaml
    if text is None:
        return resolve(args.study, args.override)
    import yaml

    if args.override:
        raise ConfigError("--override", args.override, "cannot be combined with a config")
    resolved = validate(yaml.safe_load(text))
    if resolved.id != args.study:
        raise ConfigError("--config-file", str(args.config_file or "--config-yaml"),
                          f"holds study {resolved.id}, not {args.study}")
    return resolved


def _usage() -> str:
    from creatio.pipeline.config import CONF_DIR
    from creatio.studies import registry

    beyond = [s.id for s in registry.beyond()]
    return USAGE.format(studies=", ".join(s.id for s in registry.select(in_all=True)),
                        beyond=", ".join(beyond),
                        analyses=", ".join(s.id for s in registry.select(kind="analysis"))
                        or "none", conf=CONF_DIR)


def _completion(argv: list[str]) -> int:
    """Shell completion through Hydra's plugins: `creatio -sc install=bash` prints the hook;
    a query completes the command word, then the run or probe app's groups and keys."""
    import os

    line = os.environ.get("COMP_LINE", "")
    words = line.split()
    commands = ("run", "probe", "release", "diff", "task", "ls", "open", "worker")
    if any(a.startswith("query") for a in argv[1:]):
        command = words[1] if len(words) > 1 else ""
        if command not in ("run", "probe") or (len(words) == 2 and not line.endswith(" ")):
            print(" ".join(c for c in commands if c.startswith(command)))
            return 0
        os.environ["COMP_LINE"] = " ".join([words[0], *words[2:]]) + (
            " " if line.endswith(" ") else "")
        rest = words[2:]
    else:
        command, rest = "run", []
    config_name = _primary(rest) if command == "run" else "probe"
    sys.argv = ["creatio", *argv]
    study = _selected([a for a in rest if not a.startswith("-")])[0]
    _hydra_app(config_name, _run_task if command == "run" else _probe_task,
               study if command == "run" and study in _study_ids() else None)
    return 0


def _dispatch(argv: list[str]) -> int:
    """Run one command."""
    if not argv or argv[0] in ("-h", "--help", "help"):
        print(_usage())
        return 0
    if argv[0] in ("-V", "--version"):
        from creatio import __version__

        print(f"creatio {__version__}")
        return 0
    if argv[0] in ("-sc", "--shell-completion"):
        return _completion(argv)
    command, rest = argv[0], argv[1:]
    if command not in ("run", "probe") or "-m" in rest or "--multirun" in rest:
        logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    if command == "run" and ("-m" in rest or "--multirun" in rest):
        return _multirun(rest)
    if command in ("run", "probe"):  # Hydra apps: Hydra configures logging (--info once)
        config_name = _primary(rest) if command == "run" else "probe"
        _prevalidate(rest, config_name)
        if command == "run" and not any(a.startswith(("-", "hydra")) for a in rest):
            return _run_plain(rest)
        sys.argv = [f"creatio {command}", *rest]
        study = _selected([a for a in rest if not a.startswith("-")])[0]
        _hydra_app(config_name, _run_task if command == "run" else _probe_task,
                   study if command == "run" and study in _study_ids() else None)
        return 0
    if command == "task":
        if rest[:1] == ["scene"]:
            from creatio.scenes.cli import main as scene_main

            return scene_main(rest[1:])
        if rest[:1] == ["en05"]:
            from creatio.pipeline.points import main as en05_main

            return en05_main(rest[1:])
        return _task(rest)
    if command == "calibrate":
        from creatio.pipeline.calibrate import main as calibrate_main

        return calibrate_main(rest)
    if command == "release":
        from creatio.pipeline.release import main as release_main

        return release_main(rest)
    if command == "diff":
        from creatio.diff import main as diff_main

        return diff_main(rest)
    if command == "worker":
        from creatio.pipeline.worker import main as worker_main

        # the scene jobs' module, warmed too (the worker, a layer below, names none above it)
        return worker_main(rest, entry=main, warm=("creatio.scenes.cli",))
    if command in ("ls", "open"):
        from creatio.pipeline.index import main as index_main

        return index_main([command, *rest])
    print(f"creatio: unknown command {command!r} (creatio --help lists them)", file=sys.stderr)
    return 2


class _StderrOrStdout:
    """stderr that falls back to stdout when it cannot be written: a Snakemake job's stderr
    is its log file, and on a full disk the log stayed empty and the failure unsaid (stdout
    goes to Snakemake's own output)."""

    def __init__(self, primary, fallback) -> None:  # type: ignore[no-untyped-def]
        self.primary, self.fallback, self.failed = primary, fallback, False

    def write(self, text: str) -> int:
        if not self.failed:
            try:
                n = self.primary.write(text)
                self.primary.flush()
                return n
            except OSError:
                self.failed = True
        n = self.fallback.write(text)
        self.fallback.flush()
        return n

    def flush(self) -> None:
        with contextlib.suppress(OSError):
            (self.fallback if self.failed else self.primary).flush()

    def __getattr__(self, name: str):  # type: ignore[no-untyped-def]
        return getattr(self.primary, name)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `creatio` console script: every failure is one line naming what
    and why, with a non-zero status; CREATIO_DEBUG=1 shows the traceback instead."""
    if argv is None:  # a command of its own: a warm worker may run it (creatio.pipeline.worker)
        from creatio.pipeline.worker import delegate

        code = delegate(sys.argv[1:])
        if code is not None:
            return code
    saved = sys.stderr
    if saved is not None and sys.stdout is not None and not isinstance(saved, _StderrOrStdout):
        sys.stderr = _StderrOrStdout(saved, sys.stdout)
    try:
        return _main(list(sys.argv[1:] if argv is None else argv))
    finally:
        sys.stderr = saved


def _main(argv: list[str]) -> int:
    import os

    if os.environ.get("CREATIO_DEBUG"):
        return _dispatch(argv)
    try:
        return _dispatch(argv)
    except BrokenPipeError:  # `creatio run --help | head`: the reader left; so do we
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except KeyboardInterrupt:
        print(f"creatio: {INTERRUPTED}", file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 - one line, and how to see more
        message, code = describe(e)
        print(f"creatio: {message}", file=sys.stderr)
        return code


INTERRUPTED = "interrupted (nothing half-written is kept; rerun to finish)"


def describe(e: BaseException) -> tuple[str, int]:
    """A failure as (one line naming what and why, exit status): 2 for a refused config, 1
    for anything else; the traceback is for CREATIO_DEBUG=1."""
    if isinstance(e, ConfigError):
        return str(e), 2
    from creatio.errors import interrupted

    if interrupted(e):  # Ctrl-C inside compiled code arrives as a SystemError
        return INTERRUPTED, 130
    from creatio.pipeline.checks import ChecksFailed

    if isinstance(e, ChecksFailed):
        return str(e), 1
    if isinstance(e, OSError):
        return _os_error(e), 1
    if isinstance(e, ArithmeticError):  # a value the validation let through still overflowed
        import traceback

        frame = traceback.extract_tb(e.__traceback__)[-1]
        return (f"the computation failed ({type(e).__name__}: {e}) at "
                f"{Path(frame.filename).name}:{frame.lineno}: a config value is outside the "
                "model's numeric range (CREATIO_DEBUG=1 shows the traceback)"), 1
    first = str(e).splitlines()[0] if str(e) else ""
    return f"{type(e).__name__}: {first} (CREATIO_DEBUG=1 shows the traceback)", 1


def _os_error(e: OSError) -> str:
    """An operating-system error as one line: the file, the cause, what to do."""
    import errno

    where = f"{e.filename}: " if e.filename else ""
    cause = e.strerror or str(e)
    hint = {
        errno.ENOSPC: "free some space and rerun (no partial file was kept)",
        errno.EDQUOT: "free some space and rerun (no partial file was kept)",
        errno.EROFS: "write somewhere writable (snakemake -d DIR, or run from another directory)",
        errno.EACCES: "check the permissions of the directory, or write elsewhere",
        errno.ENOENT: "check the path (snakemake all makes the default outputs)",
    }.get(e.errno or 0, "")
    return f"{where}{cause}" + (f": {hint}" if hint else "")


if __name__ == "__main__":
    sys.exit(main())
