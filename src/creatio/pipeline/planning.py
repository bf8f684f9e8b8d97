"""Planning for the Snakefile: which resolved config produces which files.

The Snakefile stays declarative; the decisions live here, where they can be tested. Every
dataset job gets its resolved config as canonical YAML, its only config parameter: a job
reruns exactly when its resolved config changes, however the overrides were spelled.
Output roots: ``data`` for a study's default config, ``data/runs/<hash>`` otherwise.
"""

from __future__ import annotations

import functools
import os
import re
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError, one_line_errors
from creatio.pipeline.code import CODE, code_version
from creatio.pipeline.config import (
    Resolved,
    applicable,
    nearest_key,
    nearest_name,
    output_root,
    resolve,
)
from creatio.studies import registry

__all__ = [
    "CODE",
    "PASSED_CONFIG",
    "JobConfigs",
    "check_tol",
    "check_workflow_config",
    "pass_config_safely",
    "code_version",
    "write_config_file",
    "one_line_errors",
    "analysis_ids",
    "beyond_studies",
    "beyond_targets",
    "StudyPlan",
    "StudyRuns",
    "SweepRegistry",
    "as_list",
    "compare_targets",
    "plan",
    "wildcard_pattern",
]


@one_line_errors
def check_workflow_config(config: Mapping[str, Any], schema: str | Path) -> None:
    """Validate Snakemake's --config against workflows/schemas/config.schema.yaml with
    snakemake.utils.validate; a refusal is creatio's one line (key, value, rule), not the
    schema dump."""
    import difflib

    from snakemake.exceptions import WorkflowError
    from snakemake.utils import validate

    try:
        validate(dict(config), str(schema), set_default=False)
    except WorkflowError as e:
        error = e.__context__ if hasattr(e.__context__, "validator") else None
        if error is None:
            raise ConfigError("--config", dict(config), str(e).splitlines()[0]) from None
        if error.validator == "additionalProperties":
            known = sorted(error.schema.get("properties", {}))
            for key in sorted(set(config) - set(known)):
                near = difflib.get_close_matches(key, known, n=1)
                hint = f" (did you mean {near[0]}?)" if near else f" (known: {', '.join(known)})"
                raise ConfigError(key, config[key], "unknown --config key" + hint) from None
        key = ".".join(str(p) for p in error.absolute_path) or "--config"
        rule = ("must be a string or a list of strings" if error.validator == "oneOf"
                else error.message)  # oneOf: the schema's only one, #/$defs/strings
        if error.schema.get("description"):
            rule += f" ({error.schema['description']})"
        raise ConfigError(key, error.instance, rule) from None
    for i, entry in enumerate(as_list(config.get("tol"))):
        check_tol(f"tol[{i}]", entry)


def check_tol(key: str, text: str) -> None:
    """Refuse a per-variable tolerance of `snakemake diff` that `creatio diff --tol` would
    refuse after the workflow has run (NAME=ATOL or NAME=ATOL,RTOL, finite and >= 0): the
    rule of creatio.diff's parse_tol, checked with the other --config keys."""
    import math

    name, sep, values = text.partition("=")
    parts = values.split(",")
    try:
        if not sep or not name or len(parts) > 2:
            raise ValueError
        numbers = [float(p) for p in parts]
    except ValueError:
        raise ConfigError(key, text, "must be NAME=ATOL or NAME=ATOL,RTOL with numbers, e.g. "
                          "'fd_error*=1e-9,1e-6'") from None
    if not all(math.isfinite(x) and x >= 0.0 for x in numbers):
        raise ConfigError(key, text, "tolerances must be finite and >= 0")


#: The only --config entry a re-invoked job gets (a `run:` job, a cluster job): the
#: invocation's own --config entries, as JSON in URL-safe base64.
PASSED_CONFIG = "creatio_config"
_SAFE_TEXT = re.compile(r"[A-Za-z0-9_=-]*")


@one_line_errors
def pass_config_safely(settings: Any, config: dict[str, Any]) -> None:
    """Keep the user's --config text out of every shell.

    Snakemake re-invokes itself for a job that runs in its own process (a ``run:`` rule
    locally, every job on a cluster) through ``/bin/sh``, and writes the invocation's
    --config entries into that command with ``repr()``, which is no shell quoting: an
    override holding ``$(...)`` ran it, one holding a quote broke the command. Here the
    entries are handed on as one ``creatio_config=<base64 of their JSON>`` entry, whose
    letters (``A-Za-z0-9_-=``) no shell interprets, however many shells it passes through
    (SLURM: sbatch --wrap, then srun on the node); the re-invoked job decodes them and
    parses them as Snakemake parses --config, so both processes see the same config.
    ``settings`` is the workflow's ``config_settings``, ``config`` its config, updated in
    place.
    """
    import base64
    import json

    from snakemake.utils import update_config

    if PASSED_CONFIG in config:  # a re-invoked job (or a user who typed it): decode
        from snakemake.cli import parse_config

        encoded = str(config.pop(PASSED_CONFIG))
        try:
            if not _SAFE_TEXT.fullmatch(encoded):
                raise ValueError("not URL-safe base64")
            entries = json.loads(base64.urlsafe_b64decode(encoded.encode()))
            if not (isinstance(entries, list) and all(isinstance(e, str) for e in entries)):
                raise ValueError("not a list of KEY=VALUE entries")
            update_config(config, parse_config(entries))
        except ValueError as e:
            raise ConfigError(PASSED_CONFIG, encoded[:40], "is creatio's own --config key "
                              f"for re-invoked jobs and this one cannot be read ({e})") from None
        return
    entries = settings.config_args
    if entries:
        text = json.dumps([str(e) for e in entries])
        settings.config_args = [
            f"{PASSED_CONFIG}={base64.urlsafe_b64encode(text.encode()).decode()}"]


def as_list(value: Any) -> list[str]:
    """A --config value as a list of strings (a bare string is one item, not characters)."""
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    return [str(v) for v in value]


@dataclass(frozen=True)
class StudyPlan:
    """One study's resolved config, applicable overrides and output root."""

    study: str
    resolved: Resolved
    overrides: tuple[str, ...]
    root: str

    @property
    def sha256(self) -> str:
        """The resolved config's hash."""
        return self.resolved.sha256

    @property
    def entry(self) -> registry.Study:
        """The registry entry of the study."""
        return registry.get(self.study)

    @property
    def datasets(self) -> list[str]:
        """Dataset paths, in the order of the study's parts (configured dt first)."""
        return self.entry.datasets(self.root, self.resolved.obj)

    @property
    def reports(self) -> list[str]:
        """Every report file of this study."""
        return self.entry.reports(self.root)


def published_groups(study: str) -> str:
    """What the notebook publishes of a study (``fd_error pattern regularity``; empty for
    none): the report rules' parameter, so that captions promise only what a study has."""
    return " ".join(sorted(registry.get(study).published))


def default_studies() -> list[str]:
    """The studies `snakemake all` builds (the registry's, analyses aside)."""
    return [s.id for s in registry.select(in_all=True)]


def beyond_studies(selected: Any = None) -> list[str]:
    """The studies `snakemake beyond` builds (the sphere and material studies outside `all`),
    or those of them --config studies=[...] selects (the others it names are `all`'s
    business); an empty selection builds none."""
    ids = [s.id for s in registry.beyond()]
    return ids if selected is None else [s for s in ids if s in as_list(selected)]


@one_line_errors
def beyond_targets(runs: StudyRuns, selected: Any = None) -> list[str]:
    """The files of `snakemake beyond`: its studies' targets; a --config studies=[...] that
    names none of them is refused (it would build nothing, silently)."""
    if not runs.studies:
        raise ConfigError("studies", as_list(selected), "names no study of `snakemake beyond` "
                          f"({', '.join(beyond_studies())})")
    return runs.targets()


def analysis_ids() -> list[str]:
    """The analyses (`snakemake benchmarks`)."""
    return [s.id for s in registry.select(kind="analysis")]


def wildcard_pattern(kind: str | None = None, folder: str | None = None) -> str:
    """A regex of the registered study ids (of one kind, or whose datasets live in one
    folder), for Snakemake wildcard constraints; one that matches nothing if there are none."""
    ids = [s.id for s in registry.select(kind=kind)
           if folder is None or s.kind.dataset_dir == folder]
    return "|".join(ids) or "(?!)"


def plan(
    overrides: Sequence[str] = (), studies: Sequence[str] | None = None, data_dir: str = "data"
) -> dict[str, StudyPlan]:
    """Resolve every study's config under the overrides; refuse overrides no study uses."""
    overrides = as_list(overrides)
    studies = default_studies() if studies is None else as_list(studies)
    unknown = [s for s in studies if s not in registry.STUDIES]
    if unknown:
        raise ConfigError("studies", unknown, f"must be among {', '.join(registry.STUDIES)}"
                          + nearest_name(unknown[0], registry.STUDIES))
    used: set[str] = set()
    out = {}
    for study in studies:
        ovs = applicable(study, overrides)
        used.update(ovs)
        resolved = resolve(study, ovs)
        out[study] = StudyPlan(study, resolved, tuple(ovs),
                               str(output_root(resolved, data_dir)))
    unused = [o for o in overrides if o not in used]
    if unused:
        raise unused_overrides(unused, studies)
    return out


def unused_overrides(unused: Sequence[str], studies: Sequence[str]) -> ConfigError:
    """The refusal of overrides no selected study has: the first one's key with the nearest
    key of the studies' configs (``sphere.muu`` -> did you mean sphere.mu?), as `creatio
    run` says it."""
    for ov in unused:
        key, _, value = str(ov).partition("=")
        near = nearest_key(key, [s for s in studies if s in registry.STUDIES])
        if near is not None:
            return ConfigError(key.lstrip("+~"), value, f"unknown key (did you mean {near}?)")
    return ConfigError("overrides", list(unused), "no selected study has these keys")


def compare_targets(plans: dict[str, StudyPlan]) -> list[str]:
    """The EN-02 / EN-02R comparison files, when both studies run on default configs."""
    pair = [plans.get("en02"), plans.get("en02r")]
    if all(p is not None and p.root == "data" for p in pair):
        return ["data/reports/compare_en02_en02r.md", "data/reports/compare_en02_en02r.png"]
    return []


def write_config_file(path: str | Path, log: str | Path, name: str, text: str,
                      sha256: str) -> None:
    """A config rule's job: the canonical resolved YAML to path and its hash to the log,
    each written to a temporary sibling and renamed (a kill leaves no partial file)."""
    for target, body in ((Path(path), text), (Path(log), f"{name} config sha256 {sha256}\n")):
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(f".{target.name}.tmp-{os.getpid()}")
        tmp.write_text(body)
        os.replace(tmp, target)


class JobConfigs:
    """Which resolved config writes under (output root, study), for every job of this run.

    Study runs and sweep points register here, so one set of dataset rules serves both.
    The default config of a study is registered on demand for the ``data`` root.
    """

    def __init__(self, data_dir: str = "data") -> None:
        self.data_dir = data_dir
        self._by_root: dict[tuple[str, str], Resolved] = {}
        self._overrides: dict[tuple[str, str], tuple[str, ...]] = {}
        # Planners to run on a miss: a job re-invoked in its own Snakemake process (run:
        # directives, cluster executors) parses the Snakefile anew without the targets.
        self.fallbacks: list[Callable[[], Any]] = []

    def add(self, root: str, resolved: Resolved, overrides: Sequence[str] = ()) -> None:
        """Register the config that produces datasets under root (first one wins), with
        the overrides that made it (recorded beside a run folder's files)."""
        self._by_root.setdefault((str(root), resolved.id), resolved)
        self._overrides.setdefault((str(root), resolved.id), tuple(overrides))

    @one_line_errors
    def get(self, root: str, study: str) -> Resolved:
        """The resolved config for (root, study)."""
        key = (str(root), study)
        if key not in self._by_root and str(root) == self.data_dir:
            self._by_root[key] = resolve(study)
        for fallback in self.fallbacks:
            if key in self._by_root:
                break
            fallback()
        try:
            return self._by_root[key]
        except KeyError:
            raise ConfigError("output", f"{root}/{study}",
                              "no configuration of this invocation writes there") from None

    @one_line_errors
    def sha(self, root: str, study: str) -> str:
        """The sha256 of (root, study)'s canonical resolved YAML: the config file rule's only
        parameter, so that it reruns exactly when the resolved config changes and says so
        in one line."""
        return self.get(root, study).sha256

    @one_line_errors
    def write(self, root: str, study: str, path: str | Path, log: str | Path) -> None:
        """Write (root, study)'s canonical resolved YAML to path (temporary, then renamed)
        and its hash to the log; a run folder (data/runs/<hash>) also gets its
        overrides.json (creatio.pipeline.index.record_run)."""
        from creatio.pipeline.index import record_run

        resolved = self.get(root, study)
        write_config_file(path, log, study, resolved.yaml, resolved.sha256)
        if str(root) != self.data_dir:
            record_run(root, "study", study, resolved.data, resolve(study).data,
                       self._overrides.get((str(root), study)), resolved.sha256,
                       self.data_dir)

    @one_line_errors
    def yaml(self, root: str, study: str) -> str:
        """The canonical resolved YAML (a dataset job's config parameter)."""
        return self.get(root, study).yaml

    @one_line_errors
    def datasets(self, root: str, study: str) -> list[str]:
        """Dataset paths of (root, study), in the order of the study's parts."""
        return registry.get(study).datasets(root, self.get(root, study).obj)

    @one_line_errors
    def part(self, root: str, study: str, name: str) -> str:
        """Check that (root, study) has a dataset part called name; return it."""
        try:
            registry.get(study).part(self.get(root, study).obj, name)
        except KeyError as e:
            raise ConfigError("output", f"{root}/{study}/{name}.nc", str(e.args[0])) from None
        return name


class StudyRuns:
    """The studies of `snakemake all`, planned on first use (so a sweep never plans them)."""

    def __init__(self, jobs: JobConfigs, overrides: Any, studies: Any) -> None:
        self.jobs = jobs
        self.overrides = as_list(overrides)
        self.studies = as_list(studies) if studies is not None else default_studies()

    @functools.cached_property
    def plans(self) -> dict[str, StudyPlan]:
        """Resolve every selected study and register its jobs."""
        plans = plan(self.overrides, self.studies, self.jobs.data_dir)
        for p in plans.values():
            self.jobs.add(p.root, p.resolved, p.overrides)
            if p.overrides:
                print(f"creatio: {p.study} {list(p.overrides)} -> {p.root}", file=sys.stderr)
        return plans

    @one_line_errors
    def targets(self) -> list[str]:
        """Every dataset and report of every selected study, plus the EN-02 / EN-02R
        comparison. The datasets are targets, not only the reports' inputs: Snakemake does
        not remake a missing input of an up-to-date job (a dataset deleted by a killed forced
        rerun would otherwise stay missing behind its report)."""
        return [f for p in self.plans.values() for f in (*p.datasets, *p.reports)] + \
            compare_targets(self.plans)


def _positive_int(key: str, value: Any) -> int | None:
    """A --config value that must be a positive integer (None when not given)."""
    if value is None:
        return None
    try:
        number = int(str(value))
    except ValueError:
        number = 0
    if number < 1:
        raise ConfigError(key, value, "must be a positive integer")
    return number


class SweepRegistry:
    """The sweeps of one workflow invocation, planned on demand (only when targeted)."""

    def __init__(self, jobs: JobConfigs, basedir: str | Path) -> None:
        self.jobs = jobs
        self.basedir = Path(basedir)
        self.plans: dict[str, Any] = {}
        # Planners to run on a miss (a job re-invoked alone, e.g. on a cluster node).
        self.fallbacks: list[Callable[[], Any]] = []

    @one_line_errors
    def outputs(self, study: str, sweep: Any, overrides: Any, batch: Any = None,
                max_points: Any = None) -> list[str]:
        """Plan a sweep (once) and return its aggregate files; its batches are its jobs."""
        from creatio.pipeline.sweep import MAX_POINTS, plan_sweep

        sweep = as_list(sweep)
        if not sweep:
            raise ConfigError("sweep", sweep,
                              "`snakemake sweep` needs --config study=ID 'sweep=[\"KEY=V1,V2\"]'")
        s = plan_sweep(study, sweep, as_list(overrides), self.jobs.data_dir,
                       batch_size=_positive_int("sweep_batch", batch),
                       max_points=_positive_int("sweep_max_points", max_points) or MAX_POINTS)
        if s.name not in self.plans:
            self.plans[s.name] = s
            print(f"creatio: sweep {s.name}: {s.n_points} points in {s.n_batches} batch(es) of "
                  f"{s.batch_size} -> {s.outdir}", file=sys.stderr)
        return s.outputs

    @one_line_errors
    def worked(self, name: str) -> list[str]:
        """The aggregate of a sweep defined in conf/sweeps/<name>.yaml."""
        import yaml

        from creatio.store.regular import read_text

        spec = yaml.safe_load(read_text(self.basedir / "conf" / "sweeps" / f"{name}.yaml"))
        return self.outputs(spec["study"], spec["sweep"], spec.get("overrides"),
                            spec.get("batch"))

    @one_line_errors
    def __getitem__(self, name: str) -> Any:
        for fallback in self.fallbacks:
            if name in self.plans:
                break
            fallback()
        try:
            return self.plans[name]
        except KeyError:
            raise ConfigError("sweep", name, "no sweep of this invocation has that name") from None
