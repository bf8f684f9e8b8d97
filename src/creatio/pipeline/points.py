"""Sweeps over an explicit list of points (a Sobol' design), through the sweep machinery; EN-05's
sample planned on it.

A :class:`PointPlan` is a :class:`~creatio.pipeline.sweep.SweepPlan` whose axes are zipped:
point i takes the i-th value of every axis instead of one combination of the product. Its
batches run by :func:`creatio.pipeline.sweep.run_batch` (the base config composed once, each
point a validated variation, every point keyed by its resolved-config hash and reused from
any earlier batch of the same point store, a refused point recorded with its reason), so a
sample runs as a few local or SLURM jobs like any sweep. Each row is what the plan's
``outputs`` function reads from the point's raw run (EN-05's: its status and outputs, no
EN-02 dataset or summary built per point, which cost a quarter of the run). Batches are
``data/sweeps/<store>/<name>/batches/p<size>-<k>.nc``: a store of its own, so that rows
made with other figures (an ordinary sweep's) are never reused where these are needed.

EN-05's sample (:func:`en05_sample`): the Sobol' design of the largest base size N over the
inputs of ``uncertainty``, run on EN-02 as bases.en02 with study.sensitivity.overrides on
top. Planning it needs no design (N (d + 2) points); a batch job reads the design the
pilot kept in the point store (``design.npz``, under a key of the sample, the code and the
libraries), or computes it (SALib, seeded: the same on every machine), and runs its slice.

Its accuracy budget (study.sensitivity.budget; creatio.studies.budget): numerical error <=
fraction x each output's standard deviation over the sample. A pilot job (:func:`pilot`)
runs a seeded subsample at a ladder of tolerances, from budget.loosest_rtol down to the
overrides' own, against 100x tighter than the latter, and writes the loosest rung that
meets the budget to ``rung.json`` in the point store; every batch job runs its points with
that rung's overrides on top. The step that writes ``en05_sobol.nc`` reruns another seeded
subsample 100x tighter than the rung (creatio.studies.budget.verify) and records the
:class:`~creatio.studies.budget.Verification` in the dataset's attributes; a broken budget
tightens the rung 10x and reruns every point in that step's process (the rare path, said in
its log). An output whose spread over the sample is within the overrides' own relative
tolerance of its size (the final radius: 3e-10 of its 1.11 m), or whose budget even the
overrides' own tolerance misses, has no budget any rung could meet: it is named
``unresolved`` beside the check (its indices are numerical noise), never silently dropped.
budget: null runs every point at the overrides' own tolerances, unchecked (the sample as
before budgets, under the same name).
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError
from creatio.pipeline.config import Resolved, compose, resolve
from creatio.pipeline.planning import one_line_errors
from creatio.pipeline.sweep import (
    SweepPlan,
    _base,
    _interpolations,
    point_changes,
    run_batch,
)
from creatio.store.regular import check_regular, read_text
from creatio.studies import registry
from creatio.studies.budget import Rung, Verification
from creatio.studies.en05_schema import ACCURACY_PREFIX, BudgetConfig

__all__ = ["En05Runs", "En05Sample", "PointPlan", "accuracy", "collect", "en05_sample", "main",
           "pilot", "sobol_dataset", "unresolved"]

log = logging.getLogger("creatio")

#: Where EN-05's points live (a point store: their rows carry EN-05's outputs).
EN05_STORE = "en05"
#: EN-05's default batching (study.sensitivity.batch_size 0): about this many batch jobs,
#: of at most EN05_MAX_BATCH points. A job costs about 3 s before its first point (a fresh
#: interpreter's imports, the compiled loops, the config's checks, the design, the base
#: composed) and a point about 10 ms at the budget's tolerance: few large jobs, one per
#: core for `-c 2` (the study's other parts fill the cores meanwhile).
EN05_BATCHES = 2
EN05_MAX_BATCH = 4096
#: The pilot estimates each output's spread on SPREAD x budget.points points at the
#: loosest rung (cheap), its errors on budget.points.
SPREAD = 8
#: The pilot's choice, in the sample's point store: the batch jobs' input.
RUNG_FILE = "rung.json"
#: How many 10x tightenings a broken budget may take before the dataset says it is broken.
MAX_TIGHTEN = 3
#: The design's input values, in the sample's point store (En05Sample.inputs).
DESIGN_FILE = "design.npz"
#: The designs computed or read in this process (design key -> input values).
_DESIGNS: dict[str, Any] = {}


@dataclass(frozen=True)
class PointPlan(SweepPlan):
    """A sweep over listed points: axis k holds the k-th coordinate of every point (all
    axes the same length), and each row is ``outputs(config)`` ("module:name": the point's
    status and figures from its raw run, no dataset), or the study's summary without it."""

    outputs: str = ""

    @property
    def shape(self) -> tuple[int, ...]:
        """One dimension: the points."""
        return (len(self.axes[0][1]),)

    def indices(self, index: int) -> tuple[int, ...]:
        """Point `index` takes value `index` of every axis."""
        return (index,) * len(self.axes)

    def row(self, entry: registry.Study, obj: Any) -> dict[str, Any]:
        """One point's row: the plan's ``outputs`` of its config (EN-05's: read from the
        run's histories, the EN-02 dataset and its summary never built: 2.8 ms a point, a
        quarter of the run), else the study's summary."""
        if not self.outputs:
            return super().row(entry, obj)
        return _function(self.outputs)(obj)

    def typed_axes(self) -> tuple[tuple[str, tuple[Any, ...]], ...]:
        """Values written as Python writes a float (a design's: ``0.05``, ``1e-05``) are
        that float, as Hydra reads them; any other is parsed by Hydra's grammar. A design of
        4,096 points x 6 inputs took 5.8 s of Hydra parsing per batch job."""
        from hydra.core.override_parser.overrides_parser import OverridesParser

        parser = None
        out = []
        for key, vals in self.axes:
            typed: list[Any] = []
            for v in vals:
                try:
                    x: float | None = float(v)
                except ValueError:
                    x = None
                if x is not None and repr(x) == v:
                    typed.append(x)
                    continue
                parser = parser or OverridesParser.create()
                typed.append(parser.parse_override(f"{key}={v}").value())
            out.append((key, tuple(typed)))
        return tuple(out)

    def batch_file(self, k: int) -> str:
        """Path of batch k's rows (p: listed points)."""
        return f"{self.outdir}/batches/p{self.batch_size}-{k:05d}.nc"

    def cli_args(self) -> str:
        """A point list does not travel on a command line: its jobs rebuild it from config."""
        raise NotImplementedError("a PointPlan's batch jobs rebuild it from its config")


@functools.cache
def _function(path: str) -> Callable[[Any], dict[str, Any]]:
    """The function named "module:name", imported once per process."""
    import importlib

    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


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


def merged_overrides(*groups: Sequence[str]) -> list[str]:
    """Hydra overrides in order, an earlier one of the same key dropped (a rung's
    ``solver.rtol`` replaces the base's): the list a plan composes and records."""
    keyed: dict[str, str] = {}
    for text in (t for group in groups for t in group):
        key = text.partition("=")[0].lstrip("+~")
        keyed.pop(key, None)
        keyed[key] = text
    return list(keyed.values())


@dataclass(frozen=True)
class En05Sample:
    """EN-05's Sobol' sample as the workflow plans it: its point store, size and batches
    (no design needed), the config that rebuilds its :class:`PointPlan`, and its accuracy
    budget (None: none)."""

    resolved: Resolved
    name: str
    outdir: str
    n_points: int
    batch_size: int
    base: tuple[str, ...]
    budget: BudgetConfig | None = None

    @property
    def n_batches(self) -> int:
        """Batch jobs of the sample."""
        return math.ceil(self.n_points / self.batch_size)

    @property
    def batches(self) -> list[str]:
        """Every batch file."""
        return [f"{self.outdir}/batches/p{self.batch_size}-{k:05d}.nc"
                for k in range(self.n_batches)]

    @property
    def rung_file(self) -> str | None:
        """The pilot's choice, which every batch job reads (None: no budget)."""
        return None if self.budget is None else f"{self.outdir}/{RUNG_FILE}"

    def pilot_record(self) -> dict[str, Any]:
        """The pilot's record (:func:`pilot`); refused in one line when it has not run."""
        path = Path(str(self.rung_file))
        if not path.is_file():
            raise ConfigError("study.sensitivity.budget", "on", f"the sample's runs need the "
                              f"pilot's choice {path} first (creatio task en05 pilot; "
                              "snakemake en05 runs it)")
        return json.loads(read_text(path))

    def rung(self) -> Rung | None:
        """The rung the pilot chose (None: no budget, the overrides' own tolerances)."""
        if self.budget is None:
            return None
        r = self.pilot_record()["rung"]
        return Rung(str(r["method"]), float(r["rtol"]), float(r["atol"]))

    @property
    def design_file(self) -> str:
        """Where a job of the sample keeps its design's input values (:meth:`inputs`)."""
        return f"{self.outdir}/{DESIGN_FILE}"

    def _design_key(self) -> str:
        """What the design's values depend on: the sample (its inputs, N and seed), the code
        that computes them and the libraries it calls (read without importing them)."""
        from importlib.metadata import version

        from creatio.pipeline.code import code_version

        spec = {"sample": self.name, "code": code_version("datasets"),
                **{lib: version(lib) for lib in ("SALib", "scipy", "numpy")}}
        return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()

    def inputs(self, keep: bool = False) -> Any:
        """The design's input values (point x input): SALib's seeded sample mapped through
        the distributions, computed once per process, or read from :attr:`design_file`
        when the pilot kept it there under the same key (sample, code, SALib, scipy and
        numpy versions): a batch job then never imports SALib and scipy.stats (1.7 s of its
        3 s start here). keep: write it there (the pilot, once its checks have passed)."""
        import numpy as np

        key = self._design_key()
        path = Path(self.design_file)
        if key not in _DESIGNS and path.is_file():
            check_regular(path)
            try:
                with np.load(path, allow_pickle=False) as f:
                    if str(f["key"]) == key:
                        _DESIGNS[key] = f["X"]
            except (OSError, ValueError, KeyError):  # damaged or another format: computed
                pass
        if key not in _DESIGNS:
            from creatio.studies.en05 import sobol_design, to_inputs

            cfg = self.resolved.obj
            sens, unc = cfg.study.sensitivity, cfg.uncertainty
            _DESIGNS[key] = to_inputs(unc.distributions,
                                      sobol_design(unc.names, max(sens.base_sizes), sens.seed))
        if keep:
            from creatio.store.atomic import atomic_write

            with atomic_write(path, "wb") as fh:
                np.savez(fh, X=_DESIGNS[key], key=np.array(key))
        return _DESIGNS[key]

    def plan(self, rung: Rung | None = None, outdir: str | None = None) -> PointPlan:
        """The full plan: the design (:meth:`inputs`) as the axes' values, run at rung (its
        overrides on top of the base's; None: the base's own), in outdir (default the
        sample's point store)."""
        unc = self.resolved.obj.uncertainty
        X = self.inputs()
        axes = tuple((d.key, tuple(repr(float(x)) for x in X[:, j]))
                     for j, d in enumerate(unc.distributions))
        base = tuple(merged_overrides(self.base, rung.overrides() if rung else ()))
        return PointPlan(unc.study, axes, base, self.name, outdir or self.outdir,
                         self.batch_size, outputs="creatio.studies.en05:point_row")


def en05_sample(resolved: Resolved, data_dir: str = "data") -> En05Sample:
    """Plan EN-05's sample: N_max (d + 2) points of EN-02, named by what defines them (the
    base overrides, the inputs, N_max, the seed and the accuracy budget)."""
    cfg = resolved.obj
    sens, unc = cfg.study.sensitivity, cfg.uncertainty
    n = max(sens.base_sizes) * (len(unc.inputs) + 2)
    base = tuple(base_overrides(resolved))
    spec: dict[str, Any] = {"study": unc.study, "base": list(base),
                            "inputs": resolved.data["uncertainty"]["inputs"],
                            "N": max(sens.base_sizes), "seed": sens.seed}
    if sens.budget is not None:  # none: the name of the sample before budgets
        spec["budget"] = resolved.data["study"]["sensitivity"]["budget"]
    text = json.dumps(spec, sort_keys=True)
    name = f"{unc.study}-{hashlib.sha256(text.encode()).hexdigest()[:12]}"
    size = sens.batch_size or min(EN05_MAX_BATCH, max(1, math.ceil(n / EN05_BATCHES)))
    return En05Sample(resolved, name, f"{data_dir}/sweeps/{EN05_STORE}/{name}", n, size, base,
                      sens.budget)


# ------------------------------------------------------------------------ the budget
class _Runs:
    """Listed points of a sample run in this process at any rung (the pilot's and the
    check's): the base composed once, each (rung, points) computed once."""

    def __init__(self, sample: En05Sample) -> None:
        from creatio.studies.en05 import OUTPUTS

        self.plan = sample.plan()
        self.base = _base(self.plan)
        self.entry = registry.get(self.plan.study)
        self.names = list(OUTPUTS)
        s = self.base.obj.solver
        self.configured = Rung(str(getattr(s.method, "value", s.method)), float(s.rtol),
                               float(s.atol))
        self.adaptive = bool(s.adaptive)
        self.done: dict[tuple[Rung, tuple[int, ...]], dict[str, Any]] = {}

    def __call__(self, rung: Rung, idx: Any) -> dict[str, Any]:
        """The outputs of points idx at rung (NaN where a point is refused or fails)."""
        import numpy as np

        key = (rung, tuple(int(i) for i in idx))
        if key not in self.done:
            cols = {name: np.full(len(key[1]), np.nan) for name in self.names}
            for i, index in enumerate(key[1]):
                row = self._row(rung, index)
                for name in self.names:
                    cols[name][i] = float(row.get(name, math.nan))
            self.done[key] = cols
        return self.done[key]

    def _row(self, rung: Rung, index: int) -> dict[str, Any]:
        from creatio.errors import interrupted
        from creatio.studies.schema import vary

        changes = {**point_changes(self.plan, self.base, index), **rung.changes()}
        try:
            return self.plan.row(self.entry, vary(self.base.obj, changes))
        except Exception as e:  # noqa: BLE001 - a refused or failed point has no outputs
            if interrupted(e):
                raise KeyboardInterrupt from e
            log.info("en05: point %d at %s: %s", index, rung.label(), str(e).splitlines()[0]
                     if str(e) else type(e).__name__)
            return {}


def unresolved(configured: Mapping[str, Any], tight: Mapping[str, Any],
               spread: Mapping[str, Any], budget: Mapping[str, float], rtol: float
               ) -> dict[str, str]:
    """The outputs no rung resolves (name -> why): a spread over the points of ``spread``
    within rtol (the configured tolerance) of the output's size, or a budget that even the
    configured tolerance misses (``configured`` against ``tight``). Their spread is at the
    level of the runs' own numerical error (the final radius: 3e-10 of its 1.11 m), so no
    rung of the ladder could meet a fraction of it and their indices are numerical noise:
    left out of the choice and of the check's verdict, and named beside it."""
    import numpy as np

    from creatio.studies.budget import errors

    err = errors(configured, tight, list(budget))
    out = {}
    for k, b in budget.items():
        v = np.asarray(spread[k], dtype=float)
        v = v[np.isfinite(v)]
        if b <= 0.0 or v.size == 0:
            continue
        sd, size = float(np.std(v)), float(np.max(np.abs(v)))
        if sd <= rtol * size:
            out[k] = (f"its spread {sd:.2g} is within the configured rtol {rtol:.2g} of its "
                      f"size {size:.3g}: numerically constant, its indices are noise")
        elif err[k] > b:
            out[k] = (f"the configured tolerance's own error {err[k]:.2g} exceeds its budget "
                      f"{b:.2g}: its spread is numerical noise")
    return out


def pilot(sample: En05Sample, out: str | Path | None = None) -> Path:
    """Choose the sample's rung (creatio.studies.budget.choose): the loosest of the ladder
    from budget.loosest_rtol down to the configured tolerance whose error on budget.points
    seeded points (seed: study.sensitivity.seed) is within the budget's safety margin,
    against 100x tighter than the configured; written as JSON for the batch jobs."""
    import numpy as np

    from creatio.store.atomic import atomic_write
    from creatio.studies.budget import SAFETY, choose, errors, ladder, sobol_budget, subsample

    b = sample.budget
    if b is None:
        raise ConfigError("study.sensitivity.budget", None, "is off: the sample has no pilot")
    runs = _Runs(sample)
    ref = runs.configured
    if not runs.adaptive:
        raise ConfigError("study.sensitivity.budget", "on", f"needs an adaptive solver in "
                          f"study.sensitivity.overrides ({ref.method} takes fixed steps): "
                          "set study.sensitivity.budget=null")
    seed = sample.resolved.obj.study.sensitivity.seed
    rungs = ladder(ref, b.loosest_rtol)
    idx = subsample(sample.n_points, b.points, seed)
    # the spread: SPREAD x as many points at the loosest rung (an error of a few 1e-3 of it
    # moves a standard deviation by less), since 16 points underestimate a heavy tail's
    spread = runs(rungs[0], subsample(sample.n_points, SPREAD * b.points, seed + 2))
    full = sobol_budget(spread, b.fraction)
    tight = runs(rungs[-1].tighter(), idx)
    noise = unresolved(runs(ref, idx), tight, spread, full, ref.rtol)
    budget = {k: v for k, v in full.items() if k not in noise}
    chosen = choose(runs, rungs, idx, lambda Y: budget)
    tried = []
    for rung in rungs:
        if (rung, tuple(int(i) for i in idx)) not in runs.done:
            continue
        err = errors(runs(rung, idx), tight, list(full))
        ratio = {k: err[k] / v for k, v in budget.items() if v > 0.0}
        worst = max(ratio, key=ratio.__getitem__) if ratio else ""
        tried.append({"rung": asdict(rung), "worst_output": worst,
                      "worst_error_over_budget": ratio.get(worst, 0.0),
                      "error": err})
        log.info("en05 pilot: %s: %s", rung.label(), f"worst {worst}: error "
                 f"{ratio[worst]:.3g} x its budget" if worst else "no budgeted output")
    for k, why in noise.items():
        log.info("en05 pilot: %s unresolved: %s", k, why)
    record = {"rung": asdict(chosen), "configured": asdict(ref),
              "reference": asdict(rungs[-1].tighter()), "fraction": b.fraction,
              "safety": SAFETY, "seed": seed, "points": [int(i) for i in idx],
              "budget": full, "unresolved": noise, "tried": tried,
              "sample": sample.name, "overrides": chosen.overrides()}
    target = Path(out) if out is not None else Path(str(sample.rung_file))
    sample.inputs(keep=True)  # the batch jobs read the design instead of computing it
    with atomic_write(target) as fh:
        fh.write(json.dumps(record, indent=1, sort_keys=True, allow_nan=False) + "\n")
    log.info("en05 pilot: %s on %d points (configured %s) -> %s", chosen.label(),
             int(np.size(idx)), ref.label(), target)
    return target


def _stale(plan: PointPlan, k: int) -> bool:
    """Whether batch k is absent or was computed with other base overrides (another rung)."""
    path = Path(plan.batch_file(k))
    if not path.is_file():
        return True
    import xarray as xr

    check_regular(path)
    with xr.open_dataset(path, engine="netcdf4") as ds:
        base = json.loads(str(ds.attrs.get("config_yaml", "{}"))).get("base")
    return base != list(plan.base)


def _checked(sample: En05Sample, plan: PointPlan, rows: dict[str, Any]
             ) -> tuple[dict[str, Any], Verification, dict[str, Any], PointPlan]:
    """Verify the sample's rows 100x tighter on a seeded subsample (seed + 1: not the
    pilot's) against each output's budget over the whole sample, the pilot's unresolved
    outputs apart (with their observed error, when the check does not find them within
    their budget after all); a broken budget tightens the rung 10x and reruns every point
    here, at most MAX_TIGHTEN times (then the Verification says so)."""
    from dataclasses import replace

    from creatio.studies.budget import sobol_budget, verify
    from creatio.studies.en05 import OUTPUTS

    b = sample.budget
    assert b is not None
    record = sample.pilot_record()
    rung = sample.rung()
    assert rung is not None
    runs = _Runs(sample)
    seed = sample.resolved.obj.study.sensitivity.seed + 1
    tightened = 0
    while True:
        outputs = {k: rows[k] for k in OUTPUTS}
        full = verify(runs, outputs, rung, sobol_budget(outputs, b.fraction), seed, b.points)
        noise = {k: {"why": why, "observed": full.observed[k], "budget": full.budget[k]}
                 for k, why in record["unresolved"].items()
                 if k in full.budget and full.observed[k] > full.budget[k]}
        check = replace(full, budget={k: v for k, v in full.budget.items() if k not in noise},
                        observed={k: v for k, v in full.observed.items() if k not in noise},
                        tightened=tightened)
        log.info("en05 check: %s", check.describe())
        for k, v in noise.items():
            log.info("en05 check: %s unresolved (error %.2g, a budget of %.2g): %s", k,
                     v["observed"], v["budget"], v["why"])
        if check.ok or tightened >= MAX_TIGHTEN:
            return rows, check, noise, plan
        rung = rung.tighter(10.0)
        tightened += 1
        plan = sample.plan(rung, f"{sample.outdir}-rtol{rung.rtol:g}")
        log.warning("en05: the budget is broken on the check (%s): every point rerun at "
                    "%s in this process, into %s", check.line(), rung.label(), plan.outdir)
        for k in range(plan.n_batches):
            if _stale(plan, k):
                run_batch(plan, k)
        rows = collect(plan, list(OUTPUTS))


def sobol_dataset(resolved: Resolved, sample: En05Sample | None = None,
                  compute_missing: bool = False) -> Any:
    """EN-05's Sobol' dataset from the sample's batch files (computing the pilot and absent
    or stale batches first in this process with compute_missing), checked against its
    accuracy budget, with the provenance of the EN-05 config."""
    from creatio.pipeline.provenance import provenance
    from creatio.studies import en05

    sample = sample or en05_sample(resolved)
    if sample.budget is not None and compute_missing and not Path(
            str(sample.rung_file)).is_file():
        pilot(sample)
    plan = sample.plan(sample.rung())
    for k in range(plan.n_batches):
        if _stale(plan, k):
            if not compute_missing:
                raise ConfigError("batch", plan.batch_file(k), "is absent or was computed at "
                                  f"other settings than {' '.join(plan.base)}: rerun its job")
            run_batch(plan, k)
    rows = collect(plan, list(en05.OUTPUTS))
    check, noise = None, {}
    if sample.budget is not None:
        rows, check, noise, plan = _checked(sample, plan, rows)
    ds = en05.sobol_dataset(resolved.obj, rows)
    ds.attrs["point_store"] = plan.outdir
    ds.attrs["sample_base_overrides"] = " ".join(plan.base)
    if check is not None:
        ds.attrs.update(check.attrs(ACCURACY_PREFIX))
        ds.attrs[f"{ACCURACY_PREFIX}fraction"] = sample.budget.fraction
        ds.attrs[f"{ACCURACY_PREFIX}unresolved"] = json.dumps(noise, sort_keys=True)
        ds.attrs[f"{ACCURACY_PREFIX}describe"] = check.describe()
    title = "EN-05 Sobol' indices of EN-02's outputs"
    ds.attrs = {**provenance(resolved.id, resolved.yaml, resolved.sha256, title), **ds.attrs}
    return ds


def accuracy(attrs: Mapping[str, Any]) -> tuple[Verification, dict[str, Any]] | None:
    """The check recorded in a Sobol' dataset's attributes and its unresolved outputs (None:
    a sample without a budget)."""
    if f"{ACCURACY_PREFIX}outputs" not in attrs:
        return None
    unresolved = json.loads(str(attrs.get(f"{ACCURACY_PREFIX}unresolved", "{}")))
    return Verification.from_attrs(attrs, ACCURACY_PREFIX), unresolved


def run_study_sample(resolved: Resolved, root: Path) -> list[Path]:
    """`creatio run study=en05`: the sample's pilot and batches in this process, then its
    dataset."""
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
                budget = ("no accuracy budget" if s.budget is None else
                          f"numerical error <= {s.budget.fraction:g} sd, pilot of "
                          f"{s.budget.points} points first")
                print(f"creatio: en05 sample {s.name}: {s.n_points} points in {s.n_batches} "
                      f"batch(es) of {s.batch_size} ({budget}) -> {s.outdir}",
                      file=sys.stderr)
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
        """The batch files of the sample of the config under root, and the pilot's choice
        they were run at (with a budget)."""
        samples = self._plan()
        if root not in samples:
            raise ConfigError("output", f"{root}/studies/en05/en05_sobol.nc",
                              "no EN-05 configuration of this invocation writes there")
        sample = samples[root][1]
        return [*sample.batches, *([sample.rung_file] if sample.rung_file else [])]


@dataclass(frozen=True)
class _SampleJob:
    """A sample's job inputs: the config file, and the pilot's choice with a budget."""

    sample: En05Sample
    config_file: str

    @property
    def inputs(self) -> dict[str, str]:
        """The named inputs of a batch job (``config``, and ``rung`` with a budget)."""
        rung = self.sample.rung_file
        return {"config": self.config_file, **({"rung": rung} if rung else {})}


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
    """`creatio task en05 pilot|batch|sobol|track ...`: one step of EN-05 as its rules call
    it."""
    from creatio.errors import Parser

    ap = Parser(prog="creatio task en05", description="One step of EN-05.")
    sub = ap.add_subparsers(dest="step", required=True)
    r = sub.add_parser("pilot", help="choose the tolerance of the Sobol' sample's runs under "
                       "its accuracy budget")
    b = sub.add_parser("batch", help="compute one batch of the Sobol' sample's points")
    s = sub.add_parser("sobol", help="the Sobol' dataset from the sample's batches, checked "
                       "against its accuracy budget")
    t = sub.add_parser("track", help="write the synthetic example track (CSV)")
    for p in (r, b, s, t):
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
        if args.step == "pilot":
            pilot(sample, args.out)
        elif args.step == "batch":
            if args.batch_size is not None and args.batch_size != sample.batch_size:
                raise ConfigError("--batch-size", args.batch_size,
                                  f"the config plans batches of {sample.batch_size}")
            if not 0 <= args.batch < sample.n_batches:
                raise ConfigError("--batch", args.batch,
                                  f"must lie in [0, {sample.n_batches - 1}]")
            run_batch(sample.plan(sample.rung()), args.batch, args.out)
        else:
            from creatio.store.netcdf import write_dataset

            out = args.out or Path("data/studies/en05/en05_sobol.nc")
            write_dataset(sobol_dataset(resolved, sample, args.compute_missing), out)
            log.info("en05: wrote %s", out)
    except ConfigError as e:
        print(f"creatio task en05: {e}", file=sys.stderr)
        return 2
    return 0
