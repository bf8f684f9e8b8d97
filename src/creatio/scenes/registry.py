"""The scene registry: one entry per scene of the notebook, read by config, planning and rules.

A scene is a config (``conf/scene/<id>.yaml`` on its kind's schema) and a *kind* that says
how its dataset is computed (config -> ``xarray.Dataset``) and how its media are drawn. What
the scene draws decides what it computes (:mod:`creatio.scenes.plan`). Everything here is
plain data; functions are named by import path and loaded on first use, so planning a
workflow imports neither xarray, matplotlib nor the compiler.

Adding a scene of an existing kind is a ``conf/scene/<id>.yaml`` and one entry of SCENES.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from creatio.scenes.schema import (
    En04SceneConfig,
    SphereSceneConfig,
    SurfaceFamilyConfig,
    VelocityNormalConfig,
)
from creatio.scenes.strain_schema import StrainSceneConfig

__all__ = ["FILES", "KINDS", "SCENES", "Kind", "Scene", "get"]

#: The files every scene writes into its directory ``<root>/scenes/<id>/``.
FILES = ("scene.nc", "index.html", "animation.webp", "poster.png")


@dataclass(frozen=True)
class Kind:
    """How a family of scenes is computed and drawn: schema, dataset and media functions."""

    name: str
    schema: type
    compute: str
    media: str
    #: Whether its scenes draw sphere runs (planned by creatio.scenes.needs, explorable
    #: over axes by creatio.scenes.family).
    runs: bool = False


SPHERE = Kind("sphere", SphereSceneConfig, "creatio.scenes.compute:sphere_scene",
              "creatio.scenes.media:sphere_media", runs=True)
SURFACE_FAMILY = Kind("surface_family", SurfaceFamilyConfig,
                      "creatio.scenes.compute:surface_family_scene",
                      "creatio.scenes.media:surface_family_media")
VELOCITY_NORMAL = Kind("velocity_normal", VelocityNormalConfig,
                       "creatio.scenes.compute:velocity_normal_scene",
                       "creatio.scenes.media:velocity_normal_media")

#: A study's two runs read from its dataset, drawn as the sphere scenes draw theirs (the same
#: page format and media).
EN04 = Kind("en04", En04SceneConfig, "creatio.scenes.compute:en04_scene",
            "creatio.scenes.media:sphere_media")

#: A sphere scene whose membrane is coloured by its strain (creatio.scenes.strain), with the
#: sphere scenes' runs, page and family.
STRAIN = Kind("strain", StrainSceneConfig, "creatio.scenes.strain:strain_scene",
              "creatio.scenes.strain:strain_media", runs=True)

#: Every kind, by name.
KINDS = {k.name: k for k in (SPHERE, SURFACE_FAMILY, VELOCITY_NORMAL, EN04, STRAIN)}


@dataclass(frozen=True)
class Scene:
    """One scene: its id, kind and a one-line description (the report's caption uses it).

    ``reads`` = (study, dataset part): the scene draws that study dataset of the config under
    ``bases.<study>`` (a required input, never recomputed here); such a scene is built with
    its study (`snakemake beyond`), and by `snakemake scenes` only when named.
    """

    id: str
    kind: Kind
    description: str
    reads: tuple[str, str] | None = None
    #: (axis key, word) pairs: what the scene's own null value of an axis key is called on
    #: its slider (creatio.scenes.family; geometry.ribs null is the ideal surface).
    null_labels: tuple[tuple[str, str], ...] = ()
    #: The study whose target builds this scene too when it reads none of that study's
    #: datasets (EN-06's scene computes its own run): `snakemake beyond` with en06 builds it.
    built_with: str | None = None

    @property
    def schema(self) -> type:
        """The root dataclass of this scene's config."""
        return self.kind.schema

    def compute_function(self) -> Callable[..., Any]:
        """config -> Dataset (imported on first use)."""
        return _load(self.kind.compute)

    def media_function(self) -> Callable[..., Any]:
        """(dataset, animation path, poster path, settings) -> None (imported on first use)."""
        return _load(self.kind.media)

    def directory(self, root: str) -> str:
        """Where this scene's files live under an output root."""
        return f"{root}/scenes/{self.id}"

    def files(self, root: str) -> list[str]:
        """Every file of this scene under an output root (FILES order)."""
        return [f"{self.directory(root)}/{name}" for name in FILES]


def _load(path: str) -> Callable[..., Any]:
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


#: The registry, in the order `snakemake scenes` builds and the report lists them.
SCENES: dict[str, Scene] = {
    s.id: s
    for s in (
        Scene("surface_family", SURFACE_FAMILY,
              "the CT-02 surface from annulus through cone to cylinder (slider over gamma)"),
        Scene("velocity_normal", VELOCITY_NORMAL,
              "one surface point's unit normal and fixed-coordinate velocity c_t in three modes"),
        Scene("en02", SPHERE, "EN-02: the sphere carried through one cycle of the membrane"),
        Scene("en02r", SPHERE, "EN-02R: the cavity carries the sphere outward while turning"),
        Scene("compare", SPHERE, "EN-02 and EN-02R side by side on one shared clock"),
        Scene("en06", STRAIN, "EN-06: the membrane coloured by the strain its shape demands, "
              "with the EN-02 sphere it carries",
              null_labels=(("geometry.ribs", "ideal"),), built_with="en06"),
        Scene("en04", EN04, "EN-04: the fastest closed-loop transport beside the open-loop "
              "quintic at its boundary cycle", reads=("en04", "en04_control")),
    )
}


def get(scene_id: str) -> Scene:
    """The registered scene; KeyError naming the choices otherwise."""
    try:
        return SCENES[scene_id]
    except KeyError:
        raise KeyError(f"unknown scene {scene_id!r}: one of {', '.join(SCENES)}") from None
