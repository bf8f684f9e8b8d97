"""Parameter sweeps in batches: a Cartesian product of values, a few jobs, one aggregate.

A sweep is a study, a list of Hydra sweep overrides (``sphere.mu=0,0.05,0.15``, also
``range(...)`` and the rest of Hydra's sweep grammar) and base overrides applied to every
point. Planning costs nothing per point: the product is cut into batches of consecutive
points, one job each (``batch_size``; by default about eight batches, at most 250 points
each). A batch job composes the base config once and varies it per point
(creatio.studies.schema.vary: a validated copy, no Hydra), runs the study's first dataset
part in the same process and keeps each point's summary figures as a row of its batch file.

Points are identified by their resolved config: a point that any earlier sweep of the study
computed is taken from that sweep's batch files instead of being run again, so rerunning a
sweep with more points computes only the new ones. A point refused by validation (an
unstable dt, an amplitude too large) is recorded with its reason, as a run that stopped early
keeps its status; neither aborts the rest. The aggregate fills one array per summary figure
from the batch files, never holding the points' datasets.
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
from creatio.studies import registry

__all__ = [
    "MAX_POINTS",
    "SweepPlan",
    "aggregate",
    "interpolations",
    "parse_axes",
    "plan_sweep",
    "run_batch",
    "write_sweep",
]

log = logging.getLogger("creatio")

#: Largest sweep planned without asking (its aggregate holds one float per point and figure).
MAX_POINTS = 200_000
#: Default batching: about this many batches, each at most MAX_BATCH points.
TARGET_BATCHES = 8
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
        """Flat indices (row-major over the axes) of the points of batch k."""
        return range(k * self.batch_size, min((k + 1) * self.batch_size, self.n_points))

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
        args += [f"--sweep {shlex.quote(f'{k}=' + ','.join(v))}" for k, v in self.axes]
        args += [f"--override {shlex.quote(o)}" for o in self.base]
        args.append(f"--batch-size {self.batch_size}")
        return " ".join(args)


def _unravel(index: int, shape: Sequence[int]) -> tuple[int, ...]:
    out = []
    for n in reversed(shape):
        index, i = divmod(index, n)
        out.append(i)
    return tuple(reversed(out))


def parse_axes(sweep: Sequence[str]) -> list[tuple[str, list[str]]]:
    """Split sweep overrides into (key, values) with Hydra's override grammar."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    parser = OverridesParser.create()
    axes = []
    for text in sweep:
        try:
            (ov,) = parser.parse_overrides([str(text)])
        except Exception as e:  # noqa: BLE001 - Hydra's grammar errors, re-worded
            raise ConfigError("sweep", text, str(e).splitlines()[0]) from None
        key = ov.get_key_element()
        try:
            values = list(ov.sweep_string_iterator()) if ov.is_sweep_override() else [
                ov.get_value_element_as_str()]
        except Exception as e:  # noqa: BLE001 - a range Hydra cannot expand (step 0, ...)
            raise ConfigError("sweep", text, f"cannot be expanded: {e}") from None
        if not values:
            raise ConfigError("sweep", text, "sweeps over no value")
        if key in [k for k, _ in axes]:
            raise ConfigError("sweep", text, f"key {key} is swept twice")
        axes.append((key, values))
    if not axes:
        raise ConfigError("sweep", list(sweep), "needs at least one KEY=V1,V2,... entry")
    return axes


def plan_sweep(
    study: str, sweep: Sequence[str], base: Sequence[str] = (), data_dir: str = "data",
    batch_size: int | None = None, max_points: int = MAX_POINTS,
) -> SweepPlan:
    """Plan a sweep: its axes, batches and outputs. Nothing is composed per point.

    Refused up front: an unknown study or key, an empty or duplicated axis, a base config
    that no point could repair (the first point checked in full), and a product larger than
    max_points (with its size and what to do).
    """
    from creatio.pipeline.config import applicable, resolve

    if not study:
        raise ConfigError("study", study, "a sweep needs the study to sweep (study=en02)")
    if study not in registry.STUDIES:
        raise ConfigError("study", study, f"must be one of {', '.join(registry.STUDIES)}")
    axes = parse_axes(sweep)
    base = tuple(str(o) for o in base)
    for key, values in axes:
        if not applicable(study, [f"{key}={values[0]}"]):
            raise ConfigError(key, values[0], f"unknown key (not in {study}'s config)")
    n = math.prod(len(v) for _, v in axes)
    if n > max_points:
        raise ConfigError("sweep", f"{n:,} points", f"exceeds {max_points:,} points (the "
                          "aggregate keeps a float per point and figure): split it into "
                          "several sweeps, or raise the limit with --config "
                          f"sweep_max_points={n}")
    if batch_size is None:
        batch_size = min(MAX_BATCH, max(1, math.ceil(n / TARGET_BATCHES)))
    if not (isinstance(batch_size, int) and batch_size >= 1):
        raise ConfigError("sweep_batch", batch_size, "must be a positive integer")
    spec = json.dumps({"study": study, "axes": axes, "base": base}, sort_keys=True)
    name = f"{study}-{hashlib.sha256(spec.encode()).hexdigest()[:12]}"
    plan = SweepPlan(study, tuple((k, tuple(v)) for k, v in axes), base, name,
                     f"{data_dir}/sweeps/{name}", batch_size)
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
    from hydra.core.override_parser.overrides_parser import OverridesParser

    from creatio.pipeline.config import compose, override_error, validate

    try:
        cfg = compose(plan.study, list(plan.base))
    except Exception as e:  # noqa: BLE001 - Hydra refused a base override
        raise override_error(plan.study, list(plan.base), e) from None
    obj = validate(cfg, check=False).obj
    parser = OverridesParser.create()
    values = tuple(
        (key, tuple(parser.parse_override(f"{key}={v}").value() for v in vals))
        for key, vals in plan.axes)
    links: dict[str, list[str]] = {}
    for key, source in _interpolations(cfg):
        if source is None:
            if any(k in _referenced(cfg, key) for k, _ in plan.axes):
                raise ConfigError(key, "(interpolation)", "follows a swept key through an "
                                  "expression a sweep cannot vary: sweep it too")
            continue
        links.setdefault(source, []).append(key)
    return _Base(obj, values, {k: tuple(v) for k, v in links.items()})


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


def _point_key(obj: Any) -> str:
    """Identity of a point: sha256 of its config tree as canonical JSON."""
    from creatio.pipeline.config import plain

    text = json.dumps(plain(obj), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _known_points(plan: SweepPlan) -> dict[str, dict[str, Any]]:
    """Rows of this study's points already computed by any sweep (point key -> row)."""
    import xarray as xr

    rows: dict[str, dict[str, Any]] = {}
    for path in Path(plan.outdir).parent.glob("*/batches/*.nc"):
        try:
            with xr.open_dataset(path, engine="netcdf4") as ds:
                if ds.attrs.get("study") != plan.study:
                    continue
                table = {name: ds[name].values for name in ds.data_vars}
        except Exception:  # noqa: BLE001 - a batch being written or damaged: not a source
            continue
        for i, key in enumerate(table.get("point_key", [])):
            if str(table["status"][i]) != "invalid":
                rows[str(key)] = {name: col[i].item() if hasattr(col[i], "item") else col[i]
                                  for name, col in table.items()}
    return rows


def _run_point(entry: registry.Study, obj: Any) -> dict[str, Any]:
    """Run the study's first dataset part for one config and return its summary row."""
    from creatio.reports import summary

    part = entry.parts(obj)[0]
    ds = entry.run_function()(obj, **part.args)
    ds.attrs["study"] = entry.id
    return {k: v for k, v in summary(ds).items()
            if isinstance(v, int | float | str) and not isinstance(v, bool)}


def _sphere_extras(obj: Any, changes: dict[str, Any], base: Any) -> dict[str, float]:
    """A sphere point's dt and the stability limit of its config (a refused point's with
    the refusal lifted, to show how far beyond it lies)."""
    from creatio.studies.schema import vary

    cfg = obj
    if cfg is None:
        try:
            cfg = vary(base, {**changes, "solver.allow_unstable": True})
        except ConfigError:
            return {"stability_limit_dt_s": math.nan, "dt_s": math.nan}
    return {"stability_limit_dt_s": float(cfg.step_limit()), "dt_s": float(cfg.solver.dt)}


def run_batch(plan: SweepPlan, k: int, out: str | Path | None = None,
              progress: Callable[[str], None] | None = None) -> Path:
    """Compute batch k: each point's summary row (reused when known), written atomically."""
    import numpy as np
    import xarray as xr

    from creatio.pipeline.io import provenance, write_dataset
    from creatio.studies.schema import vary

    say = progress or log.info
    entry = registry.get(plan.study)
    sphere = entry.kind is registry.SPHERE
    base = _base(plan)
    known = _known_points(plan)
    indices = list(plan.batch_range(k))
    rows: list[dict[str, Any]] = []
    counts = {"computed": 0, "reused": 0, "refused": 0}
    compute_s = 0.0
    t0 = last = time.perf_counter()
    for done, index in enumerate(indices, start=1):
        idx = plan.indices(index)
        changes = {key: vals[i] for (key, vals), i in zip(base.values, idx, strict=True)}
        changes.update({dep: changes[src] for src, deps in base.links.items()
                        if src in changes for dep in deps})
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
                row = {"status": "ok", **plan.row(entry, obj), "message": "",
                       "point_key": key}
                compute_s += time.perf_counter() - tc
                counts["computed"] += 1
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
                f"{counts['refused']} refused)")
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
                "batch": k, "batch_size": plan.batch_size, **counts,
                "compute_s": compute_s, "wall_s": time.perf_counter() - t0}
    target = Path(out) if out is not None else Path(plan.batch_file(k))
    return write_dataset(ds, target)


# ----------------------------------------------------------------------------- aggregate
def _coordinate(values: Sequence[str]) -> list[Any]:
    try:
        return [float(v) for v in values]
    except ValueError:
        return list(values)


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
    coords = {d: (d, _coordinate(v), {"long_name": k})
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

    ``compute_missing`` runs the batches whose files are absent first, in this process
    (`creatio run -m`, outside Snakemake).
    """
    from creatio.pipeline.index import record_sweep, refresh_index
    from creatio.pipeline.io import provenance, write_dataset
    from creatio.reports.sweep import write_sweep_report

    if compute_missing:
        for k in range(plan.n_batches):
            if not Path(plan.batch_file(k)).is_file():
                run_batch(plan, k)
    ds = aggregate(plan)
    spec = json.dumps(plan.spec(), sort_keys=True)
    attrs = provenance(plan.study, spec, hashlib.sha256(spec.encode()).hexdigest(),
                       ds.attrs["title"])
    ds.attrs = {**attrs, **ds.attrs}
    outdir = Path(plan.outdir)
    paths = {"nc": write_dataset(ds, outdir / "sweep.nc")}
    paths.update(write_sweep_report(ds, outdir))
    paths["record"] = record_sweep(outdir, plan.study, plan.axes, plan.base,
                                   int(ds.attrs["points"]), int(ds.attrs["points_run"]))
    if compute_missing:  # outside Snakemake (creatio run -m): no workflow hook lists it
        refresh_index(Path(plan.outdir).parents[1])
    return paths
