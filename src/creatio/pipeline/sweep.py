"""Parameter sweeps: a Cartesian product of overrides, one dataset job per point, one aggregate.

A sweep is a study, a list of Hydra sweep overrides (``sphere.mu=0,0.05,0.15``, also
``range(...)`` and the rest of Hydra's sweep grammar) and base overrides applied to every
point. Each point resolves to its own config hash, so its dataset lives where a single run
of that config would put it (``data/runs/<hash>/...``) and a rerun recomputes only new
points. A point refused by validation (an unstable dt, an amplitude too large) is not run:
the aggregate records it with its message, as it records a run that stopped early.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError
from creatio.pipeline.config import Resolved, output_root, resolve
from creatio.studies import registry

__all__ = ["SweepPlan", "SweepPoint", "aggregate", "parse_axes", "plan_sweep"]


@dataclass(frozen=True)
class SweepPoint:
    """One point of the product: its overrides, and its config or why it was refused."""

    index: tuple[int, ...]
    overrides: tuple[str, ...]
    resolved: Resolved | None
    error: str
    dataset: str

    @property
    def valid(self) -> bool:
        """Whether the point's config passed validation (and so gets a job)."""
        return self.resolved is not None


@dataclass(frozen=True)
class SweepPlan:
    """A sweep: its axes (key, values), base overrides, points and output directory."""

    study: str
    axes: tuple[tuple[str, tuple[str, ...]], ...]
    base: tuple[str, ...]
    points: tuple[SweepPoint, ...]
    name: str
    outdir: str

    @property
    def datasets(self) -> list[str]:
        """The datasets of the valid points (the jobs of the sweep)."""
        return [p.dataset for p in self.points if p.valid]

    @property
    def outputs(self) -> list[str]:
        """The aggregate files."""
        return [f"{self.outdir}/sweep.{ext}" for ext in ("nc", "md", "png")]

    def cli_args(self) -> str:
        """Arguments that rebuild this plan in `creatio task sweep`."""
        import shlex

        args = [f"--study {self.study}"]
        args += [f"--sweep {shlex.quote(f'{k}=' + ','.join(v))}" for k, v in self.axes]
        args += [f"--override {shlex.quote(o)}" for o in self.base]
        return " ".join(args)


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
        values = list(ov.sweep_string_iterator()) if ov.is_sweep_override() else [
            ov.get_value_element_as_str()]
        if not values:
            raise ConfigError("sweep", text, "sweeps over no value")
        if key in [k for k, _ in axes]:
            raise ConfigError("sweep", text, f"key {key} is swept twice")
        axes.append((key, values))
    if not axes:
        raise ConfigError("sweep", list(sweep), "needs at least one KEY=V1,V2,... entry")
    return axes


def plan_sweep(
    study: str, sweep: Sequence[str], base: Sequence[str] = (), data_dir: str = "data"
) -> SweepPlan:
    """Expand the product and resolve every point (refused points are kept, not run)."""
    if not study:
        raise ConfigError("study", study, "a sweep needs the study to sweep (study=en02)")
    axes = parse_axes(sweep)
    base = tuple(str(o) for o in base)
    spec = json.dumps({"study": study, "axes": axes, "base": base}, sort_keys=True)
    name = f"{study}-{hashlib.sha256(spec.encode()).hexdigest()[:12]}"
    points = []
    for index in itertools.product(*(range(len(v)) for _, v in axes)):
        ovs = tuple(f"{k}={v[i]}" for (k, v), i in zip(axes, index, strict=True))
        try:
            resolved = resolve(study, [*base, *ovs])
        except ConfigError as e:
            points.append(SweepPoint(index, ovs, None, str(e), ""))
            continue
        # a sweep point runs the study's first part (a sphere study: the configured dt)
        path = registry.get(study).datasets(str(output_root(resolved, data_dir)), resolved.obj)[0]
        points.append(SweepPoint(index, ovs, resolved, "", path))
    if not any(p.valid for p in points):
        raise ConfigError("sweep", list(sweep), f"every point was refused; the first: "
                          f"{points[0].error}")
    return SweepPlan(study, tuple((k, tuple(v)) for k, v in axes), base, tuple(points), name,
                     f"{data_dir}/sweeps/{name}")


def _coordinate(values: Sequence[str]) -> list[Any]:
    try:
        return [float(v) for v in values]
    except ValueError:
        return list(values)


def _summary(path: str) -> dict[str, Any]:
    from creatio.pipeline.io import read_dataset
    from creatio.reports import summary

    ds, _ = read_dataset(path)
    return summary(ds)


def aggregate(plan: SweepPlan):
    """One dataset: a dimension per swept key, each scalar summary figure as a variable."""
    import numpy as np
    import xarray as xr

    shape = tuple(len(v) for _, v in plan.axes)
    dims = [k.replace(".", "__") for k, _ in plan.axes]
    summaries = {p.index: _summary(p.dataset) for p in plan.points if p.valid}
    keys = sorted({k for s in summaries.values() for k, v in s.items()
                   if isinstance(v, int | float) and not isinstance(v, bool)})
    data: dict[str, Any] = {}
    for key in keys:
        arr = np.full(shape, np.nan)
        for idx, s in summaries.items():
            arr[idx] = float(s.get(key, math.nan))
        data[key] = (dims, arr)
    status = np.empty(shape, dtype=object)
    message = np.empty(shape, dtype=object)
    limit = np.full(shape, np.nan)
    dt = np.full(shape, np.nan)
    for p in plan.points:
        s = summaries.get(p.index)
        status[p.index] = s.get("status", "ok") if s else "invalid"
        message[p.index] = p.error
        if _is_sphere(plan.study):
            cfg = p.resolved or _unchecked(plan.study, [*plan.base, *p.overrides])
            if cfg is not None:
                limit[p.index] = cfg.obj.step_limit()
                dt[p.index] = cfg.obj.solver.dt
    data["status"] = (dims, status.astype(str))
    data["message"] = (dims, message.astype(str),
                       {"long_name": "why a point was refused (empty when it ran)"})
    if _is_sphere(plan.study):
        data["stability_limit_dt_s"] = (dims, limit, {"units": "s"})
        data["dt_s"] = (dims, dt, {"units": "s"})
    coords = {d: (d, _coordinate(v), {"long_name": k})
              for d, (k, v) in zip(dims, plan.axes, strict=True)}
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "title": f"sweep of {plan.study} over {', '.join(k for k, _ in plan.axes)}",
        "study": plan.study,
        "sweep": json.dumps([[k, list(v)] for k, v in plan.axes]),
        "base_overrides": json.dumps(list(plan.base)),
        "points": len(plan.points),
        "points_run": len(summaries),
    })
    return ds


def _is_sphere(study: str) -> bool:
    return registry.get(study).kind is registry.SPHERE


def _unchecked(study: str, overrides: Sequence[str]) -> Resolved | None:
    """A refused point's config with the stability refusal lifted, to report its limit."""
    try:
        return resolve(study, [*overrides, "solver.allow_unstable=true"])
    except ConfigError:
        return None


def write_sweep(plan: SweepPlan) -> dict[str, Path]:
    """Aggregate, then write sweep.nc, a markdown table and one figure per summary figure."""
    from creatio.pipeline.io import provenance, write_dataset
    from creatio.reports.sweep import write_sweep_report

    ds = aggregate(plan)
    spec = json.dumps({"study": plan.study, "axes": [[k, list(v)] for k, v in plan.axes],
                       "base": list(plan.base)}, sort_keys=True)
    attrs = provenance(plan.study, spec, hashlib.sha256(spec.encode()).hexdigest(),
                       ds.attrs["title"])
    ds.attrs = {**attrs, **ds.attrs}
    outdir = Path(plan.outdir)
    paths = {"nc": write_dataset(ds, outdir / "sweep.nc")}
    paths.update(write_sweep_report(ds, outdir))
    return paths
