"""What a scene computes, planned from what it draws; and the Snakefile's scene planning.

A sphere scene draws frames, not the 0.1 s history: each study it shows is run once, at its
configured step, with histories written only at the frame times (``solver.output_interval``
= playback speed / fps), no energy bookkeeping (no scene shows energy), no dt / refine
partner, and rotation asked for only when the marker, the band or a spin readout is drawn
(otherwise the core integrates it only where friction couples it to the path). Where the
study's own dataset for the same resolved config already exists and holds every frame (its
output interval divides the frame interval, and it integrated the rotation if that is
needed), the scene reuses it instead of computing again.

Planning imports neither xarray nor the compiler: reuse is decided from the dataset's path,
which the study's resolved config determines; the scene job checks the file's config hash
when it reads it.
"""

from __future__ import annotations

import functools
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError, one_line_errors
from creatio.model.numerics import steps_in
from creatio.pipeline.config import Resolved, nearest_key, nearest_name
from creatio.pipeline.config import output_root as study_root
from creatio.scenes import registry
from creatio.scenes.config import output_root, resolve, route
from creatio.scenes.needs import RunNeed, needs
from creatio.studies import registry as studies

__all__ = ["RunNeed", "ScenePlan", "SceneRuns", "needs", "reusable", "scenes_of",
           "study_dataset"]


def _holds(base: Resolved, need: RunNeed) -> bool:
    """Whether the study's own dataset (its configured dt) holds every frame the need asks
    for: output interval dividing the frame interval, rotation integrated where needed."""
    cfg = base.obj
    if steps_in(need.interval, cfg.solver.output_interval) is None:
        return False
    if "rotation" in need.outputs and "rotation" not in [str(o) for o in cfg.study.outputs]:
        return cfg.sphere_problem().rotation_integrated
    return True


def reusable(base: Resolved, need: RunNeed, data_dir: str | Path = "data") -> str | None:
    """The study dataset a scene can read instead of computing, if it exists and holds the
    need; else None. Path only (the job checks the file's config hash when it reads it)."""
    if not _holds(base, need):
        return None
    entry = studies.get(base.id)
    path = entry.datasets(str(study_root(base, data_dir)), base.obj)[0]
    return path if Path(path).is_file() else None


def study_dataset(base: Resolved, part: str, data_dir: str | Path = "data") -> str:
    """The path of one dataset part of a study config, where the study's own rules write it."""
    entry = studies.get(base.id)
    name = entry.part(base.obj, part).name
    return f"{entry.dataset_dir(str(study_root(base, data_dir)))}/{name}.nc"


def scenes_of(study_ids: Sequence[str]) -> list[str]:
    """The scenes built with these studies: those that read one of their datasets, or that
    name one of them as the study they are built with."""
    return [s.id for s in registry.SCENES.values()
            if (s.reads[0] if s.reads else s.built_with) in study_ids]


@dataclass(frozen=True)
class ScenePlan:
    """One scene's resolved config, the overrides that reached it, and its output root."""

    scene: str
    resolved: Resolved
    overrides: tuple[str, ...]
    root: str

    @property
    def entry(self) -> registry.Scene:
        """The registry entry of the scene."""
        return registry.get(self.scene)

    @property
    def files(self) -> list[str]:
        """scene.nc, index.html, the animation and the poster."""
        return self.entry.files(self.root)

    def reuse(self, data_dir: str | Path = "data") -> dict[str, str]:
        """{study: dataset path} of the study datasets this scene reads instead of computing;
        for a scene that reads a study's dataset (``reads``), that dataset, built first."""
        bases = self.resolved.bases
        if self.entry.reads is not None:
            study, part = self.entry.reads
            return {study: study_dataset(bases[study], part, data_dir)}
        out = {}
        for need in needs(self.resolved):
            path = reusable(bases[need.study], need, data_dir)
            if path is not None:
                out[need.study] = path
        return out


class SceneRuns:
    """The scenes of one workflow invocation, planned on first use (`snakemake scenes`).

    Overrides reach every scene whose config has the key (see :func:`route`); an override
    no selected scene has is refused, as for studies (unless ``strict`` is off: the scenes
    `snakemake beyond` builds with its studies, whose planner refuses them). Without a
    selection, every scene but those built with a study (``reads``). Jobs look their config
    up by (output root, scene), here and then in ``fallbacks`` (other planners of the same
    invocation); a job re-invoked on its own (a cluster node) plans the same again from the
    same --config.
    """

    def __init__(self, overrides: Any, scenes: Any = None, data_dir: str = "data",
                 strict: bool = True) -> None:
        from creatio.pipeline.planning import as_list

        self.overrides = as_list(overrides)
        self.scenes = (as_list(scenes) if scenes is not None
                       else [s.id for s in registry.SCENES.values() if s.reads is None])
        self.data_dir = data_dir
        self.strict = strict
        self.fallbacks: list[SceneRuns] = []

    @functools.cached_property
    def plans(self) -> dict[str, ScenePlan]:
        """Resolve every selected scene under the overrides."""
        unknown = [s for s in self.scenes if s not in registry.SCENES]
        if unknown:
            raise ConfigError("scenes", unknown, f"must be among {', '.join(registry.SCENES)}"
                              + nearest_name(unknown[0], registry.SCENES))
        used: set[str] = set()
        out = {}
        for scene in self.scenes:
            routed, applied = route(scene, self.overrides)
            used.update(applied)
            try:
                resolved = resolve(scene, routed)
            except ConfigError as e:
                raise as_typed(e, applied) from None
            root = str(output_root(resolved, self.data_dir))
            out[scene] = ScenePlan(scene, resolved, tuple(routed), root)
            if routed:
                print(f"creatio: scene {scene} {routed} -> {root}", file=sys.stderr)
        unused = [o for o in self.overrides if o not in used]
        if unused and self.strict:
            for ov in unused:
                key, _, value = ov.partition("=")
                near = nearest_key(key, list(studies.STUDIES))
                if near is not None:
                    raise ConfigError(key.lstrip("+~"), value,
                                      f"unknown key (did you mean {near}?)")
            raise ConfigError("overrides", unused, "no selected scene has these keys")
        return out

    def study_jobs(self, jobs: Any) -> None:
        """Register with ``jobs`` (creatio.pipeline.planning.JobConfigs) the study configs
        whose datasets the selected scenes read, so that the study's own rules build them
        under these overrides (``bases.en04.bases.en02.sphere.mu`` is the study's
        ``bases.en02.sphere.mu``). A JobConfigs fallback: if these scenes cannot be planned
        it registers nothing, and the invocation's own planners say why."""
        if not any(registry.SCENES[s].reads for s in self.scenes if s in registry.SCENES):
            return
        try:
            plans = self.plans
        except ConfigError:
            return
        for plan in plans.values():
            if plan.entry.reads is None:
                continue
            study = plan.entry.reads[0]
            base = plan.resolved.bases[study]
            prefix = f"bases.{study}."
            overrides = [o[len(prefix):] if o.startswith(prefix) else o for o in plan.overrides]
            jobs.add(str(study_root(base, self.data_dir)), base, overrides)

    @one_line_errors
    def targets(self) -> list[str]:
        """Every file of every selected scene."""
        return [f for p in self.plans.values() for f in p.files]

    @one_line_errors
    def built(self) -> list[str]:
        """The files of the scenes whose every file exists (what a report can include),
        this planner's and its fallbacks'."""
        own = [f for p in self.plans.values() if all(Path(x).is_file() for x in p.files)
               for f in p.files]
        return own + [f for other in self.fallbacks for f in other.built() if f not in own]

    @one_line_errors
    def get(self, root: str, scene: str) -> ScenePlan:
        """The plan that writes ``<root>/scenes/<scene>/``: this invocation's, or the default
        config's when the root is the data directory (a scene file asked for by path)."""
        plan = self.plans.get(scene) if scene in self.scenes else None
        if plan is not None and plan.root == str(root):
            return plan
        for other in self.fallbacks:
            plan = other.plans.get(scene) if scene in other.scenes else None
            if plan is not None and plan.root == str(root):
                return plan
        if str(root) == self.data_dir:
            return ScenePlan(scene, resolve(scene), (), self.data_dir)
        raise ConfigError("output", f"{root}/scenes/{scene}",
                          "no scene configuration of this invocation writes there")

    @one_line_errors
    def sha(self, root: str, scene: str) -> str:
        """The sha256 of a scene's canonical resolved YAML (its config rule's parameter)."""
        return self.get(root, scene).resolved.sha256

    @one_line_errors
    def write(self, root: str, scene: str, path: str | Path, log: str | Path) -> None:
        """Write a scene's canonical resolved YAML to path (temporary, then renamed) and its
        hash to the log; a run folder also gets its overrides.json."""
        from creatio.pipeline.index import record_run
        from creatio.pipeline.planning import write_config_file

        plan = self.get(root, scene)
        resolved = plan.resolved
        write_config_file(path, log, scene, resolved.yaml, resolved.sha256)
        if str(root) != self.data_dir:
            record_run(root, "scene", scene, resolved.data, resolve(scene).data,
                       plan.overrides, resolved.sha256, self.data_dir)

    @one_line_errors
    def yaml(self, root: str, scene: str) -> str:
        """The canonical resolved YAML of a scene job (its only config parameter)."""
        return self.get(root, scene).resolved.yaml

    @one_line_errors
    def reuse(self, root: str, scene: str) -> dict[str, str]:
        """{study: dataset} a scene job reads instead of computing (its extra inputs)."""
        return self.get(root, scene).reuse(self.data_dir)

    @one_line_errors
    def reuse_args(self, root: str, scene: str) -> str:
        """``--reuse STUDY=PATH ...`` for `creatio task scene dataset`."""
        return " ".join(f"--reuse {s}={p}" for s, p in self.reuse(root, scene).items())

    @property
    def store(self) -> str:
        """Where computed family members are kept for reuse (shared by every output root)."""
        return f"{self.data_dir}/scenes/members"

    def family(self, root: str, scene: str) -> list[str]:
        """The family batch files of an explorable scene (its extra inputs; none without
        axes)."""
        from creatio.scenes.family import family_of

        plan = self.get(root, scene)
        if not plan.entry.kind.runs:
            return []
        family = family_of(plan.resolved)
        return family.batch_files(plan.entry.directory(root)) if family else []


def as_typed(error: ConfigError, typed: Sequence[str]) -> ConfigError:
    """A scene's refusal named by the key the user typed (``sphere.mu``), not the base's key
    it was routed to (``bases.en02.sphere.mu``)."""
    keys = [ov.partition("=")[0].lstrip("+~").split("@", 1)[0] for ov in typed]
    parts = str(error.key).split(".")
    if len(parts) < 3 or parts[0] != "bases":
        return error
    inner = ".".join(parts[2:])
    if not any(inner == k or inner.startswith(f"{k}.") or inner.startswith(f"{k}[")
               for k in keys):
        return error
    routed = ".".join(parts[:2]) + "."
    return ConfigError(inner, error.value, str(error.rule).replace(routed, ""))


def scene_ids(scenes: Sequence[str] | None = None) -> str:
    """A regex of the registered scene ids, for Snakemake wildcard constraints."""
    return "|".join(scenes or registry.SCENES)
