"""Sweeps over an explicit list of points (a Sobol' design), through the sweep machinery; EN-05's
sample planned on it.

A :class:`PointPlan` is a :class:`~creatio.pipeline.sweep.SweepPlan` whose axes are zipped:
point i takes the i-th value of every axis instead of one combination of the product. Its
batches run by :func:`creatio.pipeline.sweep.run_batch` (the base config composed once, each
point a validated variation, every point keyed by its resolved-config hash and reused from
any earlier batch of the same point store, a refused point recorded with its reason), so a
sample runs as a few local or SLURM jobs like any sweep. Each row keeps the study's summary
and the figures of the plan's ``figures`` function. Batches are
``data/sweeps/<store>/<name>/batches/p<size>-<k>.nc``: a store of its own, so that rows
made with other figures (an ordinary sweep's) are never reused where these are needed.

EN-05's sample (:func:`en05_sample`): the Sobol' design of the largest base size N over the
inputs of ``uncertainty``, run on EN-02 as bases.en02 with study.sensitivity.overrides on
top. Planning it needs no design (N (d + 2) points); a batch job computes the design
(SALib, seeded: the same on every machine) and runs its slice.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError
from creatio.pipeline.config import Resolved, compose, resolve
from creatio.pipeline.planning import one_line_errors
from creatio.pipeline.sweep import MAX_BATCH, TARGET_BATCHES, SweepPlan, _interpolations, run_batch
from creatio.store.regular import check_regular, read_text
from creatio.studies import registry

__all__ = ["En05Runs", "En05Sample", "PointPlan", "collect", "en05_sample", "main",
           "sobol_dataset"]

log = logging.getLogger("creatio")

#: Where EN-05's points live (a point store: their rows carry EN-05's outputs).
EN05_STORE = "en05"


@dataclass(frozen=True)
class PointPlan(SweepPlan):
    """A sweep over listed points: axis k holds the k-th coordinate of every point (all
    axes the same length), and each row adds ``figures(dataset, config)`` ("module:name")
    to the study's summary."""

    figures: str = ""

    @property
    def shape(self) -> tuple[int, ...]:
        """One dimension: the points."""
        return (len(self.axes[0][1]),)

    def indices(self, index: int) -> tuple[int, ...]:
        """Point `index` takes value `index` of every axis."""
        return (index,) * len(self.axes)

    def row(self, entry: registry.Study, obj: Any) -> dict[str, Any]:
        """The study's first dataset part for one point: its summary and the plan's figures."""
        from creatio.reports import summary

        part = entry.parts(obj)[0]
        ds = entry.run_function()(obj, **part.args)
        ds.attrs["study"] = entry.id
        row = {k: v for k, v in summary(ds).items()
               if isinstance(v, int | float | str) and not isinstance(v, bool)}
        if self.figures:
            module, _, name = self.figures.partition(":")
            import importlib

            row.update(getattr(importlib.import_module(module), name)(ds, obj))
        return row

    def batch_file(self, k: int) -> str:
        """Path of batch k's rows (p: listed points)."""
        return f"{self.outdir}/batches/p{self.batch_size}-{k:05d}.nc"

    def cli_args(self) -> str:
        """A point list does not travel on a command line: its jobs rebuild it from config."""
        raise NotImplementedError("a PointPlan's batch jobs rebuild it from its config")


def collect(plan: SweepPlan, names: Sequence[str]) -> dict[str, Any]:
    """The columns ``names`` (and status, message) of every point, in point order, from the
    plan's batch files (NaN where a row lacks a figure)."""
    import numpy as np
    import xarray as xr

    n = plan.n_points
    out: dict[str, Any] = {name: np.full(n, np.nan) for name in names}
    out["status"] = np.full(n, "", dtype=object)
    out["message"] = np.full(n, "", dtype=object)
    seen = np.zeros(n, dtype=bool)
    for path in plan.batches:
        check_regular(path)
        with xr.open_dataset(path, engine="netcdf4") as ds:
            idx = ds.point.values.astype(np.int64)
            seen[idx] = True
            for name in names:
                if name in ds:
                    out[name][idx] = ds[name].values.astype(float)
            out["status"][idx] = [str(s) for s in ds.status.values]
            out["message"][idx] = [str(m) for m in ds.message.values]
    if not seen.all():
        raise ValueError(f"{int(np.sum(~seen))} points of {plan.name} are in no batch file")
    return out


# ----------------------------------------------------------------------------- EN-05
def _format(value: Any) -> str:
    """A resolved config value as a Hydra override value."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, list):
        return "[" + ",".join(_format(v) for v in value) + "]"
    return str(value)


def _leaves(data: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(data, dict):
        out: dict[str, Any] = {}
        for k, v in data.items():
            out.update(_leaves(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: data}


def base_overrides(resolved: Resolved) -> list[str]:
    """Overrides that turn EN-02's default config into EN-05's bases.en02 (keys that follow
    another by interpolation left to follow it), then study.sensitivity.overrides."""
    study = resolved.obj.uncertainty.study
    default = _leaves(resolve(study).data)
    base = _leaves(resolved.data["bases"][study])
    following = {key for key, _ in _interpolations(compose(study))}
    diff = [f"{k}={_format(v)}" for k, v in sorted(base.items())
            if k not in following and default.get(k) != v]
    return [*diff, *resolved.obj.study.sensitivity.overrides]


@dataclass(frozen=True)
class En05Sample:
    """EN-05's Sobol' sample as the workflow plans it: its point store, size and batches
    (no design needed), and the config that rebuilds its :class:`PointPlan`."""

    resolved: Resolved
    name: str
    outdir: str
    n_points: int
    batch_size: int
    base: tuple[str, ...]

    @property
    def n_batches(self) -> int:
        """Batch jobs of the sample."""
        return math.ceil(self.n_points / self.batch_size)

    @property
    def batches(self) -> list[str]:
        """Every batch file."""
        return [f"{self.outdir}/batches/p{self.batch_size}-{k:05d}.nc"
                for k in range(self.n_batches)]

    def plan(self) -> PointPlan:
        """The full plan: the design (SALib) as the axes' values."""
        from creatio.studies.en05 import sobol_design, to_inputs

        cfg = self.resolved.obj
        sens, unc = cfg.study.sensitivity, cfg.uncertainty
        X = to_inputs(unc.distributions,
                      sobol_design(unc.names, max(sens.base_sizes), sens.seed))
        axes = tuple((d.key, tuple(repr(float(x)) for x in X[:, j]))
                     for j, d in enumerate(unc.distributions))
        return PointPlan(unc.study, axes, self.base, self.name, self.outdir, self.batch_size,
                         figures="creatio.studies.en05:point_outputs")


def en05_sample(resolved: Resolved, data_dir: str = "data") -> En05Sample:
    """Plan EN-05's sample: N_max (d + 2) points of EN-02, named by what defines them (the
    base overrides, the inputs, N_max and the seed)."""
    cfg = resolved.obj
    sens, unc = cfg.study.sensitivity, cfg.uncertainty
    n = max(sens.base_sizes) * (len(unc.inputs) + 2)
    base = tuple(base_overrides(resolved))
    spec = json.dumps({"study": unc.study, "base": list(base),
                       "inputs": resolved.data["uncertainty"]["inputs"],
                       "N": max(sens.base_sizes), "seed": sens.seed}, sort_keys=True)
    name = f"{unc.study}-{hashlib.sha256(spec.encode()).hexdigest()[:12]}"
    size = sens.batch_size or min(MAX_BATCH, max(1, math.ceil(n / TARGET_BATCHES)))
    return En05Sample(resolved, name, f"{data_dir}/sweeps/{EN05_STORE}/{name}", n, size, base)


def sobol_dataset(resolved: Resolved, sample: En05Sample | None = None,
                  compute_missing: bool = False) -> Any:
    """EN-05's Sobol' dataset from the sample's batch files (computing absent ones first in
    this process with compute_missing), with the provenance of the EN-05 config."""
    from creatio.pipeline.provenance import provenance
    from creatio.studies import en05

    sample = sample or en05_sample(resolved)
    plan = sample.plan()
    if compute_missing:
        for k in range(plan.n_batches):
            if not Path(plan.batch_file(k)).is_file():
                run_batch(plan, k)
    rows = collect(plan, list(en05.OUTPUTS))
    ds = en05.sobol_dataset(resolved.obj, rows)
    ds.attrs["point_store"] = plan.outdir
    ds.attrs["sample_base_overrides"] = " ".join(plan.base)
    title = "EN-05 Sobol' indices of EN-02's outputs"
    ds.attrs = {**provenance(resolved.id, resolved.yaml, resolved.sha256, title), **ds.attrs}
    return ds


def run_study_sample(resolved: Resolved, root: Path) -> list[Path]:
    """`creatio run study=en05`: the sample's batches in this process, then its dataset."""
    from creatio.store.netcdf import write_dataset

    out = Path(resolved.entry.dataset_dir(str(root))) / "en05_sobol.nc"
    return [write_dataset(sobol_dataset(resolved, compute_missing=True), out)]


# ---------------------------------------------------------------------------- workflow
class En05Runs:
    """EN-05 in one workflow invocation (workflows/rules/en05.smk): its config under the
    overrides, its sample, and every file `snakemake en05` makes. Planned on first use."""

    def __init__(self, jobs: Any, overrides: Any, data_dir: str = "data") -> None:
        from creatio.pipeline.planning import StudyRuns

        self.runs = StudyRuns(jobs, overrides, ["en05"])
        self.data_dir = data_dir
        self._samples: dict[str, tuple[str, En05Sample]] = {}

    def fallback(self) -> None:
        """Plan EN-05 for a job re-invoked alone (a `run:` job, a cluster job), which parses
        the workflow anew without its targets; overrides EN-05 does not have mean the job
        is not one of EN-05's, and another planner finds it."""
        try:
            self.runs.plans  # noqa: B018 - planning registers the job configs
        except ConfigError:
            pass

    def _plan(self) -> dict[str, tuple[str, En05Sample]]:
        if not self._samples:
            for p in self.runs.plans.values():
                s = en05_sample(p.resolved, self.data_dir)
                self._samples.setdefault(p.root, (s.name, s))
                print(f"creatio: en05 sample {s.name}: {s.n_points} points in {s.n_batches} "
                      f"batch(es) of {s.batch_size} -> {s.outdir}", file=sys.stderr)
        return self._samples

    @one_line_errors
    def targets(self) -> list[str]:
        """The datasets, the Sobol' dataset, the reports, and the example's calibration."""
        self._plan()
        out = []
        for p in self.runs.plans.values():
            out += [*p.datasets, f"{p.root}/studies/en05/en05_sobol.nc", *p.reports]
        return out + [f"{self.data_dir}/calibration/en02_example/calibration.{ext}"
                      for ext in ("nc", "json", "md", "png")]

    @one_line_errors
    def sample(self, name: str) -> Any:
        """The sample called name, with the config file its batch jobs read."""
        for root, (n, s) in self._plan().items():
            if n == name:
                return _SampleJob(s, f"{root}/configs/en05.yaml")
        raise ConfigError("sample", name, "no EN-05 configuration of this invocation has it")

    @one_line_errors
    def batches(self, root: str) -> list[str]:
        """The batch files of the sample of the config under root."""
        samples = self._plan()
        if root not in samples:
            raise ConfigError("output", f"{root}/studies/en05/en05_sobol.nc",
                              "no EN-05 configuration of this invocation writes there")
        return samples[root][1].batches


@dataclass(frozen=True)
class _SampleJob:
    sample: En05Sample
    config_file: str


# ------------------------------------------------------------------------------- tasks
def _config(path: Path) -> Resolved:
    """The resolved EN-05 config of a config file (what the workflow writes)."""
    from creatio.pipeline.config import validate
    from creatio.store.yamlio import load_yaml

    resolved = validate(load_yaml(read_text(path)))
    if resolved.id != "en05":
        raise ConfigError("--config-file", str(path), f"holds study {resolved.id}, not en05")
    return resolved


def main(argv: Sequence[str], say: Callable[[str], None] | None = None) -> int:
    """`creatio task en05 batch|sobol|track ...`: one step of EN-05 as its rules call it."""
    from creatio.errors import Parser

    ap = Parser(prog="creatio task en05", description="One step of EN-05.")
    sub = ap.add_subparsers(dest="step", required=True)
    b = sub.add_parser("batch", help="compute one batch of the Sobol' sample's points")
    s = sub.add_parser("sobol", help="the Sobol' dataset from the sample's batches")
    t = sub.add_parser("track", help="write the synthetic example track (CSV)")
    for p in (b, s, t):
        p.add_argument("--config-file", type=Path, default=None,
                       help="EN-05's resolved config (default: conf/ with --override)")
        p.add_argument("--override", action="append", default=[], metavar="KEY=VALUE")
        p.add_argument("--out", type=Path, default=None)
    b.add_argument("--batch", type=int, required=True)
    b.add_argument("--batch-size", type=int, default=None,
                   help="the batch size the workflow planned (checked)")
    s.add_argument("--compute-missing", action="store_true",
                   help="run absent batches in this process first")
    args = ap.parse_args(list(argv))
    try:
        resolved = (_config(args.config_file) if args.config_file
                    else resolve("en05", args.override))
        if args.step == "track":
            from creatio.pipeline.calibrate import write_example_track

            path = write_example_track(resolved, args.out)
            log.info("en05: example track %s", path)
            return 0
        sample = en05_sample(resolved)
        if args.step == "batch":
            if args.batch_size is not None and args.batch_size != sample.batch_size:
                raise ConfigError("--batch-size", args.batch_size,
                                  f"the config plans batches of {sample.batch_size}")
            if not 0 <= args.batch < sample.n_batches:
                raise ConfigError("--batch", args.batch,
                                  f"must lie in [0, {sample.n_batches - 1}]")
            run_batch(sample.plan(), args.batch, args.out)
        else:
            from creatio.store.netcdf import write_dataset

            out = args.out or Path("data/studies/en05/en05_sobol.nc")
            write_dataset(sobol_dataset(resolved, sample, args.compute_missing), out)
            log.info("en05: wrote %s", out)
    except ConfigError as e:
        print(f"creatio task en05: {e}", file=sys.stderr)
        return 2
    return 0
