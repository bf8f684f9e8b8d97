"""Planning for the Snakefile: which files each study needs for one set of overrides.

The Snakefile stays declarative; the decisions live here, where they can be tested:
each study gets only the overrides that apply to it, its resolved config hash, and an
output root (``data`` for the default config, ``data/runs/<hash>`` otherwise).
"""

from __future__ import annotations

import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.config import (
    DYNAMIC,
    STUDIES,
    ConfigError,
    applicable,
    dataset_path,
    output_root,
    resolve,
)

__all__ = ["JobConfigs", "StudyPlan", "SweepRegistry", "compare_targets", "plan"]

KINEMATIC_REPORT = ("json", "md", "png", "csv")
DYNAMIC_REPORT = ("json", "md", "png", "csv", "trajectory.png", "convergence.png")


@dataclass(frozen=True)
class StudyPlan:
    """One study's resolved config hash, overrides and file layout for this invocation."""

    study: str
    sha256: str
    overrides: tuple[str, ...]
    root: str
    dts: tuple[float, ...] | None

    @property
    def datasets(self) -> list[str]:
        """Dataset paths (one per timestep for a dynamic study)."""
        if self.dts is None:
            return [str(dataset_path(self.root, self.study))]
        return [str(dataset_path(self.root, self.study, dt)) for dt in self.dts]

    def report(self, kind: str) -> str:
        """Path of one report file: json, md, png, csv, or a dynamic study's extra figures."""
        reports = Path(self.root) / "reports"
        if kind == "csv":
            suffix = "_fd_error.csv" if self.dts is None else "_history.csv"
            return str(reports / f"{self.study}{suffix}")
        if kind in ("trajectory.png", "convergence.png"):
            return str(reports / f"{self.study}_{kind}")
        return str(reports / f"{self.study}.{kind}")

    @property
    def reports(self) -> list[str]:
        """Every report file of this study."""
        kinds = KINEMATIC_REPORT if self.dts is None else DYNAMIC_REPORT
        return [self.report(k) for k in kinds]

    @property
    def cli_overrides(self) -> str:
        """The overrides as shell-quoted `--override` arguments."""
        return " ".join(f"--override {shlex.quote(o)}" for o in self.overrides)


def plan(
    overrides: Sequence[str] = (), studies: Sequence[str] = STUDIES, data_dir: str = "data"
) -> dict[str, StudyPlan]:
    """Resolve every study's config under the overrides; refuse overrides no study uses."""
    overrides = [str(o) for o in overrides]
    unknown = [s for s in studies if s not in STUDIES]
    if unknown:
        raise ConfigError("studies", unknown, f"must be among {', '.join(STUDIES)}")
    used: set[str] = set()
    out = {}
    for study in studies:
        ovs = applicable(study, overrides)
        used.update(ovs)
        resolved = resolve(study, ovs)
        dts = tuple(resolved.obj.solver.timesteps()) if study in DYNAMIC else None
        out[study] = StudyPlan(study, resolved.sha256, tuple(ovs),
                               str(output_root(resolved, data_dir)), dts)
    unused = [o for o in overrides if o not in used]
    if unused:
        raise ConfigError("overrides", unused, "no selected study has these keys")
    return out


def compare_targets(plans: dict[str, StudyPlan]) -> list[str]:
    """The EN-02 / EN-02R comparison files, when both studies run on default configs."""
    pair = [plans.get("en02"), plans.get("en02r")]
    if all(p is not None and p.root == "data" for p in pair):
        return ["data/reports/compare_en02_en02r.md", "data/reports/compare_en02_en02r.png"]
    return []


class JobConfigs:
    """Which config each dataset job runs: (output root, study) -> (hash, overrides).

    Study runs and sweep points both register here, so one dataset rule serves both.
    """

    def __init__(self) -> None:
        self._by_root: dict[tuple[str, str], tuple[str, tuple[str, ...]]] = {}

    def add(self, root: str, study: str, sha256: str, overrides: Sequence[str]) -> None:
        """Register the config that produces datasets under root for study."""
        self._by_root[(str(root), study)] = (sha256, tuple(overrides))

    def add_plans(self, plans: dict[str, StudyPlan]) -> None:
        """Register every study of a plan."""
        for p in plans.values():
            self.add(p.root, p.study, p.sha256, p.overrides)

    def add_sweep(self, sweep) -> None:
        """Register every valid point of a sweep plan."""
        for point in sweep.points:
            if point.valid:
                root = str(Path(point.dataset).parents[2])
                self.add(root, sweep.study, point.resolved.sha256,
                         [*sweep.base, *point.overrides])

    def _get(self, root: str, study: str) -> tuple[str, tuple[str, ...]]:
        try:
            return self._by_root[(root, study)]
        except KeyError:
            raise ConfigError("output", f"{root}/{study}",
                              "no configuration of this invocation writes there") from None

    def sha(self, root: str, study: str) -> str:
        """Short config hash the job must reproduce."""
        return self._get(root, study)[0][:12]

    def cli_overrides(self, root: str, study: str) -> str:
        """The job's overrides as shell-quoted `--override` arguments."""
        return " ".join(f"--override {shlex.quote(o)}" for o in self._get(root, study)[1])


class SweepRegistry:
    """The sweeps of one workflow invocation, planned on demand (only when targeted)."""

    def __init__(self, jobs: JobConfigs, basedir: str | Path) -> None:
        self.jobs = jobs
        self.basedir = Path(basedir)
        self.plans: dict[str, Any] = {}

    def outputs(self, study: str, sweep: Sequence[str], overrides: Sequence[str]) -> list[str]:
        """Plan a sweep (once), register its points' dataset jobs, return its aggregate."""
        import sys

        from creatio.sweep import plan_sweep

        if not sweep:
            raise ConfigError("sweep", list(sweep),
                              "`snakemake sweep` needs --config study=ID 'sweep=[\"KEY=V1,V2\"]'")
        s = plan_sweep(study, list(sweep), list(overrides))
        if s.name not in self.plans:
            self.plans[s.name] = s
            self.jobs.add_sweep(s)
            print(f"creatio: sweep {s.name}: {len(s.points)} points, {len(s.datasets)} valid "
                  f"-> {s.outdir}", file=sys.stderr)
        return s.outputs

    def worked(self, name: str) -> list[str]:
        """The aggregate of a sweep defined in conf/sweeps/<name>.yaml."""
        import yaml

        spec = yaml.safe_load((self.basedir / "conf" / "sweeps" / f"{name}.yaml").read_text())
        return self.outputs(spec["study"], spec["sweep"], spec.get("overrides") or [])

    def __getitem__(self, name: str) -> Any:
        return self.plans[name]
