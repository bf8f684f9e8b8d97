"""Scene configs: Hydra in, a validated :class:`Resolved` out; overrides routed per scene.

The pipeline composes the ``study`` and ``analysis`` groups; this module is the small adapter
that does the same for the ``scene`` group (``conf/scene.yaml`` + ``conf/scene/<id>.yaml``),
with the pipeline's own schemas registered so that ``/study@bases.en02: en02`` pulls in the
whole, typed EN-02 config. A scene's sphere studies are validated again on their own schema
(:func:`creatio.pipeline.config.validate`): their canonical YAML and sha256 are exactly those
of ``creatio run study=en02`` with the same overrides, which is how a scene finds a study
dataset it can reuse.

Overrides travel as for studies: ``sphere.mu=0.3`` is applied to every scene whose config has
that key, either at its top level (``geometry.A`` of the kinematic scenes, ``scene.*``) or in a
base (``bases.en02.sphere.mu``). A config-group override of a base (``solver=radau5``) is
routed to that base's group (``solver@bases.en02.solver=radau5``).
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from creatio.errors import ConfigError
from creatio.pipeline.config import (
    CONF_DIR,
    Resolved,
    nearest_name,
    omit_nulls,
    refuse_identity,
    refuse_interpolations,
    refuse_resolvers,
    reword,
)
from creatio.scenes import registry
from creatio.studies import registry as study_registry

__all__ = [
    "compose",
    "output_root",
    "resolve",
    "route",
    "validate",
]

#: The primary config of the scenes (conf/scene.yaml) and its config group (conf/scene/).
PRIMARY = "scene"


def register_schemas(scene: str | None = None) -> bool:
    """Put the study schemas (the pipeline's) and every scene schema in Hydra's ConfigStore
    (``conf/scene/<id>.yaml`` pulls in ``/schema/scene_<id>@_here_``); with ``scene``, only
    the schemas composing that scene pulls in (creatio.pipeline.config.schemas_of), when
    they can be told. True when it stored one not stored before."""
    from hydra.core.config_store import ConfigStore

    from creatio.pipeline.config import register_schemas as register_study_schemas
    from creatio.pipeline.config import schemas_of

    needed = schemas_of("scene", scene) if scene is not None else None
    studies = sorted(set(needed or ()) & study_registry.STUDIES.keys())
    if needed is not None and needed - set(studies) == {f"scene_{scene}"}:
        stored = register_study_schemas(*studies, only=True)
        scenes = [registry.get(scene)]
    else:  # every scene, or a schema neither a study's nor the scene's own: all of them
        stored = register_study_schemas()
        scenes = list(registry.SCENES.values())
    cs = ConfigStore.instance()
    for entry in scenes:
        if entry.id in _REGISTERED:  # storing converts the dataclass: once per process
            continue
        cs.store(group="schema", name=f"scene_{entry.id}", node=entry.schema,
                 package="_global_")
        _REGISTERED.add(entry.id)
        stored = True
    return stored


_REGISTERED: set[str] = set()


def compose(scene: str, overrides: Sequence[str] = ()) -> DictConfig:
    """Compose conf/scene.yaml with ``scene=<id>`` and Hydra overrides (re-entrant)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    registry.get(scene)
    register_schemas(scene)
    gh = GlobalHydra.instance()
    outer, gh.hydra = gh.hydra, None  # park a running Hydra app's instance while composing
    try:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            try:
                return hydra_compose(config_name=PRIMARY,
                                     overrides=[f"scene={scene}", *overrides])
            except Exception:
                # an override reached a schema the defaults lists do not name: all of them
                # (none new stored: the composition failed for another reason)
                if not register_schemas():
                    raise
                return hydra_compose(config_name=PRIMARY,
                                     overrides=[f"scene={scene}", *overrides])
    finally:
        GlobalHydra.instance().hydra = outer


def validate(cfg: DictConfig | dict, family: bool = True) -> Resolved:
    """Merge onto the scene's schema, check every rule, return the resolved config.
    ``family=False`` leaves a declared family unplanned (its axes, links and page size
    checked when the config was first validated): for a config read back from a scene
    dataset, whose page and animation draw from the dataset (planning composes the studies
    through Hydra, a few tenths of a second)."""
    if not isinstance(cfg, dict):
        cfg = OmegaConf.to_container(cfg, resolve=False)
    cfg = {k: v for k, v in cfg.items() if k != "hydra"}
    refuse_resolvers(cfg)
    cfg = OmegaConf.create(cfg)
    scene = str(OmegaConf.select(cfg, "scene.id", default=""))
    if scene not in registry.SCENES:
        raise ConfigError("scene.id", scene, f"must be one of {', '.join(registry.SCENES)}")
    try:
        merged = OmegaConf.merge(OmegaConf.structured(registry.get(scene).schema), cfg)
        data = OmegaConf.to_container(merged, resolve=True, enum_to_str=True,
                                      throw_on_missing=True)
        obj = OmegaConf.to_object(merged)
    except OmegaConfBaseException as e:
        key = getattr(e, "full_key", None) or "?"
        msg = str(getattr(e, "msg", e)).splitlines()[0]
        raise ConfigError(key, getattr(e, "value", None), msg) from None
    obj.check()
    if family and getattr(obj.scene, "axes", None):  # its axes, and whether it fits
        from creatio.scenes.family import plan_family

        plan_family(obj)
    data = omit_nulls(obj, data)
    text = OmegaConf.to_yaml(OmegaConf.create(data), sort_keys=True)
    return Resolved(scene, obj, data, text, hashlib.sha256(text.encode()).hexdigest(),
                    lookup=registry.get)


@functools.lru_cache(maxsize=64)
def _base_config(scene: str) -> DictConfig:
    return compose(scene)


def route(scene: str, overrides: Sequence[str]) -> tuple[list[str], list[str]]:
    """(the overrides rewritten for this scene's config, the original ones that applied).

    A key the scene has at its top level is kept; otherwise it goes to every base that has
    it (``sphere.mu=0.3`` -> ``bases.en02.sphere.mu=0.3``); a key naming a config group of a
    base (``solver=radau5``) overrides that base's group.
    """
    base = _base_config(scene)
    missing = object()
    routed: list[str] = []
    used: list[str] = []
    for ov in overrides:
        key, sep, value = ov.partition("=")
        prefix = key[: len(key) - len(key.lstrip("+~"))]
        key = key.lstrip("+~")
        axes = OmegaConf.select(base, "scene.axes", default=missing, throw_on_missing=False)
        if key == "scene.axes" and axes is not missing and sep and not prefix:
            routed += _replace_axes(axes, value)  # the whole set: {} or null for none
            used.append(ov)
            continue
        if key.startswith("scene.axes.") and axes is not missing:
            # an axis is the scene's own key (a new one is added); its value is sweep grammar
            if not prefix and OmegaConf.select(base, key, default=missing,
                                               throw_on_missing=False) is missing:
                prefix = "+"
            routed.append(f"{prefix}{key}{sep}{_axis_value(value) if sep else ''}")
            used.append(ov)
            continue
        if OmegaConf.select(base, key, default=missing, throw_on_missing=False) is not missing:
            routed.append(ov)
            used.append(ov)
            continue
        hit = False
        for name in OmegaConf.select(base, "bases", default={}) or {}:
            node = OmegaConf.select(base, f"bases.{name}.{key}", default=missing,
                                    throw_on_missing=False)
            if node is missing:
                continue
            hit = True
            if isinstance(node, DictConfig) and (CONF_DIR / key).is_dir():
                routed.append(f"{prefix}{key}@bases.{name}.{key}{sep}{value}")
            else:
                routed.append(f"{prefix}bases.{name}.{key}{sep}{value}")
        if hit:
            used.append(ov)
    return routed, used


def _replace_axes(current: Any, value: str) -> list[str]:
    """``scene.axes=<mapping>`` as overrides Hydra applies: every declared axis removed, each
    one of the mapping added (a structured config's mapping is merged, not replaced)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    from creatio.scenes.family import flatten_axes, listed_value

    try:
        new = OverridesParser.create().parse_override(f"scene.axes={value}").value()
    except Exception as e:  # noqa: BLE001 - Hydra's grammar error, re-worded
        raise ConfigError("scene.axes", value, "must be a mapping of axes, e.g. "
                          f"{{sphere.mu:'0,0.1'}} ({str(e).splitlines()[0]})") from None
    if new is None or new == "":
        new = {}
    if not isinstance(new, dict):
        raise ConfigError("scene.axes", value, "must be a mapping of axes, e.g. "
                          "{sphere.mu:'0,0.1'}, or {} for none")
    out = [f"~scene.axes.{name}" for name in current]
    for key, spec in flatten_axes(new):
        text = (f"[{','.join(listed_value(v) for v in spec)}]" if isinstance(spec, list)
                else _axis_value(str(spec)))
        out.append(f"+scene.axes.{key}={text}")
    return out


def _axis_value(value: str) -> str:
    """An axis value as Hydra must read it: the sweep grammar (``range(0,0.4,0.1)``,
    ``0,0.1``) quoted, so that composing keeps it as text; lists, null and quoted text as
    given."""
    text = value.strip()
    if not text or text[0] in "[{" or text in ("null", "None"):
        return value
    if len(text) > 1 and text[0] == text[-1] and text[0] in "'\"" and text[0] not in text[1:-1]:
        return value  # one quoted string already
    if "'" not in text:
        return f"'{text}'"
    return f'"{text}"' if '"' not in text else value


def resolve(scene: str, overrides: Sequence[str] = ()) -> Resolved:
    """Compose and validate one scene's config with (already routed) overrides, memoised."""
    return _resolve(scene, tuple(str(o) for o in overrides))


@functools.lru_cache(maxsize=256)
def _resolve(scene: str, overrides: tuple[str, ...]) -> Resolved:
    refuse_interpolations(overrides)
    refuse_identity(overrides, "scene.id", "--config 'scenes=[ID]'")
    try:
        # without overrides, the composition route() reads (planning asks for both)
        cfg = compose(scene, overrides) if overrides else _base_config(scene)
    except KeyError:
        raise ConfigError("scene", scene, f"must be one of {', '.join(registry.SCENES)}"
                          + nearest_name(scene, registry.SCENES)) from None
    except Exception as e:  # Hydra refused an override: name the first culprit
        raise _override_error(scene, overrides, e) from None
    return validate(cfg)


def _override_error(scene: str, overrides: Sequence[str], error: Exception) -> ConfigError:
    for ov in overrides:
        try:
            compose(scene, [ov])
        except Exception as e:  # noqa: BLE001 - any refusal pins the culprit
            key, _, value = ov.partition("=")
            reason = reword(str(e.__cause__ or e).splitlines()[0], key.lstrip("+~"), value)
            if "not in struct" in reason or "Could not override" in reason:
                reason = "unknown key (not in this scene's config)"
            return ConfigError(key.lstrip("+~"), value, f"scene {scene}: {reason}")
    return ConfigError("overrides", list(overrides), str(error).splitlines()[0])


def output_root(resolved: Resolved, data_dir: str | Path = "data") -> Path:
    """Default scene config -> ``data``; anything else -> ``data/runs/<config hash>``."""
    default = resolve(resolved.id)
    data_dir = Path(data_dir)
    return data_dir if default.sha256 == resolved.sha256 else data_dir / "runs" / resolved.key
