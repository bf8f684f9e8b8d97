"""Config composition and validation at the boundary: Hydra in, a Resolved config out.

Every study config is composed from ``conf/`` (the primary config of its group +
``conf/<group>/<id>.yaml`` + the groups it pulls in), merged onto the study's dataclass
schema (creatio.studies.schema; unknown keys and wrong types are refused by OmegaConf), then
checked rule by rule. A bad value raises :class:`~creatio.errors.ConfigError` naming the key,
the value and the rule, before anything is computed. The canonical resolved YAML and its
sha256 identify a config: outputs are placed by it and jobs rerun when it changes.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import MISSING, dataclass, field, fields, is_dataclass
from enum import Enum
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from creatio.errors import ConfigError
from creatio.store.regular import read_bytes, read_text
from creatio.studies import registry
from creatio.studies.schema import HUGE, OMIT_NULL, TINY, ProbeConfig, check_finite

__all__ = [
    "CONF_DIR",
    "HUGE",
    "TINY",
    "ConfigError",
    "check_finite",
    "composed",
    "forget_if_changed",
    "nearest_key",
    "nearest_name",
    "omit_nulls",
    "reword",
    "Resolved",
    "applicable",
    "compose",
    "output_root",
    "plain",
    "refuse_identity",
    "refuse_interpolations",
    "refuse_resolvers",
    "register_schemas",
    "resolve",
    "schemas_of",
    "validate",
    "warm",
]

CONF_DIR = Path(os.environ.get("CREATIO_CONF_DIR", Path(__file__).resolve().parents[3] / "conf"))

#: The primary config of each config group (conf/<name>.yaml).
PRIMARY = {"study": "config", "analysis": "analysis"}


@dataclass(frozen=True)
class Resolved:
    """A validated experiment config, a study's or a scene's: its id, typed object tree,
    plain dict, canonical YAML and the sha256 that keys everything made from it. ``lookup``
    finds its registry entry (the study registry's, or the scene registry's for a scene)."""

    id: str
    obj: Any
    data: dict
    yaml: str
    sha256: str
    lookup: Callable[[str], Any] = field(default=registry.get, compare=False, repr=False)

    @property
    def key(self) -> str:
        """Short config hash used to key output directories."""
        return self.sha256[:12]

    @property
    def entry(self) -> Any:
        """The registry entry of this config's study or scene."""
        return self.lookup(self.id)

    @functools.cached_property
    def bases(self) -> dict[str, Resolved]:
        """Each study config under ``bases`` (a scene's), resolved as the study itself
        would be."""
        return {name: validate(cfg) for name, cfg in self.data.get("bases", {}).items()}


def register_schemas(*extra: str, only: bool = False) -> bool:
    """Put the schemas in Hydra's ConfigStore so composition is typed from the start
    (``conf/<group>/<id>.yaml`` pulls in ``/schema/<id>@_here_``): every study of the
    ``study`` group (an analysis includes them as its bases), the probe's, and the extra
    studies named (loading an analysis's schema imports its module, so only on demand);
    ``only``: just the extra ones (what one composition needs, :func:`schemas_of`). True
    when it stored one not stored before."""
    from hydra.core.config_store import ConfigStore

    cs = ConfigStore.instance()
    names = [] if only else [s.id for s in registry.STUDIES.values() if s.group == "study"]
    stored = False
    for name in [*names, *extra, *([] if only else ["probe"])]:
        if name in _REGISTERED:  # storing converts the dataclass: once per process
            continue
        schema = ProbeConfig if name == "probe" else registry.get(name).schema
        cs.store(group="schema", name=name, node=schema, package="_global_")
        _REGISTERED.add(name)
        stored = True
    return stored


_REGISTERED: set[str] = set()


@functools.lru_cache(maxsize=64)
def schemas_of(group: str, name: str) -> frozenset[str] | None:
    """The schemas composing ``conf/<group>/<name>.yaml`` pulls in: its own
    ``/schema/<id>`` and those of the ``/study@...`` configs it includes, followed through
    their defaults lists (storing one schema costs about 15 ms: a process that composes one
    study stores what it needs, not all of them). None when the file cannot be read (then
    every schema is registered)."""
    from creatio.store.yamlio import load_yaml

    out: set[str] = set()
    try:
        data = load_yaml(read_text(CONF_DIR / group / f"{name}.yaml"))
    except (OSError, ValueError):
        return None
    for entry in (data or {}).get("defaults", []) if isinstance(data, dict) else []:
        if isinstance(entry, str) and entry.startswith("/schema/"):
            out.add(entry.removeprefix("/schema/").partition("@")[0])
        elif isinstance(entry, dict):
            for key, value in entry.items():
                if str(key).partition("@")[0] == "/study" and isinstance(value, str):
                    inner = schemas_of("study", value)
                    if inner is None:
                        return None
                    out |= inner
    return frozenset(out)


def compose(study: str, overrides: Sequence[str] = (), config_name: str | None = None
            ) -> DictConfig:
    """Compose conf/ for one study with Hydra overrides (context-manager API, re-entrant).

    ``config_name`` names another primary config (``probe``); by default the primary
    config of the study's group, with the study selected in that group.
    """
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    extra: list[str] = []
    needed = None
    if config_name is None:
        group = registry.get(study).group
        config_name = PRIMARY[group]
        extra = [f"{group}={study}"]
        needed = schemas_of(group, study)
    if needed is not None and not needed <= registry.STUDIES.keys():
        needed = None  # a schema that is not a study's: all of them
    if needed is None:
        register_schemas(*([study] if study in registry.STUDIES else []))
    else:
        register_schemas(*sorted(needed), only=True)
    # Inside a running Hydra app the global instance is taken: park it while composing.
    gh = GlobalHydra.instance()
    outer, gh.hydra = gh.hydra, None
    try:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            try:
                return hydra_compose(config_name=config_name, overrides=[*extra, *overrides])
            except Exception:
                # an override reached a schema the defaults lists do not name: all of them
                # (none new stored: the composition failed for another reason)
                if needed is None or not register_schemas():
                    raise
                return hydra_compose(config_name=config_name, overrides=[*extra, *overrides])
    finally:
        GlobalHydra.instance().hydra = outer


def validate(cfg: DictConfig | dict, schema: type | None = None, check: bool = True
             ) -> Resolved:
    """Merge onto the study's schema, check every rule, return the resolved config.

    Raises ConfigError for unknown keys, wrong types, missing values and broken rules.
    ``check=False`` skips the rules (types are still enforced): a base for
    creatio.studies.schema.vary, which checks the varied config.
    """
    if not isinstance(cfg, dict):  # drop the composed types: every key meets the schema anew,
        cfg = OmegaConf.to_container(cfg, resolve=False)  # a `+key=` addition included
    cfg = {k: v for k, v in cfg.items() if k != "hydra"}
    refuse_resolvers(cfg)
    cfg = OmegaConf.create(cfg)
    study = str(OmegaConf.select(cfg, "study.id", default="probe"))
    if schema is None:
        if study not in registry.STUDIES:
            raise ConfigError("study.id", study, f"must be one of {', '.join(registry.STUDIES)}"
                              + nearest_name(study, registry.STUDIES))
        schema = registry.STUDIES[study].schema
    try:
        merged = OmegaConf.merge(OmegaConf.structured(schema), cfg)
        data = OmegaConf.to_container(merged, resolve=True, enum_to_str=True,
                                      throw_on_missing=True)
        obj = OmegaConf.to_object(merged)
    except OmegaConfBaseException as e:
        key = getattr(e, "full_key", None) or "?"
        msg = str(getattr(e, "msg", e)).splitlines()[0]
        value = getattr(e, "value", None)
        if "not in" in msg:
            msg = "unknown key" + _nearest(schema, key)
            value = OmegaConf.select(cfg, key, default=value, throw_on_missing=False)
        raise ConfigError(key, value, msg) from None
    check_finite(obj)
    if check:
        obj.check()
    data = omit_nulls(obj, data)
    text = OmegaConf.to_yaml(OmegaConf.create(data), sort_keys=True)
    return Resolved(study, obj, data, text, hashlib.sha256(text.encode()).hexdigest())


#: Why no user text may hold an interpolation: OmegaConf resolves it where the config is
#: resolved, from outside the value (a resolver such as oc.env reads the environment).
NO_INTERPOLATION = ("interpolations (${...}) are not accepted in overrides: they are resolved "
                    "from outside the value (${oc.env:...} reads the environment); write the "
                    "value itself")


def refuse_interpolations(overrides: Sequence[str]) -> None:
    """Refuse any override whose text holds ``${`` (an interpolation, escaped or not, which a
    later OmegaConf pass would resolve), naming its key: user overrides carry values only."""
    for ov in overrides:
        if "${" in str(ov):
            key, _, value = str(ov).partition("=")
            raise ConfigError(key.lstrip("+~"), value, NO_INTERPOLATION)


def refuse_identity(overrides: Sequence[str], key: str = "study.id",
                    pick: str = "study=ID") -> None:
    """Refuse an override of a config's own id (``study.id=en02r`` labelled an EN-02 run as
    EN-02R: its outputs, provenance and report): the id is chosen with the group."""
    for ov in overrides:
        name, _, value = str(ov).partition("=")
        if name.lstrip("+~").split("@", 1)[0] == key:
            raise ConfigError(key, value, f"names the config and cannot be overridden: pick "
                              f"another with {pick}")


def refuse_resolvers(tree: Any, prefix: str = "") -> None:
    """Refuse a resolver call (``${name:...}``) anywhere in a config tree before it is
    resolved: conf/ uses plain references only (``${..phases.T}``), so a resolver came from
    outside (a config file a task reads, a value smuggled past the override check)."""
    items = tree.items() if isinstance(tree, dict) else enumerate(tree)
    for name, value in items:
        key = f"{prefix}[{name}]" if isinstance(tree, list) else f"{prefix}{name}"
        if isinstance(value, dict | list):
            refuse_resolvers(value, f"{key}." if isinstance(value, dict) else key)
        elif isinstance(value, str) and "${" in value and ":" in value:
            raise ConfigError(key, value, "resolvers (${name:...}) are not evaluated in "
                              "configs (${oc.env:...} would read the environment); write "
                              "the value itself")


def omit_nulls(obj: Any, data: Any) -> Any:
    """data (the plain tree of the config obj) without the fields marked OMIT_NULL whose value
    is null, at any depth (an optional group off is absent from the canonical text, so the
    configs that do not use it keep their YAML and sha256)."""
    if is_dataclass(obj) and isinstance(data, dict):
        out = {}
        for f in fields(obj):
            if f.name not in data:
                continue
            value = getattr(obj, f.name)
            if value is None and f.metadata.get(OMIT_NULL, False):
                continue
            out[f.name] = omit_nulls(value, data[f.name])
        return out
    if isinstance(obj, dict) and isinstance(data, dict):
        study = data.get("study")
        sid = study.get("id") if isinstance(study, dict) else None
        if isinstance(sid, str) and sid in registry.STUDIES and not any(
                is_dataclass(v) for v in obj.values()):
            # an untyped study config (a scene's base held as a plain mapping): its schema
            return _omit_by_schema(registry.get(sid).schema, data)
        return {k: omit_nulls(obj[k], v) if k in obj else v for k, v in data.items()}
    if isinstance(obj, list | tuple) and isinstance(data, list) and len(obj) == len(data):
        return [omit_nulls(o, d) for o, d in zip(obj, data, strict=True)]
    return data


def _omit_by_schema(tp: Any, data: Any) -> Any:
    """:func:`omit_nulls` for plain data of the schema type tp (a dataclass, a dict or list of
    them, an optional one)."""
    import types
    import typing

    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        return _omit_by_schema(inner[0], data) if len(inner) == 1 else data
    if origin is dict and isinstance(data, dict) and len(args) == 2:
        return {k: _omit_by_schema(args[1], v) for k, v in data.items()}
    if origin is list and isinstance(data, list) and args:
        return [_omit_by_schema(args[0], v) for v in data]
    if isinstance(tp, type) and is_dataclass(tp) and isinstance(data, dict):
        hints = _hints(tp)
        out = {}
        for f in fields(tp):
            if f.name not in data:
                continue
            if data[f.name] is None and f.metadata.get(OMIT_NULL, False):
                continue
            out[f.name] = _omit_by_schema(hints[f.name], data[f.name])
        return out
    return data


def _optional_key(schema: Any, key: str) -> bool:
    """Whether a dotted key names, or lies under, a field of the schema that the canonical
    text leaves out while null (sphere.beta_deg): the default's data cannot show it."""
    import types
    import typing

    tp: Any = schema
    for part in key.split("."):
        origin, args = typing.get_origin(tp), typing.get_args(tp)
        if origin in (typing.Union, types.UnionType):
            inner = [a for a in args if a is not type(None)]
            tp = inner[0] if len(inner) == 1 else None
        if not (isinstance(tp, type) and is_dataclass(tp)):
            return False
        field_ = next((f for f in fields(tp) if f.name == part), None)
        if field_ is None:
            return False
        if field_.metadata.get(OMIT_NULL, False):
            return True
        tp = _hints(tp)[part]
    return False


def _omittable(schema: Any) -> set[str]:
    """The top-level fields of a schema that its canonical text leaves out while null."""
    return {f.name for f in fields(schema) if f.metadata.get(OMIT_NULL, False)}


def _keys(schema: Any, prefix: str = "") -> list[str]:
    """Every dotted key of a schema (dataclass fields, recursively)."""
    out = []
    for f in fields(schema):
        key = f"{prefix}{f.name}"
        out.append(key)
        kind = f.type if isinstance(f.type, type) else None
        if kind is None and f.default_factory is not MISSING:  # a dataclass default
            kind = type(f.default_factory())
        if kind is not None and is_dataclass(kind):
            out += _keys(kind, f"{key}.")
    return out


def _nearest(schema: type, key: str) -> str:
    """'(did you mean sphere.mu?)' for a mistyped key, or nothing when nothing is close."""
    import difflib

    keys = _keys(schema)
    parent, _, leaf = key.rpartition(".")
    siblings = {k.rpartition(".")[2]: k for k in keys if k.rpartition(".")[0] == parent}
    match = difflib.get_close_matches(leaf, list(siblings), n=1, cutoff=0.6)
    if match:
        return f" (did you mean {siblings[match[0]]}?)"
    match = difflib.get_close_matches(key, keys, n=1, cutoff=0.85)
    return f" (did you mean {match[0]}?)" if match else " (not in this study's config)"


def nearest_key(key: str, studies: Sequence[str]) -> str | None:
    """The key of the studies' configs nearest a mistyped one (``sphere.muu`` ->
    ``sphere.mu``), or None when none is close: what a refusal suggests."""
    key = key.lstrip("+~").split("@", 1)[0]
    for study in studies:
        hint = _nearest(registry.get(study).schema, key)
        if hint.startswith(" (did you mean "):
            return hint.removeprefix(" (did you mean ").removesuffix("?)")
    return None


def nearest_name(name: str, names: Sequence[str]) -> str:
    """' (did you mean en02?)' for a mistyped study or scene name, or '' when none is close."""
    import difflib

    match = difflib.get_close_matches(str(name), list(names), n=1, cutoff=0.6)
    return f" (did you mean {match[0]}?)" if match else ""


def applicable(study: str, overrides: Sequence[str]) -> list[str]:
    """The overrides whose full key (or group) exists in this study's config."""
    if not overrides:
        return []
    base = resolve(study).data
    optional = _omittable(registry.get(study).schema)
    keep = []
    for ov in overrides:
        key = ov.split("=", 1)[0].lstrip("+~").split("@", 1)[0]
        if key.split(".")[0] in optional or _optional_key(registry.get(study).schema, key):
            # an optional group or key the default leaves out (control=pd, and its keys:
            # control.omega_n=40; sphere.beta_deg=2)
            keep.append(ov)
            continue
        node: Any = base
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                break
            node = node[part]
        else:
            keep.append(ov)
    return keep


def resolve(study: str, overrides: Sequence[str] = (), only_applicable: bool = False) -> Resolved:
    """Compose and validate one study's config with overrides (memoised in the process, and
    on disk: see :func:`cache_dir`)."""
    return _resolve(study, tuple(str(o) for o in overrides), only_applicable)


@functools.lru_cache(maxsize=512)
def _resolve(study: str, overrides: tuple[str, ...], only_applicable: bool) -> Resolved:
    if study not in registry.STUDIES:
        raise ConfigError("study", study, f"must be one of {', '.join(registry.STUDIES)}"
                          + nearest_name(study, registry.STUDIES))
    refuse_interpolations(overrides)
    refuse_identity(overrides, "study.id", f"{registry.get(study).group}=ID")
    ovs = tuple(applicable(study, overrides) if only_applicable else overrides)
    spec = _cache_spec(study, ovs)
    path = _cache_path(spec)
    if path is not None:
        cached = _load(path, spec, study)
        if cached is not None:
            return cached
    try:
        cfg = compose(study, list(ovs))
    except Exception as e:  # Hydra refused an override: unknown key, bad type, bad syntax
        raise override_error(study, list(ovs), e) from None
    resolved = validate(cfg)
    if resolved.id != study:  # conf/<group>/<study>.yaml names another study
        raise ConfigError("study.id", resolved.id, f"must be {study} (the config chosen)")
    if path is not None:
        _store(path, spec, resolved)
    return resolved


def warm(study: str = "en02") -> None:
    """Compose and validate one study once, bypassing the caches, and register every study's
    schema: Hydra's first composition in a process costs about 0.2 s more than the next, so
    a warm worker does it before forking its jobs (measured: a job's first new config
    resolved in 0.10 s instead of 0.30 s). Its default composition and resolution are then
    kept (:func:`composed`, :func:`resolve`) for the jobs forked while conf/ is unchanged
    (:func:`forget_if_changed`)."""
    register_schemas(*registry.STUDIES)
    validate(compose(study))
    _WARM["stamp"] = _conf_stamp()
    composed(study)
    resolve(study)


def _conf_stamp() -> str:
    """sha256 of conf/ by content (each YAML file's path and bytes): what a composition
    depends on besides the sources (a changed source stops a worker; a changed conf/ file
    does not). Read anew at every call, never by modification time or size: an edit whose
    time was put back (``cp -p``, ``rsync -a``, ``tar x``, ``touch -r``) is an edit. It
    costs about 0.8 ms for conf/ (46 files, 48 kB) and 7 ms for 320 such files, measured
    here on 2 busy cores: a job pays it once or twice per config it resolves."""
    root = str(CONF_DIR)
    files = sorted(os.path.relpath(os.path.join(folder, name), root)
                   for folder, _, names in os.walk(root, followlinks=True)
                   for name in names if name.endswith(".yaml"))
    h = hashlib.sha256()
    for rel in files:
        try:
            data = read_bytes(os.path.join(root, rel))
        except OSError as e:  # what Hydra would meet too: its reason, not the bytes
            data = f"unreadable: {e.strerror}".encode()
        name = rel.encode()
        h.update(len(name).to_bytes(8, "big") + name + len(data).to_bytes(8, "big") + data)
    return h.hexdigest()


_WARM: dict[str, Any] = {}
_COMPOSED: dict[str, DictConfig] = {}


def composed(study: str) -> DictConfig:
    """A study's default composition, once per process: shared, so read it, never change it
    (a sweep's base, a family's links)."""
    if study not in _COMPOSED:
        _COMPOSED[study] = compose(study)
    return _COMPOSED[study]


def forget_if_changed() -> bool:
    """In a job forked from a warm worker: drop the compositions and resolutions it
    inherited when conf/ has changed since the worker kept them (True then), so that a job
    never computes with an older config than a fresh process would compose."""
    stamp = _WARM.get("stamp")
    if stamp is None or stamp == _conf_stamp():
        return False
    _COMPOSED.clear()
    _resolve.cache_clear()
    schemas_of.cache_clear()
    _WARM.clear()
    return True


def cache_dir() -> Path:
    """Where resolved configs are kept between processes: composing with Hydra costs a few
    tenths of a second per study, loading a resolved one a millisecond. Entries are keyed by
    the content of conf/ and of the package's sources, so any edit recomposes.
    ``CREATIO_CONFIG_CACHE`` moves it (``off`` disables it).

    An entry is JSON (never a pickle: loading one runs no code) holding its own key, the
    resolved data, YAML and sha256, and an HMAC-SHA256 of all of it under a random key
    that only this user can read (``.key``, mode 0600, refused if anyone else owns it or
    can read it). An entry is used only when its HMAC, key, sha256 and YAML all check out
    and the typed config rebuilt from its data gives the same data back; anything else
    (damaged, planted, swapped, of another key) is removed and composed anew."""
    root = os.environ.get("CREATIO_CONFIG_CACHE") or Path(
        os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "creatio" / "configs"
    return Path(root)


def _digest(files: list[Path]) -> str:
    h = hashlib.sha256()
    for path in files:
        h.update(str(path).encode())
        h.update(read_bytes(path))
    return h.hexdigest()


def _fingerprint() -> str:
    """sha256 over conf/ by content, read at every call (:func:`_conf_stamp`), and over the
    package sources as this process imported them (hashed once, at import: a process still
    running old code never files its results under the new code's key)."""
    return hashlib.sha256((_conf_stamp() + _PACKAGE_DIGEST).encode()).hexdigest()


#: The fingerprint each cache key of this process was made with (see :func:`_store`).
_SPECS: dict[str, str] = {}
_PACKAGE_DIGEST = _digest(sorted(Path(__file__).resolve().parents[1].rglob("*.py")))


def _cache_spec(study: str, overrides: tuple[str, ...]) -> str:
    """What identifies a resolution: the sources' fingerprint, the study, the overrides."""
    if os.environ.get("CREATIO_CONFIG_CACHE") == "off":
        return ""
    fingerprint = _fingerprint()
    spec = hashlib.sha256("\0".join((fingerprint, study, *overrides)).encode()).hexdigest()
    _SPECS[spec] = fingerprint
    return spec


def _cache_path(spec: str) -> Path | None:
    """The cache entry of a resolution (None when the cache is off)."""
    return cache_dir() / f"{spec[:32]}.json" if spec else None


def _cache_key(create: bool) -> bytes | None:
    """The cache's HMAC key: 32 random bytes in <cache>/.key, readable by this user only
    (None when it is missing and not to be created, or not trustworthy)."""
    import secrets

    path = cache_dir() / ".key"
    try:
        st = path.stat()
    except FileNotFoundError:
        if not create:
            return None
        try:  # exclusive: never replaces a key another process made first (a reader that
            # meets it half written finds 31 bytes or fewer and caches nothing this once)
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "wb") as fh:
                fh.write(secrets.token_bytes(32))
        except FileExistsError:
            pass
        except OSError:
            return None
        return _cache_key(create=False)
    except OSError:
        return None
    if st.st_uid != os.getuid() or st.st_mode & 0o077 or st.st_size != 32:
        return None
    try:
        return read_bytes(path)
    except OSError:
        return None


def _mac(key: bytes, body: dict[str, Any]) -> str:
    import hmac

    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    return hmac.new(key, text.encode(), hashlib.sha256).hexdigest()


def _load(path: Path, spec: str, study: str) -> Resolved | None:
    """A verified cache entry (see cache_dir), or None; a bad one is removed."""
    import hmac

    try:
        entry = json.loads(read_text(path))
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        entry = None
    key = _cache_key(create=False)
    try:
        body = {k: entry[k] for k in ("spec", "study", "data", "yaml", "sha256")}
        ok = (key is not None and hmac.compare_digest(str(entry["mac"]), _mac(key, body))
              and body["spec"] == spec and body["study"] == study
              and hashlib.sha256(body["yaml"].encode()).hexdigest() == body["sha256"])
        if ok:
            obj = from_plain(registry.get(study).schema, body["data"])
            ok = plain(obj) == body["data"]
    except Exception:  # noqa: BLE001 - any entry that does not check out is not used
        ok = False
    if not ok:
        with contextlib.suppress(OSError):
            path.unlink()
        return None
    _SPECS.pop(spec, None)  # found: nothing to store
    return Resolved(study, obj, body["data"], body["yaml"], body["sha256"])


def _store(path: Path, spec: str, resolved: Resolved) -> None:
    """Write one cache entry atomically; a cache that cannot be written is skipped, and so
    is an entry composed while conf/ changed (filed under the content it was not made of)."""
    if _SPECS.pop(spec, None) != _fingerprint():
        return
    key = _cache_key(create=True)
    if key is None:
        return
    body = {"spec": spec, "study": resolved.id, "data": resolved.data,
            "yaml": resolved.yaml, "sha256": resolved.sha256}
    try:
        # the data in its own order (a study's axes and parts are ordered); the MAC is
        # computed over sorted keys, so it does not depend on it
        text = json.dumps({**body, "mac": _mac(key, body)})
    except (TypeError, ValueError):  # a value JSON cannot hold: not cached
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
        tmp.write_text(text)
        os.replace(tmp, path)
    except OSError:
        pass


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    import typing

    return typing.get_type_hints(cls)


def from_plain(cls: type, data: Any) -> Any:
    """A typed config tree (dataclasses, enums) from its plain data, without OmegaConf: what
    a verified cache entry is rebuilt with (a thousandth of validate's cost)."""
    names = {f.name for f in fields(cls)}
    if not isinstance(data, dict) or not set(data) <= names or not (
            names - set(data) <= _omittable(cls)):
        raise ValueError(f"{cls.__name__}: the data's keys are not its fields")
    return cls(**{f.name: _typed(_hints(cls)[f.name], data[f.name]) for f in fields(cls)
                  if f.name in data})


def _typed(tp: Any, value: Any) -> Any:
    import types
    import typing

    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        (tp,) = [a for a in args if a is not type(None)][:1] or [Any]
        return _typed(tp, value)
    if origin is list:
        return [_typed(args[0] if args else Any, v) for v in value]
    if origin is dict:
        return {k: _typed(args[1] if args else Any, v) for k, v in value.items()}
    if isinstance(tp, type) and is_dataclass(tp):
        return from_plain(tp, value)
    if isinstance(tp, type) and issubclass(tp, Enum):
        return tp(value)
    if tp is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def override_error(
    study: str, overrides: Sequence[str], error: Exception, config_name: str | None = None
) -> ConfigError:
    """Find the first override Hydra refuses on its own and name its key, value and reason."""
    for ov in overrides:
        try:
            compose(study, [ov], config_name=config_name)
        except Exception as e:  # noqa: BLE001 - any refusal pins the culprit
            key, _, value = ov.partition("=")
            cause = e.__cause__ or e
            lines = [ln.strip() for ln in str(cause).splitlines() if ln.strip()]
            reason = lines[0]
            if reason.endswith("while composing config:") and len(lines) > 1:
                reason = lines[1]  # Hydra's header; the refusal itself is on the next line
            reason = reword(reason, key.lstrip("+~"), value)
            if reason.startswith("Multiple values for"):  # `+group=x` of a listed group
                reason = (f"the group is in the defaults list already: write "
                          f"{key.lstrip('+~')}={value}")
            if any("Available options" in ln for ln in lines):  # Hydra's list, on one line
                start = next(i for i, ln in enumerate(lines) if "Available options" in ln)
                options = []
                for ln in lines[start + 1:]:
                    if ln.startswith("Config search path"):
                        break
                    options.append(ln)
                reason += f" (available: {', '.join(options)})"
            if any(s in reason for s in ("not in struct", "Could not override", "not in '")):
                schema = (registry.get(study).schema if study in registry.STUDIES
                          else ProbeConfig)
                reason = "unknown key" + _nearest(schema, key.lstrip("+~"))
            return ConfigError(key.lstrip("+~"), value, reason)
    return ConfigError("overrides", list(overrides), str(error).splitlines()[0])


#: What a comma in a single run's value means, and how to write what was meant instead.
SWEEP_HINT = ("a comma makes a sweep: run it with creatio run -m (or snakemake sweep --config "
              "'sweep=[\"{key}={value}\"]'); a list is [{value}]; a decimal point is '.'")


def reword(reason: str, key: str, value: str) -> str:
    """Hydra's refusal of an override in creatio's words where it is cryptic: a comma in a
    single run's value ("Ambiguous value for argument") is a sweep."""
    if reason.startswith("Ambiguous value for argument"):
        return SWEEP_HINT.format(key=key, value=value)
    return reason


def output_root(resolved: Resolved, data_dir: str | Path = "data") -> Path:
    """Default config -> ``data``; anything else -> ``data/runs/<config hash>``."""
    default = resolve(resolved.id)
    data_dir = Path(data_dir)
    return data_dir if default.sha256 == resolved.sha256 else data_dir / "runs" / resolved.key


def plain(obj: Any) -> Any:
    """Dataclass/enum tree to plain Python values (for attrs and JSON)."""
    if is_dataclass(obj):
        return {f.name: plain(getattr(obj, f.name)) for f in fields(obj)
                if not (getattr(obj, f.name) is None and f.metadata.get(OMIT_NULL, False))}
    if isinstance(obj, Enum):
        return obj.value
    if isinstance(obj, dict):
        return {k: plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [plain(v) for v in obj]
    return obj
