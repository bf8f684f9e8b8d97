"""Parameter sweeps in batches: a Cartesian product of values, a few jobs, one aggregate.

A sweep is a study, a list of Hydra sweep overrides (``sphere.mu=0,0.05,0.15``, also
``range(...)`` and the rest of Hydra's sweep grammar) and base overrides applied to every
point. Planning costs nothing per point: the product is dealt out in turn into batches, one job
each (``batch_size`` points at most; by default about eight batches of 20 to 250 points
each), so that batches cost alike even where the refused or dearer points gather at one end
of an axis. A batch job composes the base config once and varies it per point
(creatio.studies.schema.vary: a validated copy, no Hydra), runs the study's first dataset
part in the same process and keeps each point's summary figures as a row of its batch file.

Points are identified by their resolved config and the code that computes them: a point
that any earlier sweep of the study computed with the same code (the ``datasets`` code
version of creatio.pipeline.planning, which the dataset rules carry too) is taken from that
sweep's batch files instead of being run again, so rerunning a sweep with more points
computes only the new ones, and a code change computes every point anew. A point refused by
validation (an unstable dt, an amplitude too large) is recorded with its reason, as a run that
stopped early keeps its status; neither aborts the rest. The aggregate fills one array per
summary figure from the batch files, never holding the points' datasets.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError
from creatio.store.regular import check_regular
from creatio.studies import registry

__all__ = [
    "HARD_MAX_POINTS",
    "MAX_POINTS",
    "SweepPlan",
    "aggregate",
    "interpolations",
    "grammar_error",
    "parse_axes",
    "plan_sweep",
    "point_changes",
    "run_batch",
    "write_sweep",
]

log = logging.getLogger("creatio")

#: Largest sweep planned without asking (its aggregate holds one float per point and figure).
MAX_POINTS = 200_000
#: Largest sweep planned at all (sweep_max_points cannot go beyond): its aggregate holds
#: ~20 float64 figures, a status and a message per point, ~2 GB at 10 million points.
HARD_MAX_POINTS = 10_000_000
#: Default batching: about this many batches, each of MIN_BATCH to MAX_BATCH points. A
#: batch of fewer points costs more in its job's start (a process or a fork, composing the
#: base config, writing the batch file: about 1 s here) than in its computing (EN-02: about
#: 0.15 s a point), so a small sweep is a few batches, not eight (40 or 41 points: two).
TARGET_BATCHES = 8
MIN_BATCH = 20
MAX_BATCH = 250


@dataclass(frozen=True)
class SweepPlan:
    """A sweep: its axes (key, values), base overrides, batching and output directory."""

    study: str
    axes: tuple[tuple[str, tuple[str, ...]], ...]
    base: tuple[str, ...]
    name: str
    outdir: str
    batch_size: int
    #: the sweep overrides as given (``sphere.mu=range(0,1,0.001)``), what a job re-parses
    texts: tuple[str, ...] = ()
    #: the size limit the plan was made under (a job re-plans under the same one)
    max_points: int = MAX_POINTS

    @property
    def shape(self) -> tuple[int, ...]:
        """Number of values of each axis."""
        return tuple(len(v) for _, v in self.axes)

    @property
    def n_points(self) -> int:
        """Points of the product."""
        return math.prod(self.shape)

    @property
    def n_batches(self) -> int:
        """Batch jobs of the sweep."""
        return math.ceil(self.n_points / self.batch_size)

    def batch_range(self, k: int) -> range:
        """Flat indices (row-major over the axes) of the points of batch k: every
        n_batches-th point from k. Dealt out in turn, not cut into consecutive runs, so that
        the batches of a sweep cost alike: the points validation refuses (a mu beyond the
        friction's stability limit) and the dearer ones gather at one end of an axis."""
        return range(k, self.n_points, self.n_batches)

    def batch_file(self, k: int) -> str:
        """Path of batch k's rows (named by the batching, so a new batch size is new files)."""
        return f"{self.outdir}/batches/b{self.batch_size}-{k:05d}.nc"

    @property
    def batches(self) -> list[str]:
        """Every batch file (the inputs of the aggregate)."""
        return [self.batch_file(k) for k in range(self.n_batches)]

    def indices(self, index: int) -> tuple[int, ...]:
        """The value of each axis that the point with flat index `index` takes: row-major
        over the product (creatio.pipeline.points lists its points instead)."""
        return _unravel(index, self.shape)

    def row(self, entry: registry.Study, obj: Any) -> dict[str, Any]:
        """The figures a batch keeps of one computed point: its study's summary."""
        return _run_point(entry, obj)

    def typed_axes(self) -> tuple[tuple[str, tuple[Any, ...]], ...]:
        """Every axis value parsed to its Hydra type (once per batch job, by Hydra's
        override grammar: ``5`` an int, ``0.5`` a float, ``abc`` a string)."""
        from hydra.core.override_parser.overrides_parser import OverridesParser

        parser = OverridesParser.create()
        return tuple((key, tuple(parser.parse_override(f"{key}={v}").value() for v in vals))
                     for key, vals in self.axes)

    def overrides(self, index: int) -> tuple[str, ...]:
        """The sweep overrides of the point with flat index `index`."""
        idx = self.indices(index)
        return tuple(f"{k}={v[i]}" for (k, v), i in zip(self.axes, idx, strict=True))

    @property
    def outputs(self) -> list[str]:
        """The aggregate files."""
        return [f"{self.outdir}/sweep.{ext}" for ext in ("nc", "md", "png")]

    def spec(self) -> dict[str, Any]:
        """What defines the sweep (its name is a hash of this)."""
        return {"study": self.study, "axes": [[k, list(v)] for k, v in self.axes],
                "base": list(self.base)}

    def cli_args(self) -> str:
        """Arguments that rebuild this plan in `creatio task sweep|sweep-batch`."""
        import shlex

        args = [f"--study {self.study}"]
        # the overrides as typed, not their expansion: a job's command line stays short (a
        # million values written into each of 4000 jobs' parameters took 24 GB)
        texts = self.texts or tuple(f"{k}=" + ",".join(v) for k, v in self.axes)
        args += [f"--sweep {shlex.quote(t)}" for t in texts]
        args += [f"--override {shlex.quote(o)}" for o in self.base]
        args.append(f"--batch-size {self.batch_size}")
        if self.max_points != MAX_POINTS:
            args.append(f"--max-points {self.max_points}")
        return " ".join(args)


def _unravel(index: int, shape: Sequence[int]) -> tuple[int, ...]:
    out = []
    for n in reversed(shape):
        index, i = divmod(index, n)
        out.append(i)
    return tuple(reversed(out))


def _axis_size(ov: Any) -> int | None:
    """How many values a parsed sweep override expands to, computed without expanding it
    (None: Hydra must expand it to tell, a glob over a config group's few options)."""
    import decimal

    from hydra.core.override_parser.types import ChoiceSweep, RangeSweep

    if not ov.is_sweep_override():
        return 1
    sweep = ov.value()
    if isinstance(sweep, ChoiceSweep):
        return len(sweep.list)
    if isinstance(sweep, RangeSweep):
        if sweep.start is None or sweep.stop is None:
            return None
        try:  # as Hydra counts: a Python range for ints, exact decimals for floats
            if all(isinstance(x, int) for x in (sweep.start, sweep.stop, sweep.step)):
                return len(range(sweep.start, sweep.stop, sweep.step))
            start, stop, step = (decimal.Decimal(x) for x in (sweep.start, sweep.stop,
                                                              sweep.step))
        except (ValueError, decimal.InvalidOperation) as e:  # step 0, nan
            raise ValueError(str(e) or "a range needs a finite, non-zero step") from None
        if not (start.is_finite() and stop.is_finite() and step.is_finite()) or step == 0:
            raise ValueError("a range needs finite bounds and a non-zero step")
        span = (stop - start) / step
        return max(0, int(span.to_integral_value(rounding=decimal.ROUND_CEILING)))
    return None


def parse_axes(sweep: Sequence[str], max_points: int = MAX_POINTS
               ) -> list[tuple[str, list[str]]]:
    """Split sweep overrides into (key, values) with Hydra's override grammar.

    The size of every axis, and of their product, is computed from the override before any
    axis is expanded, and a product beyond max_points is refused with its size: a
    ``range(0, 1e8, 1)`` used to be expanded (7 GB) before the size was checked."""
    import itertools

    from hydra.core.override_parser.overrides_parser import OverridesParser

    from creatio.pipeline.config import refuse_identity, refuse_interpolations

    refuse_interpolations([str(t) for t in sweep])
    refuse_identity([str(t) for t in sweep], "study.id", "--config study=ID")
    parser = OverridesParser.create()
    parsed = []
    for text in sweep:
        try:
            (ov,) = parser.parse_overrides([str(text)])
        except Exception as e:  # noqa: BLE001 - Hydra's grammar errors, re-worded
            raise ConfigError("sweep", text, grammar_error(str(text), e)) from None
        try:
            size = _axis_size(ov)
        except ValueError as e:
            raise ConfigError("sweep", text, f"cannot be expanded: {e}") from None
        if ov.get_key_element() in [o.get_key_element() for _, o, _ in parsed]:
            raise ConfigError("sweep", text, f"key {ov.get_key_element()} is swept twice")
        parsed.append((text, ov, size))
    if not parsed:
        raise ConfigError("sweep", list(sweep), "needs at least one KEY=V1,V2,... entry")
    known = math.prod(size for _, _, size in parsed if size is not None)
    if known > max_points:
        _too_many(known, max_points)
    axes = []
    for text, ov, _ in parsed:
        try:  # never more values than the limit allows, whatever the count said
            values = list(itertools.islice(ov.sweep_string_iterator(), max_points + 1)) \
                if ov.is_sweep_override() else [ov.get_value_element_as_str()]
        except Exception as e:  # noqa: BLE001 - a sweep Hydra cannot expand (interval, ...)
            raise ConfigError("sweep", text, f"cannot be expanded: {e}") from None
        if not values:
            raise ConfigError("sweep", text, "sweeps over no value")
        axes.append((ov.get_key_element(), values))
    n = math.prod(len(v) for _, v in axes)
    if n > max_points:
        _too_many(n, max_points)
    return axes


_FUNCTION = re.compile(r"^\s*(range|interval)\s*\((.*)\)\s*$")


def grammar_error(text: str, error: Exception) -> str:
    """What is wrong with a sweep override Hydra's grammar refused, in one line: a range()
    or interval() argument that is no number is named; otherwise Hydra's first line and
    the syntax."""
    value = text.partition("=")[2]
    m = _FUNCTION.match(value)
    if m:
        name, args = m.group(1), [a.strip() for a in m.group(2).split(",")]
        shape = "range(START, STOP[, STEP])" if name == "range" else "interval(LOW, HIGH)"
        for arg in args:
            try:
                float(arg.partition("=")[2] if "=" in arg else arg)
            except ValueError:
                return f"{shape} takes numbers: {arg!r} is not a number"
        if len(args) not in ((2, 3) if name == "range" else (2,)):
            return (f"{shape} takes {'2 or 3' if name == 'range' else '2'} numbers, not "
                    f"{len(args)}")
    first = str(error).splitlines()[0] if str(error) else type(error).__name__
    return (f"{first} (sweep syntax: KEY=V1,V2,... or KEY=range(START,STOP,STEP); quote "
            "a value holding a comma or a bracket)")


def _too_many(n: int, max_points: int) -> None:
    hint = (f"raise the limit with --config sweep_max_points={n}" if n <= HARD_MAX_POINTS
            else f"the limit cannot exceed {HARD_MAX_POINTS:,}")
    raise ConfigError("sweep", f"{n:,} points", f"exceeds {max_points:,} points (the "
                      f"aggregate keeps a float per point and figure): split it into several "
                      f"sweeps, or {hint}")


def plan_sweep(
    study: str, sweep: Sequence[str], base: Sequence[str] = (), data_dir: str = "data",
    batch_size: int | None = None, max_points: int = MAX_POINTS, check_first: bool = True,
) -> SweepPlan:
    """Plan a sweep: its axes, batches and outputs. Nothing is composed per point.

    Refused up front: an unknown study or key, an empty or duplicated axis, a base config
    that no point could repair (the first point checked in full, unless ``check_first`` is
    off: the jobs of a planned sweep, whose points are each checked as they run), and a
    product larger than max_points (with its size and what to do).
    """
    from creatio.pipeline.config import applicable, nearest_key, nearest_name, resolve

    if not study:
        raise ConfigError("study", study, "a sweep needs the study to sweep (study=en02)")
    if study not in registry.STUDIES:
        raise ConfigError("study", study, f"must be one of {', '.join(registry.STUDIES)}"
                          + nearest_name(study, registry.STUDIES))
    if not (isinstance(max_points, int) and 1 <= max_points <= HARD_MAX_POINTS):
        raise ConfigError("sweep_max_points", max_points,
                          f"must be an integer in [1, {HARD_MAX_POINTS:,}] (the aggregate "
                          "holds every point's figures in memory)")
    axes = parse_axes(sweep, max_points)
    base = tuple(str(o) for o in base)
    for key, values in axes:
        if not applicable(study, [f"{key}={values[0]}"]):
            near = nearest_key(key, [study])
            raise ConfigError(key, values[0], f"unknown key (did you mean {near}?)" if near
                              else f"unknown key (not in {study}'s config)")
    n = math.prod(len(v) for _, v in axes)
    if batch_size is None:
        batches = max(1, min(TARGET_BATCHES, n // MIN_BATCH))
        batch_size = min(MAX_BATCH, math.ceil(n / batches))
    if not (isinstance(batch_size, int) and batch_size >= 1):
        raise ConfigError("sweep_batch", batch_size, "must be a positive integer")
    spec = json.dumps({"study": study, "axes": axes, "base": base}, sort_keys=True)
    name = f"{study}-{hashlib.sha256(spec.encode()).hexdigest()[:12]}"
    plan = SweepPlan(study, tuple((k, tuple(v)) for k, v in axes), base, name,
                     f"{data_dir}/sweeps/{name}", batch_size, tuple(str(t) for t in sweep),
                     max_points)
    if not check_first:
        return plan
    first = plan.overrides(0)
    try:
        resolve(study, [*base, *first])
    except ConfigError as e:
        if e.key.split("[")[0] not in {k for k, _ in axes}:
            raise ConfigError(e.key, e.value, f"{e.rule} (in the base config of the sweep: "
                              f"the first point {list(first)} is refused)") from None
    return plan


# ---------------------------------------------------------------------------- batch jobs
@dataclass(frozen=True)
class _Base:
    """What a batch job varies: the study's unchecked base config, the typed axis values,
    and the keys that follow a swept key (``study.duration: ${..phases.T}``)."""

    obj: Any
    values: tuple[tuple[str, tuple[Any, ...]], ...]
    links: dict[str, tuple[str, ...]]


def _base(plan: SweepPlan) -> _Base:
    """Compose the base config once (unchecked: a point's values may make it valid), parse
    every axis value to its Hydra type once, and find the interpolations a swept key feeds."""
    from creatio.pipeline.config import compose, composed, override_error, validate

    try:  # no base override: the default composition, shared (only read here)
        cfg = compose(plan.study, list(plan.base)) if plan.base else composed(plan.study)
    except Exception as e:  # noqa: BLE001 - Hydra refused a base override
        raise override_error(plan.study, list(plan.base), e) from None
    obj = validate(cfg, check=False).obj
    values = plan.typed_axes()
    links: dict[str, list[str]] = {}
    for key, source in _interpolations(cfg):
        if source is None:
            if any(k in _referenced(cfg, key) for k, _ in plan.axes):
                raise ConfigError(key, "(interpolation)", "follows a swept key through an "
                                  "expression a sweep cannot vary: sweep it too")
            continue
        links.setdefault(source, []).append(key)
    return _Base(obj, values, {k: tuple(v) for k, v in links.items()})


def point_changes(plan: SweepPlan, base: _Base, index: int) -> dict[str, Any]:
    """The typed values point `index` sets, with the keys that follow them (schema.vary's
    changes of the base config)."""
    idx = plan.indices(index)
    changes = {key: vals[i] for (key, vals), i in zip(base.values, idx, strict=True)}
    changes.update({dep: changes[src] for src, deps in base.links.items()
                    if src in changes for dep in deps})
    return changes


def _interpolations(cfg: Any, prefix: str = "") -> list[tuple[str, str | None]]:
    """(key, the absolute key it copies, or None for any other expression) of every
    interpolation in a composed config."""
    from omegaconf import OmegaConf

    out: list[tuple[str, str | None]] = []
    for name in cfg:
        key = f"{prefix}{name}"
        if OmegaConf.is_interpolation(cfg, name):
            text = str(cfg._get_node(name)._value())
            m = re.fullmatch(r"\$\{(\.*)([A-Za-z_][\w.]*)\}", text)
            if m is None:
                out.append((key, None))
                continue
            dots, target = m.groups()
            parents = key.split(".")[:-1]
            if dots:  # relative: one dot is the node's own container, each more one up
                parents = parents[: len(parents) - (len(dots) - 1)]
            else:
                parents = []
            out.append((key, ".".join([*parents, target])))
        elif OmegaConf.is_dict(cfg._get_node(name)):
            out += _interpolations(cfg._get_node(name), f"{key}.")
    return out


def _referenced(cfg: Any, key: str) -> str:
    """The raw text of an interpolation (to see which keys it mentions)."""
    node = cfg
    *path, name = key.split(".")
    for part in path:
        node = node._get_node(part)
    return str(node._get_node(name)._value())


def interpolations(cfg: Any) -> list[tuple[str, str | None, str]]:
    """(key, the key it copies or None for another expression, its text) of every
    interpolation in a composed config: the keys that follow a key a sweep or a scene
    family varies (creatio.scenes.family)."""
    return [(key, source, _referenced(cfg, key)) for key, source in _interpolations(cfg)]


def study_links(study: str) -> tuple[tuple[str, str | None, str], ...]:
    """:func:`interpolations` of a study's default config, composed once per process (a
    composition costs 0.1-0.3 s: a warm worker composes EN-02's before it forks its jobs,
    creatio.pipeline.config.composed)."""
    from creatio.pipeline.config import composed

    return tuple(interpolations(composed(study)))


def _point_key(obj: Any) -> str:
    """Identity of a point: sha256 of its config tree as canonical JSON."""
    from creatio.pipeline.config import plain

    text = json.dumps(plain(obj), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _code() -> str:
    """The version of the code that computes a point (the dataset rules' ``code``)."""
    from creatio.pipeline.code import code_version

    return code_version("datasets")


def _batch_code(path: str | Path) -> str | None:
    """The code version a batch file was computed with (None: unreadable or unrecorded)."""
    import xarray as xr

    try:
        check_regular(path)
        with xr.open_dataset(path, engine="netcdf4") as ds:
            return ds.attrs.get("code_version")
    except Exception:  # noqa: BLE001 - a batch being written or damaged: not current
        return None


def _known_points(plan: SweepPlan, code: str) -> dict[str, dict[str, Any]]:
    """Rows of this study's points already computed by any sweep with the same code
    (point key -> row); a batch of other code, or of none recorded, is never a source."""
    import xarray as xr

    rows: dict[str, dict[str, Any]] = {}
    for path in Path(plan.outdir).parent.glob("*/batches/*.nc"):
        try:
            check_regular(path)
            with xr.open_dataset(path, engine="netcdf4") as ds:
                if ds.attrs.get("study") != plan.study or ds.attrs.get("code_version") != code:
                    continue
                table = {name: ds[name].values for name in ds.data_vars}
        except Exception:  # noqa: BLE001 - a batch being written or damaged: not a source
            continue
        for i, key in enumerate(table.get("point_key", [])):
            if str(table["status"][i]) not in ("invalid", "failed") and str(key):
                rows[str(key)] = {name: col[i].item() if hasattr(col[i], "item") else col[i]
                                  for name, col in table.items()}
    return rows


def _run_point(entry: registry.Study, obj: Any) -> dict[str, Any]:
    """Run the study's first dataset part for one config and return its summary row."""
    from creatio.reports import summary

    part = entry.parts(obj)[0]
    ds = entry.run_function()(obj, **part.args)
    ds.attrs["study"] = entry.id
    checks = ""
    if entry.kind is registry.SPHERE:  # absurd own checks: status checks_failed, with why
        from creatio.pipeline.checks import dataset_problems

        checks = "; ".join(dataset_problems(ds))
    row = {k: v for k, v in summary(ds).items()
           if isinstance(v, int | float | str) and not isinstance(v, bool)}
    if checks:
        row.update(status="checks_failed",
                   message=f"{checks} (the run's own status: {row.get('status', '?')})")
    return row


def _sphere_extras(obj: Any, changes: dict[str, Any], base: Any) -> dict[str, float]:
    """A sphere point's dt and the stability limit of its config (a refused point's with
    the refusal lifted, to show how far beyond it lies)."""
    from creatio.studies.schema import vary

    cfg = obj
    try:
        if cfg is None:
            cfg = vary(base, {**changes, "solver.allow_unstable": True})
        return {"stability_limit_dt_s": float(cfg.step_limit()), "dt_s": float(cfg.solver.dt)}
    except Exception:  # noqa: BLE001 - no limit for a config that cannot be built
        return {"stability_limit_dt_s": math.nan, "dt_s": math.nan}


def _failure(e: Exception) -> str:
    """A point's failure as one line (what and where), as the command line words it."""
    import traceback

    first = str(e).splitlines()[0] if str(e) else ""
    frame = traceback.extract_tb(e.__traceback__)[-1] if e.__traceback__ else None
    where = f" at {Path(frame.filename).name}:{frame.lineno}" if frame else ""
    return f"{type(e).__name__}: {first}{where}"


def run_batch(plan: SweepPlan, k: int, out: str | Path | None = None,
              progress: Callable[[str], None] | None = None) -> Path:
    """Compute batch k: each point's summary row (reused when known to the same code),
    written atomically."""
    import numpy as np
    import xarray as xr

    from creatio.pipeline.provenance import provenance
    from creatio.store.netcdf import write_dataset
    from creatio.studies.schema import vary

    say = progress or log.info
    entry = registry.get(plan.study)
    sphere = entry.kind is registry.SPHERE
    base = _base(plan)
    code = _code()
    known = _known_points(plan, code)
    indices = list(plan.batch_range(k))
    rows: list[dict[str, Any]] = []
    counts = {"computed": 0, "reused": 0, "refused": 0, "failed": 0}
    compute_s = 0.0
    t0 = last = time.perf_counter()
    for done, index in enumerate(indices, start=1):
        changes = point_changes(plan, base, index)
        try:
            obj = vary(base.obj, changes)
        except ConfigError as e:
            row: dict[str, Any] = {"status": "invalid", "message": str(e), "point_key": ""}
            counts["refused"] += 1
            obj = None
        else:
            key = _point_key(obj)
            if key in known:
                row = dict(known[key])
                counts["reused"] += 1
            else:
                tc = time.perf_counter()
                try:
                    row = {"status": "ok", "message": "", **plan.row(entry, obj),
                           "point_key": key}
                except Exception as e:  # noqa: BLE001 - one point's failure is its row
                    from creatio.errors import interrupted

                    if interrupted(e):  # Ctrl-C inside the compiled loop: stop the batch
                        raise KeyboardInterrupt from e
                    row = {"status": "failed", "message": _failure(e), "point_key": ""}
                    say(f"sweep {plan.name}: point {index} {list(plan.overrides(index))} "
                        f"failed: {row['message']}")
                    counts["failed"] += 1
                else:
                    counts["computed"] += 1
                compute_s += time.perf_counter() - tc
        if sphere and "dt_s" not in row:
            row.update(_sphere_extras(obj, changes, base.obj))
        row["point"] = index
        rows.append(row)
        now = time.perf_counter()
        if now - last > 2.0 or done == len(indices):
            rate = done / max(now - t0, 1e-9)
            say(f"sweep {plan.name} batch {k + 1}/{plan.n_batches}: {done}/{len(indices)} "
                f"points, {rate:.1f}/s, ETA {(len(indices) - done) / rate:.0f} s "
                f"({counts['computed']} computed, {counts['reused']} reused, "
                f"{counts['refused']} refused, {counts['failed']} failed)")
            last = now
    names = sorted({n for r in rows for n, v in r.items()
                    if n != "point" and isinstance(v, int | float) and not isinstance(v, bool)})
    data: dict[str, Any] = {
        name: ("point", np.array([float(r.get(name, math.nan)) for r in rows]))
        for name in names}
    for name in ("status", "message", "point_key", "study"):
        data[name] = ("point", np.array([str(r.get(name, "")) for r in rows], dtype=object))
    ds = xr.Dataset(data, coords={"point": ("point", np.array(indices, dtype=np.int64))})
    spec = json.dumps(plan.spec(), sort_keys=True)
    ds.attrs = {**provenance(plan.study, spec, hashlib.sha256(spec.encode()).hexdigest(),
                             f"sweep {plan.name} batch {k}"),
                "batch": k, "batch_size": plan.batch_size, "code_version": code, **counts,
                "compute_s": compute_s, "wall_s": time.perf_counter() - t0}
    target = Path(out) if out is not None else Path(plan.batch_file(k))
    return write_dataset(ds, target)


# ----------------------------------------------------------------------------- aggregate
def _coordinate(key: str, values: Sequence[str]) -> list[Any]:
    """An axis's values as its coordinate: numbers, or the strings the points got (a quoted
    Hydra string without its quotes)."""
    try:
        return [float(v) for v in values]
    except ValueError:
        from hydra.core.override_parser.overrides_parser import OverridesParser

        parser = OverridesParser.create()
        return [str(parser.parse_override(f"{key}={v}").value()) for v in values]


def aggregate(plan: SweepPlan):
    """One dataset: a dimension per swept key, each scalar summary figure as a variable."""
    import numpy as np
    import xarray as xr

    shape = plan.shape
    dims = [k.replace(".", "__") for k, _ in plan.axes]
    figures: dict[str, Any] = {}
    status = np.full(shape, "", dtype=object)
    message = np.full(shape, "", dtype=object)
    run = 0
    for path in plan.batches:
        check_regular(path)
        with xr.open_dataset(path, engine="netcdf4") as ds:
            flat = ds.point.values
            for name in ds.data_vars:
                col = ds[name].values
                if name in ("status", "message", "point_key", "study"):
                    continue
                arr = figures.setdefault(name, np.full(plan.n_points, np.nan))
                arr[flat] = col.astype(float)
            status.flat[flat] = [str(s) for s in ds.status.values]
            message.flat[flat] = [str(m) for m in ds.message.values]
            run += int(np.sum(ds.status.values != "invalid"))
    data: dict[str, Any] = {
        name: (dims, arr.reshape(shape)) for name, arr in sorted(figures.items())}
    for name in ("stability_limit_dt_s", "dt_s"):
        if name in data:
            data[name] = (dims, data[name][1], {"units": "s"})
    data["status"] = (dims, status.astype(str))
    data["message"] = (dims, message.astype(str),
                       {"long_name": "why a point was refused (empty when it ran)"})
    coords = {d: (d, _coordinate(k, v), {"long_name": k})
              for d, (k, v) in zip(dims, plan.axes, strict=True)}
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "title": f"sweep of {plan.study} over {', '.join(k for k, _ in plan.axes)}",
        "study": plan.study,
        "sweep": json.dumps([[k, list(v)] for k, v in plan.axes]),
        "base_overrides": json.dumps(list(plan.base)),
        "points": plan.n_points,
        "points_run": run,
        "batches": plan.n_batches,
    })
    return ds


def write_sweep(plan: SweepPlan, compute_missing: bool = False) -> dict[str, Path]:
    """Aggregate, then write sweep.nc, a markdown table and one figure per summary figure.

    ``compute_missing`` runs the batches whose files are absent, or were computed by other
    code, first, in this process (`creatio run -m`, outside Snakemake).
    """
    from creatio.pipeline.index import record_sweep, refresh_index
    from creatio.pipeline.provenance import provenance
    from creatio.reports.sweep import report_paths, write_sweep_report
    from creatio.store.forked import run_all
    from creatio.store.netcdf import write_dataset

    if compute_missing:
        for k in range(plan.n_batches):
            if _batch_code(plan.batch_file(k)) != _code():
                run_batch(plan, k)
    ds = aggregate(plan)
    spec = json.dumps(plan.spec(), sort_keys=True)
    attrs = provenance(plan.study, spec, hashlib.sha256(spec.encode()).hexdigest(),
                       ds.attrs["title"])
    ds.attrs = {**attrs, **ds.attrs}
    outdir = Path(plan.outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    # the table and figure (most of the time) drawn in a forked child where a core is free,
    # while this process writes the dataset and the record (creatio.store.forked)
    paths = {"nc": outdir / "sweep.nc", **report_paths(outdir)}
    run_all([lambda: write_sweep_report(ds, outdir),
             lambda: write_dataset(ds, paths["nc"])])
    paths["record"] = record_sweep(outdir, plan.study, plan.axes, plan.base,
                                   int(ds.attrs["points"]), int(ds.attrs["points_run"]))
    if compute_missing:  # outside Snakemake (creatio run -m): no workflow hook lists it
        refresh_index(Path(plan.outdir).parents[1])
    return paths
