"""The study registry: one entry per study, read by validation, dispatch, planning and reports.

A study is a config (``conf/<group>/<id>.yaml`` on its schema) and a function ``config ->
xarray.Dataset`` per dataset part. Its *kind* says where its datasets and reports live and
which files a report writes; the report writer is the reports' own business
(creatio.reports.registry), and a sampled study's batch jobs the pipeline's. Everything
here is plain data: the run functions are named by import path and loaded on first use, so
planning a workflow imports neither xarray nor the compiler, and no name here points to a
layer above this one (tests/architecture/test_layers.py).

Adding a study of an existing kind is a ``conf/study/<id>.yaml`` (its time laws under
``conf/phases/`` if new), one entry of STUDIES below and one of the reports' registry.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from creatio.studies import published
from creatio.studies.ct02_schema import Ct02Config
from creatio.studies.en01_schema import En01Config
from creatio.studies.en02f_schema import En02fConfig
from creatio.studies.en02g_schema import En02gConfig
from creatio.studies.en03_schema import En03Config
from creatio.studies.en03m_schema import En03mConfig
from creatio.studies.schema import DynamicConfig

__all__ = ["BEYOND_KINDS", "KINDS", "STUDIES", "Kind", "Part", "Study", "beyond", "get", "select"]


@dataclass(frozen=True)
class Part:
    """One dataset of a study: its file stem and the keyword arguments of the run function."""

    name: str
    args: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Kind:
    """How a family of studies is laid out on disk and reported.

    Datasets go to ``<root>/<dataset_dir>/<id>/<part>.nc``; reports to
    ``<root>/<report_dir>/<id><suffix>`` for each suffix of ``reports``.
    """

    name: str
    dataset_dir: str
    report_dir: str
    reports: tuple[str, ...]


KINEMATIC = Kind("kinematic", "studies", "reports", (".json", ".md", ".html", ".png",
                                                    "_fd_error.csv"))
SPHERE = Kind("sphere", "studies", "reports", (".json", ".md", ".html", ".png", "_history.csv",
                                                "_trajectory.png", "_convergence.png"))
ANALYSIS = Kind("analysis", "benchmarks", "benchmarks", (".json", ".md", ".png"))
#: EN-06: fields over the membrane from the prescribed surface (strain, stress, fatigue).
MATERIAL = Kind("material", "studies", "reports", (".json", ".md", ".html", ".png",
                                                   "_envelope.png", "_fatigue.png",
                                                   "_tolerances.png", "_ribs_transport.png",
                                                   "_rib_errors.png"))
#: EN-07: a microgravity demonstrator (similarity, platforms' requirements, host interfaces).
DEMONSTRATOR = Kind("demonstrator", "studies", "reports", (".json", ".md", ".html", ".png",
                                                           "_feasible.png", "_yaw.png"))
UNCERTAINTY = Kind("uncertainty", "studies", "reports", (".json", ".md", ".png", "_sobol.csv",
                                                         "_calibration.png", "_design.png"))

#: Every kind, by name.
KINDS = {k.name: k for k in (KINEMATIC, SPHERE, ANALYSIS, UNCERTAINTY, MATERIAL,
                             DEMONSTRATOR)}


def _one_part(study_id: str) -> Callable[[Any], list[Part]]:
    return lambda cfg: [Part(study_id)]


def _timestep_parts(study_id: str) -> Callable[[Any], list[Part]]:
    """A sphere study's datasets: one per run of its convergence pair (the solver's rungs,
    dt and dt / refine), named by the rung's label; the run looks its rung up by dt."""
    return lambda cfg: [Part(f"{study_id}_{r.label}", {"dt": r.dt})
                        for r in cfg.solver.rungs()]


def _en02f_parts(cfg: Any) -> list[Part]:
    """EN-02F's datasets: the (T, e) sweep at each timestep, then the drop test."""
    return _timestep_parts("en02f")(cfg) + [Part("en02f_drop", {"drop": True})]


def _en03_parts(cfg: Any) -> list[Part]:
    """EN-03's datasets: the single run at each timestep, then the inertia sweep at each."""
    return _timestep_parts("en03")(cfg) + [
        Part(f"en03_inertia_{r.label}", {"dt": r.dt, "sweep": True})
        for r in cfg.solver.rungs()]


@dataclass(frozen=True)
class Study:
    """One study: its id, kind, config schema and group, and what it runs and reports.

    ``schema`` and ``parts`` may be given as "module:name" paths (an analysis keeps them in
    its own module), loaded on first use like ``run``.
    """

    id: str
    kind: Kind
    schema_ref: type | str
    run: str
    parts_ref: Callable[[Any], list[Part]] | str
    group: str = "study"
    published: Mapping[str, Any] = field(default_factory=dict)
    #: The config keys (dotted prefixes) the published figures depend on: a run that changes
    #: one of them from the default is not the published case, and its report compares
    #: nothing with the notebook. Empty: every key (a study that declares none).
    published_case: tuple[str, ...] = ()
    in_all: bool = True
    #: Its datasets include a sample the workflow computes in batch jobs (EN-05's Sobol'
    #: sample): the pipeline runs it in batch jobs, `creatio run` in one process.
    sampled: bool = False

    def published_keys(self, changed: Mapping[str, Any]) -> list[str]:
        """The changed keys (dotted) that take a run off the published case: those under a
        declared prefix, and any whose default is null (a feature switched on)."""
        def under(key: str) -> bool:
            return not self.published_case or any(
                key == p or key.startswith(p + ".") for p in self.published_case)

        return [k for k, v in changed.items()
                if under(k) or (isinstance(v, list | tuple) and v and v[0] is None)]

    @property
    def schema(self) -> type:
        """The root dataclass of this study's config."""
        ref = self.schema_ref
        return _load(ref) if isinstance(ref, str) else ref

    def parts(self, cfg: Any) -> list[Part]:
        """The dataset parts of a validated config of this study."""
        ref = self.parts_ref
        return (_load(ref) if isinstance(ref, str) else ref)(cfg)

    def run_function(self) -> Callable[..., Any]:
        """The function config -> Dataset (imported on first use)."""
        return _load(self.run)

    def dataset_dir(self, root: str) -> str:
        """Where the datasets of this study live under an output root."""
        return f"{root}/{self.kind.dataset_dir}/{self.id}"

    def datasets(self, root: str, cfg: Any) -> list[str]:
        """Dataset paths of a validated config of this study, in part order."""
        return [f"{self.dataset_dir(root)}/{p.name}.nc" for p in self.parts(cfg)]

    def part(self, cfg: Any, name: str) -> Part:
        """The part of this config whose file stem is name."""
        for p in self.parts(cfg):
            if p.name == name:
                return p
        choices = ", ".join(p.name for p in self.parts(cfg))
        raise KeyError(f"{self.id} has no dataset {name!r} for this config (it has {choices})")

    def reports(self, root: str) -> list[str]:
        """Report files of this study under an output root."""
        return [f"{root}/{self.kind.report_dir}/{self.id}{s}" for s in self.kind.reports]


def _load(path: str) -> Callable[..., Any]:
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


#: The registry, in the order `snakemake all` builds and reports list them.
STUDIES: dict[str, Study] = {
    s.id: s
    for s in (
        Study("ct02", KINEMATIC, Ct02Config, "creatio.studies.ct02:run",
              _one_part("ct02")),
        Study("en01", KINEMATIC, En01Config, "creatio.studies.en01:run",
              _one_part("en01"),
              published={"fd_error": published.EN01_FD_ERROR,
                         "regularity": published.EN01_REGULARITY,
                         "pattern": published.EN01_PATTERN}),
        Study("en02", SPHERE, DynamicConfig, "creatio.studies.sphere:run",
              _timestep_parts("en02"),
              published=published.EN02, published_case=published.EN02_CASE),
        Study("en02r", SPHERE, DynamicConfig, "creatio.studies.sphere:run",
              _timestep_parts("en02r")),
        Study("en02v", SPHERE, DynamicConfig, "creatio.studies.sphere:run",
              _timestep_parts("en02v")),
        # Beyond the notebook (docs/studies.md): outside `all`, built by `snakemake beyond`
        Study("en02g", SPHERE, En02gConfig, "creatio.studies.en02g:run",
              _timestep_parts("en02g"), in_all=False),
        Study("en02f", SPHERE, En02fConfig, "creatio.studies.en02f:run",
              _en02f_parts, in_all=False),
        Study("en03", SPHERE, En03Config, "creatio.studies.en03:run",
              _en03_parts, in_all=False),
        Study("en03m", SPHERE, En03mConfig, "creatio.studies.en03m:run",
              _timestep_parts("en03m"), in_all=False),
        Study("en04", SPHERE, "creatio.studies.en04:En04Config", "creatio.studies.en04:run",
              "creatio.studies.en04:parts", in_all=False),
        # EN-06 (docs/materials.md): what the membrane must be made of; built by `beyond`
        Study("en06", MATERIAL, "creatio.studies.en06_schema:En06Config",
              "creatio.studies.en06:run", "creatio.studies.en06:parts", in_all=False),
        # EN-07 (docs/aerospace.md): a microgravity demonstrator; built by `beyond`
        Study("en07", DEMONSTRATOR, "creatio.studies.en07_schema:En07Config",
              "creatio.studies.en07:run", "creatio.studies.en07:parts", in_all=False),
        # EN-05 (docs/studies.md): its own target, `snakemake en05`; its Sobol' sample runs as
        # batch jobs of the pipeline, its other parts as datasets
        Study("en05", UNCERTAINTY, "creatio.studies.en05_schema:En05Config",
              "creatio.studies.en05:run",
              "creatio.studies.en05:parts", in_all=False,
              sampled=True),
        *(Study(name, ANALYSIS, f"creatio.studies.{name}:{schema}", f"creatio.studies.{name}:run",
                f"creatio.studies.{name}:parts",
                group="analysis", in_all=False)
          for name, schema in (("work_precision", "WorkPrecisionConfig"),
                               ("stability_map", "StabilityMapConfig"),
                               ("boundaries", "BoundariesConfig"))),
    )
}


def get(study_id: str) -> Study:
    """The registered study; KeyError naming the choices otherwise."""
    try:
        return STUDIES[study_id]
    except KeyError:
        raise KeyError(f"unknown study {study_id!r}: one of {', '.join(STUDIES)}") from None


def select(kind: str | None = None, in_all: bool | None = None) -> list[Study]:
    """Registered studies, optionally of one kind or only those `snakemake all` builds."""
    return [s for s in STUDIES.values()
            if (kind is None or s.kind.name == kind) and (in_all is None or s.in_all == in_all)]


#: The kinds of study `snakemake beyond` builds (EN-05 and the analyses have targets of their own).
BEYOND_KINDS = ("sphere", "material", "demonstrator")


def beyond() -> list[Study]:
    """The studies `snakemake beyond` builds: those outside `all` of the sphere, material and
    demonstrator kinds, in registry order."""
    return [s for s in select(in_all=False) if s.kind.name in BEYOND_KINDS]
