"""Explorable scenes: the family of a sphere scene over its declared parameter axes.

A sphere scene may declare axes, ``scene.axes: {sphere: {mu: "range(0, 0.41, 0.01)"}}``
(values in the grammar of ``snakemake sweep``: ``range(...)``, ``0,0.1,0.2`` or a list). Its
family is the Cartesian product of the axes; each member is the scene's config with the
axis keys set in every study it shows (``sphere.mu`` reaches ``bases.en02`` and
``bases.en02r`` of ``compare``), planned from what the page draws exactly as the scene
itself (:func:`creatio.scenes.needs.needs`: frame times only, no energy, no dt / 2 partner).
The page gets a slider per axis and a chart of each member's headline figures (:data:`FIGURES`).

The family is computed the way ``snakemake sweep`` computes points
(:mod:`creatio.pipeline.sweep`: the axis grammar, consecutive batches, a base varied per
point without composing it, refusals recorded with their reason): ``scene_family_batch``
jobs write ``<root>/scenes/<scene>/family/b<size>-<k>.nc`` and the scene's dataset job
gathers them. Each computed member is also kept in a store (``data/scenes/members/``) under
a key of its study configs, what it draws and the code that computes it, so a rerun or a
wider axis computes only the members not computed before.

Refused before anything runs, in one line: an axis key no study of the scene has, a config
group as an axis, studies that disagree on the key's value, and a family whose page would
not fit in :data:`MAX_BYTES` (its size and a hint). A member that the
validation refuses (a dt beyond the friction stability limit) is recorded as refused with
the reason, and the page shows it as such. The scene config's own value of every axis is
always one of the values (inserted when the axis does not list it): the page opens on it.
"""

from __future__ import annotations

import bisect
import dataclasses
import functools
import hashlib
import json
import logging
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import ConfigError

__all__ = [
    "FIGURES",
    "Axis",
    "Family",
    "Member",
    "assemble",
    "attach",
    "compute_family",
    "family_of",
    "flatten_axes",
    "listed_value",
    "plan_family",
    "run_batch",
]

log = logging.getLogger("creatio")

#: Batches a family is cut into by default: one job each, so a 2-core machine runs the whole
#: family at once and pays the start of a job (imports, compiled code) twice, not per member.
FAMILY_BATCHES = 2
#: Largest family planned at all (checked before its members are listed).
MAX_MEMBERS = 10_000
#: Bytes of a page besides its frames: template, viewer, style and the pinned three.js bundle
#: (571 KB minified), rounded up.
PAGE_OVERHEAD = 700_000
#: The largest page the project ships (the issue's limit; here, not in scenes.page, so that
#: planning a family's size loads no xarray).
MAX_BYTES = 5 * 1024 * 1024


def _deg(var: Any) -> float:
    """The last value of an angle history in degrees, whatever unit the dataset states."""
    value = float(var.values[-1])
    return math.degrees(value) if str(var.attrs.get("units", "")) in ("rad", "radian") else value


#: Headline figures of a member run, charted against the axes: name -> (label, unit, how to
#: take it from the run's study dataset). Extrema are over every step (the run's own). The
#: names differ from every readout's (cumulative_spin is a readout over the frames).
FIGURES: dict[str, tuple[str, str, Callable[[Any], float]]] = {
    "final_radius": ("final radius", "m", lambda ds: float(ds.centre_radius.values[-1])),
    "final_lag": ("final lag", "deg", lambda ds: _deg(ds.angular_lag)),
    "final_cumulative_spin": ("cumulative spin", "deg", lambda ds: _deg(ds.cumulative_spin)),
    "min_normal_reaction": ("min N", "N", lambda ds: float(ds.attrs["min_normal_reaction"])),
}
#: What each figure is, for the dataset's long names and the page's tooltips.
FIGURE_MEANING = {
    "final_radius": "horizontal radius of the centre at the run's end",
    "final_lag": "centre azimuth minus pattern angle at the run's end",
    "final_cumulative_spin": "integral of |omega| dt over the run",
    "min_normal_reaction": "smallest normal reaction over every integration step",
}


# ------------------------------------------------------------------------------ planning
@dataclass(frozen=True)
class Axis:
    """One axis: its key (as written for a study: ``sphere.mu``), its typed values, their
    labels, the index of the scene config's own value, and the studies it applies to."""

    key: str
    values: tuple[Any, ...]
    labels: tuple[str, ...]
    base: int
    studies: tuple[str, ...]
    inserted: bool

    @property
    def dim(self) -> str:
        """Its name as a NetCDF variable (dots written ``__``, as in sweep.nc)."""
        return self.key.replace(".", "__")


@dataclass(frozen=True)
class Family:
    """The members of an explorable scene: the product of its axes (row-major), batched."""

    scene: str
    axes: tuple[Axis, ...]
    links: tuple[tuple[str, str, str], ...]  # (study, swept key, key that copies it)
    batch_size: int

    @property
    def shape(self) -> tuple[int, ...]:
        """Values per axis."""
        return tuple(len(a.values) for a in self.axes)

    @property
    def size(self) -> int:
        """Members of the family."""
        return math.prod(self.shape)

    @property
    def base_member(self) -> int:
        """Flat index of the member that is the scene's own config."""
        return self.ravel(tuple(a.base for a in self.axes))

    def ravel(self, idx: Sequence[int]) -> int:
        """Flat (row-major) index of one value index per axis."""
        flat = 0
        for i, n in zip(idx, self.shape, strict=True):
            flat = flat * n + i
        return flat

    def unravel(self, index: int) -> tuple[int, ...]:
        """One value index per axis of a flat member index."""
        out = []
        for n in reversed(self.shape):
            index, i = divmod(index, n)
            out.append(i)
        return tuple(reversed(out))

    def values(self, index: int) -> dict[str, Any]:
        """{axis key: value} of one member."""
        return {a.key: a.values[i] for a, i in zip(self.axes, self.unravel(index), strict=True)}

    def label(self, index: int) -> str:
        """``sphere.mu = 0.3, phases.T = 60`` of one member."""
        return ", ".join(f"{a.key} = {a.labels[i]}"
                         for a, i in zip(self.axes, self.unravel(index), strict=True))

    @property
    def n_batches(self) -> int:
        """Batch jobs of the family."""
        return math.ceil(self.size / self.batch_size)

    def batch_range(self, k: int) -> range:
        """Flat member indices of batch k."""
        return range(k * self.batch_size, min((k + 1) * self.batch_size, self.size))

    def batch_files(self, directory: str | Path) -> list[str]:
        """Every batch file under a scene's directory (named by the batching, as sweeps)."""
        return [f"{directory}/family/b{self.batch_size}-{k:05d}.nc"
                for k in range(self.n_batches)]

    def spec(self) -> list[dict[str, Any]]:
        """The axes as the page and scene.nc record them."""
        return [{"key": a.key, "dim": a.dim, "labels": list(a.labels), "base": a.base,
                 "studies": list(a.studies), "inserted": a.inserted} for a in self.axes]


def flatten_axes(axes: Mapping[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """(dotted key, value spec) of a nested axes mapping; a None or empty leaf is no axis
    (``scene.axes.sphere.mu=null`` removes one)."""
    out: list[tuple[str, Any]] = []
    for name, value in axes.items():
        key = f"{prefix}{name}"
        if isinstance(value, Mapping):
            out += flatten_axes(value, f"{key}.")
        elif value is not None and value != "":
            out.append((key, value))
    return out


def _spec_text(key: str, spec: Any) -> str:
    """The axis as a sweep override ``key=v1,v2`` (a YAML list is a list of choices)."""
    if isinstance(spec, list | tuple):
        if not spec:
            raise ConfigError(f"scene.axes.{key}", list(spec), "lists no value")
        if any(isinstance(v, list | tuple | Mapping) for v in spec):
            raise ConfigError(f"scene.axes.{key}", list(spec), "values must be plain numbers "
                              "or words")
        return f"{key}={','.join(listed_value(v) for v in spec)}"
    return f"{key}={spec}"


def listed_value(value: Any) -> str:
    """One listed value in the sweep grammar: a number as written, a word quoted."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return repr(value)
    text = str(value).replace("\\", "\\\\").replace("'", "\\'")
    return f"'{text}'"


def _typed(key: str, texts: Sequence[str]) -> list[Any]:
    """Each value text to its Hydra type; floats to 12 significant digits (Hydra's float
    ``range`` accumulates 0.15000000000000002 where 0.15 is meant)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    parser = OverridesParser.create()
    out = []
    for text in texts:
        try:
            value = parser.parse_override(f"{key}={text}").value()
        except Exception:  # noqa: BLE001 - kept as text: the member refuses it with a reason
            value = text
        if isinstance(value, float) and math.isfinite(value):
            value = float(f"{value:.12g}")
        out.append(value)
    return out


def _label(value: Any) -> str:
    return repr(value) if isinstance(value, float) else str(value)


def _get(obj: Any, key: str) -> Any:
    """The value at a dotted key of a config tree; KeyError where there is none."""
    node = obj
    for part in key.split("."):
        if dataclasses.is_dataclass(node) and hasattr(node, part):
            node = getattr(node, part)
        elif isinstance(node, Mapping) and part in node:
            node = node[part]
        else:
            raise KeyError(key)
    return node


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, int | float) and isinstance(b, int | float) and not isinstance(a, bool):
        return float(a) == float(b)
    return str(a) == str(b)


def plan_family(obj: Any) -> Family | None:
    """The family a sphere scene config declares (None without axes). Checks every axis
    against the scene's studies and the page size; lists no member."""
    from creatio.pipeline.sweep import MAX_BATCH, parse_axes, study_links

    declared = flatten_axes(obj.scene.axes)
    if not declared:
        return None
    axes: list[Axis] = []
    links: list[tuple[str, str, str]] = []
    for key, spec in declared:
        name = f"scene.axes.{key}"
        try:
            ((_, texts),) = parse_axes([_spec_text(key, spec)])
        except ConfigError as e:
            raise ConfigError(name, spec, e.rule) from None
        if key in [a.key for a in axes]:
            raise ConfigError(name, spec, "is declared twice")
        if math.prod([len(a.values) for a in axes] + [len(texts)]) > MAX_MEMBERS:
            raise ConfigError("scene.axes", f"more than {MAX_MEMBERS:,} members",
                              "is too large for a page: use fewer values")
        own: dict[str, Any] = {}
        for study, base in obj.bases.items():
            if study not in obj.scene.studies:
                continue
            try:
                value = _get(base, key)
            except KeyError:
                continue
            if dataclasses.is_dataclass(value) or isinstance(value, Mapping | list):
                raise ConfigError(name, spec, f"must name a value of {study}'s config "
                                  "(sphere.mu), not a group of values")
            own[study] = value
        if not own:
            raise ConfigError(name, spec, "unknown key: no study of this scene has it "
                              f"(studies: {', '.join(obj.scene.studies)})")
        firsts = list(own.values())
        if any(not _same(v, firsts[0]) for v in firsts[1:]):
            raise ConfigError(name, spec, "the studies of this scene differ on it "
                              f"({', '.join(f'{s}: {v}' for s, v in own.items())}): an "
                              "axis sets it in every one")
        values = _typed(key, texts)
        for i, v in enumerate(values):
            if any(_same(v, w) for w in values[:i]):
                raise ConfigError(name, spec, f"lists {_label(v)} twice")
        base_value = firsts[0]
        if isinstance(base_value, float):
            base_value = float(f"{base_value:.12g}")
        hit = [i for i, v in enumerate(values) if _same(v, base_value)]
        inserted = not hit
        if inserted:  # the page opens on the scene's own config: make it a member
            numeric = all(isinstance(v, int | float) and not isinstance(v, bool)
                          for v in values)
            # a null own value (a feature off: geometry.ribs, the ideal surface) goes last
            if numeric and base_value is not None and values == sorted(values):
                at = bisect.bisect(values, base_value)
            else:
                at = len(values)
            values.insert(at, base_value)
            hit = [at]
        for study in own:
            # (key, the key it copies or None for an expression, the expression's text)
            # of every interpolation in the study's config (study.duration: ${..phases.T})
            for dep, source, text in study_links(obj.bases[study].study.id):
                if source == key and _same(_get(obj.bases[study], dep), base_value):
                    links.append((study, key, dep))
                elif source is None and key in text:
                    raise ConfigError(name, spec, f"{study}'s {dep} follows it through an "
                                      f"expression ({text}) a family cannot vary")
        labels = [_label(v) for v in values]
        if base_value is None:  # named by what null means (the scene registry's word)
            labels[hit[0]] = _null_label(obj, key)
        axes.append(Axis(key, tuple(values), tuple(labels), hit[0], tuple(own), inserted))
    n = math.prod(len(a.values) for a in axes)
    size = min(MAX_BATCH, max(1, math.ceil(n / FAMILY_BATCHES)))
    family = Family(str(obj.scene.id), tuple(axes), tuple(links), size)
    _check_size(obj, family)
    return family


def _null_label(obj: Any, key: str) -> str:
    """The slider's label of a null value of an axis key: the scene registry's word for it
    (``ideal`` for geometry.ribs), else ``null``."""
    from creatio.scenes import registry

    return dict(registry.get(str(obj.scene.id)).null_labels).get(key, "null")


def _frames(obj: Any, family: Family) -> int:
    """Most frames a member can have (its span: the longest study duration it reaches)."""
    interval = obj.scene.playback.interval
    longest = max(obj.bases[s].study.duration for s in obj.scene.studies)
    durations = {key for _, key, dep in family.links if dep == "study.duration"}
    for axis in family.axes:
        if axis.key == "study.duration" or axis.key in durations:
            longest = max([longest, *(float(v) for v in axis.values if isinstance(v, int | float)
                                      and not isinstance(v, bool) and math.isfinite(v))])
    return round(longest / interval) + 1


def member_bytes(obj: Any, family: Family) -> int:
    """Bytes one member adds to the page (base64 of float64): per study and frame the
    centre, orientation if drawn, the three phases and each readout."""
    s = obj.scene
    columns = 3 + (4 if s.rotation else 0) + 3 + len([r for r in s.readouts if str(r) != "time"])
    return math.ceil(len(s.studies) * _frames(obj, family) * columns * 8 * 4 / 3)


def _check_size(obj: Any, family: Family) -> None:
    """Refuse a family whose page would pass the page limit, before anything is computed."""
    per = member_bytes(obj, family)
    own = getattr(obj.scene, "extra_page_bytes", None)  # what the scene adds (its strain)
    extra = own(len(obj.scene.studies), _frames(obj, family)) if own is not None else 0
    total = PAGE_OVERHEAD + extra + (family.size + 1) * per  # + members and own frames
    if total > MAX_BYTES:
        fit = max(0, (MAX_BYTES - PAGE_OVERHEAD - extra) // per - 1)
        raise ConfigError("scene.axes", f"{family.size} members",
                          f"the page would be about {total / 2**20:.1f} MB, above its "
                          f"{MAX_BYTES / 2**20:.0f} MB limit ({per / 1e3:.0f} kB a member): "
                          f"use fewer values (about {fit} members fit), fewer readouts, or "
                          "fewer frames (a lower scene.playback.fps)")


def family_of(resolved: Any) -> Family | None:
    """The family of a resolved scene config (None for a scene without axes)."""
    if getattr(resolved.obj.scene, "axes", None) is None:
        return None
    return plan_family(resolved.obj)


# ------------------------------------------------------------------------------- members
@dataclass(frozen=True)
class _Base:
    """A member's study config, shaped like the resolved base compute.sphere_scene reads."""

    obj: Any
    sha256: str


@dataclass(frozen=True)
class Member:
    """One member: the scene config with its axis values set in every study it shows; or
    the reason the validation refused it."""

    id: str
    index: int
    obj: Any
    refused: str
    key: str

    @property
    def entry(self) -> Any:
        """The registry entry of the scene."""
        from creatio.scenes import registry

        return registry.get(self.id)

    @functools.cached_property
    def bases(self) -> dict[str, _Base]:
        """Each study's config (point key as its hash: no reuse of study datasets)."""
        return {name: _Base(cfg, _point_key(cfg)) for name, cfg in self.obj.bases.items()}


def _point_key(obj: Any) -> str:
    """sha256 of a config tree as canonical JSON (as sweeps key their points)."""
    from creatio.pipeline.config import plain

    return hashlib.sha256(json.dumps(plain(obj), sort_keys=True, default=str).encode()
                          ).hexdigest()


@functools.lru_cache(maxsize=1)
def _code() -> str:
    """The code a member's numbers depend on: the datasets' (model, dynamics, studies) and
    the scenes' own, as the rules' code= versions."""
    from creatio.pipeline.planning import code_version

    return code_version("datasets") + code_version("scenes")


def member(resolved: Any, family: Family, index: int) -> Member:
    """The member at a flat index: each study varied (creatio.studies.schema.vary, checked),
    then the scene's own rules; a refusal is kept as the member's reason."""
    from creatio.studies.schema import vary

    obj = resolved.obj
    values = family.values(index)
    bases = dict(obj.bases)
    try:
        for study in obj.scene.studies:
            changes = {a.key: values[a.key] for a in family.axes if study in a.studies}
            changes.update({dep: values[key] for s, key, dep in family.links if s == study})
            if changes:
                try:
                    bases[study] = vary(obj.bases[study], changes)
                except ConfigError as e:
                    raise ConfigError(f"bases.{study}.{e.key}", e.value, e.rule) from None
        scene = dataclasses.replace(obj.scene, axes={})
        varied = dataclasses.replace(obj, scene=scene, bases=bases)
        varied.check()
    except ConfigError as e:
        return Member(resolved.id, index, None, str(e).removeprefix("invalid config: "), "")
    s = varied.scene
    text = json.dumps({
        "runs": [[name, _point_key(bases[name])] for name in s.studies],
        "interval": s.playback.interval, "rotation": s.rotation,
        "readouts": [str(r) for r in s.readouts], "code": _code()}, sort_keys=True)
    return Member(resolved.id, index, varied, "", hashlib.sha256(text.encode()).hexdigest())


def compute_member(m: Member) -> Any:
    """One member's frames (compute.sphere_scene on its config) with its headline figures
    per study from the run's own dataset."""
    import numpy as np

    from creatio.scenes.compute import run_need, sphere_scene
    from creatio.scenes.needs import needs

    computed = {need.study: run_need(m.obj.bases[need.study], need) for need in needs(m)}
    ds = sphere_scene(m, computed=computed)
    for name, (label, unit, take) in FIGURES.items():
        ds[name] = ("run", np.array([take(computed[str(r)][0]) for r in ds.run.values]),
                    {"long_name": f"{label}: {FIGURE_MEANING[name]}", "units": unit})
    ds.attrs["member_key"] = m.key
    return ds


def _store_path(store: str | Path, key: str) -> Path:
    return Path(store) / f"{key[:32]}.nc"


@dataclass(frozen=True)
class _Var:
    values: Any
    attrs: dict[str, Any]


@dataclass(frozen=True)
class _Stored:
    """A stored member as :func:`assemble` reads it (its variables' values and attributes,
    its sizes and attributes), read with netCDF4 alone: what xarray gives for these files
    (NaN kept as NaN, text as str) in half the time, 21 members a batch."""

    variables: dict[str, _Var]
    sizes: dict[str, int]
    attrs: dict[str, Any]

    def __getitem__(self, name: str) -> _Var:
        return self.variables[name]


#: Attributes xarray moves into a variable's encoding when it reads a file.
_ENCODING_ATTRS = ("_FillValue", "missing_value", "coordinates")


def _read_stored(path: Path) -> _Stored:
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        variables = {
            name: _Var(var[...], {a: var.getncattr(a) for a in var.ncattrs()
                                  if a not in _ENCODING_ATTRS})
            for name, var in nc.variables.items()}
        return _Stored(variables, {k: len(d) for k, d in nc.dimensions.items()},
                       {a: nc.getncattr(a) for a in nc.ncattrs()})


def _from_store(store: str | Path | None, key: str) -> Any | None:
    """A stored member whose recorded key is this one; None if absent, damaged or another."""
    if store is None:
        return None
    path = _store_path(store, key)
    if not path.is_file():
        return None
    try:
        ds = _read_stored(path)
    except Exception:  # noqa: BLE001 - a damaged entry is recomputed and rewritten
        log.warning("scene member store: %s is unreadable; computing it again", path)
        return None
    if ds.attrs.get("member_key") != key:
        log.warning("scene member store: %s holds another member; computing it again", path)
        return None
    return ds


def _to_store(store: str | Path | None, ds: Any) -> None:
    """Keep a computed member (temporary file, then renamed: a kill leaves no partial one)."""
    if store is None:
        return
    path = _store_path(store, ds.attrs["member_key"])
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        ds.to_netcdf(tmp, engine="netcdf4")
        os.replace(tmp, path)
    except OSError as e:  # a full or read-only store: the family is still computed
        log.warning("scene member store: %s not kept (%s)", path, e)
    finally:
        tmp.unlink(missing_ok=True)


# ----------------------------------------------------------------------------- assembly
#: Per member variables with a frame dimension, and per study scalars, as scene.nc holds them.
FRAME_VARS = ("centre", "quaternion", "phase_r", "phase_a", "inclination")
RUN_VARS = ("frames_run", "stop_time", "sphere_radius", "R0", "dR", "A", "Kr", "Ka",
            *FIGURES)
RUN_TEXT = ("status", "direction", "source")


def assemble(rows: Sequence[tuple[int, Any, str]], runs: Sequence[str], frames: int,
             rotation: bool, readouts: Sequence[str]) -> Any:
    """One dataset of members (dimension ``member``): each row (flat index, member frames
    dataset or None, reason refused) padded with NaN to ``frames``."""
    import numpy as np
    import xarray as xr

    n, r = len(rows), len(runs)
    shapes = {"centre": (3,), "quaternion": (4,), "phase_r": (), "phase_a": (),
              "inclination": ()}
    names = [v for v in FRAME_VARS if v != "quaternion" or rotation] + list(readouts)
    arrays = {v: np.full((n, r, frames, *shapes.get(v, ())), np.nan) for v in names}
    scalars = {v: np.full((n, r), np.nan) for v in RUN_VARS}
    texts = {v: np.full((n, r), "", dtype=object) for v in RUN_TEXT}
    message = np.full(n, "", dtype=object)
    attrs: dict[str, dict] = {}
    # a rib surface's splines (compute.skin_rows), NaN for a member of the ideal surface
    skins = {v: ds[v] for _, ds, _ in rows if ds is not None and "skin_c" in ds.variables
             for v in ("skin_c", "skin_s")}
    width = next((int(np.shape(var.values)[-1]) for var in skins.values()), 0)
    skin = {v: np.full((n, r, width), np.nan) for v in skins}
    for i, (_, ds, reason) in enumerate(rows):
        if ds is None:
            message[i] = reason
            texts["status"][i, :] = "refused"
            continue
        k = ds.sizes["frame"]
        for v in names:
            arrays[v][i, :, :k] = ds[v].values
            attrs.setdefault(v, dict(ds[v].attrs))
        for v in RUN_VARS:
            scalars[v][i] = ds[v].values
            attrs.setdefault(v, dict(ds[v].attrs))
        for v in RUN_TEXT:
            texts[v][i] = [str(x) for x in ds[v].values]
        for v in skin:
            if v in ds.variables:
                skin[v][i] = ds[v].values
                attrs.setdefault(v, dict(ds[v].attrs))
    dims = {"centre": ("member", "run", "frame", "component"),
            "quaternion": ("member", "run", "frame", "quaternion_component")}
    data: dict[str, Any] = {
        v: (dims.get(v, ("member", "run", "frame")), a, attrs.get(v, {}))
        for v, a in arrays.items()}
    data.update({v: (("member", "run"), a, attrs.get(v, {})) for v, a in scalars.items()})
    data.update({v: (("member", "run"), a.astype(str)) for v, a in texts.items()})
    data.update({v: (("member", "run", "mesh_alpha"), a, attrs.get(v, {}))
                 for v, a in skin.items()})
    data["message"] = ("member", message.astype(str),
                       {"long_name": "why the validation refused the member (empty: it ran)"})
    return xr.Dataset(data, coords={"member": ("member", [i for i, _, _ in rows]),
                                    "run": ("run", list(runs))})


def _layout(resolved: Any, family: Family) -> tuple[list[str], int, bool, list[str]]:
    s = resolved.obj.scene
    readouts = [str(r) for r in s.readouts if str(r) != "time"]
    return list(s.studies), _frames(resolved.obj, family), s.rotation, readouts


def run_batch(resolved: Any, family: Family, k: int, out: str | Path | None = None,
              store: str | Path | None = None, progress: Callable[[str], None] | None = None
              ) -> Any:
    """Batch k of a family: each member taken from the store or computed (and kept), or
    refused with its reason; written to ``out`` when given. Returns the batch dataset."""
    say = progress or log.info
    rows: list[tuple[int, Any, str]] = []
    counts = {"computed": 0, "reused": 0, "refused": 0}
    compute_s = 0.0
    indices = list(family.batch_range(k))
    t0 = last = time.perf_counter()
    for done, index in enumerate(indices, start=1):
        m = member(resolved, family, index)
        if m.refused:
            rows.append((index, None, m.refused))
            counts["refused"] += 1
        else:
            ds = _from_store(store, m.key)
            if ds is None:
                tc = time.perf_counter()
                ds = compute_member(m)
                compute_s += time.perf_counter() - tc
                _to_store(store, ds)
                counts["computed"] += 1
            else:
                counts["reused"] += 1
            rows.append((index, ds, ""))
        now = time.perf_counter()
        if now - last > 2.0 or done == len(indices):
            rate = done / max(now - t0, 1e-9)
            say(f"scene {resolved.id} family batch {k + 1}/{family.n_batches}: "
                f"{done}/{len(indices)} members, {rate:.1f}/s, "
                f"ETA {(len(indices) - done) / rate:.0f} s ({counts['computed']} computed, "
                f"{counts['reused']} reused, {counts['refused']} refused)")
            last = now
    ds = assemble(rows, *_layout(resolved, family))
    ds.attrs.update({"scene": resolved.id, "config_sha256": resolved.sha256, "batch": k,
                     "batch_size": family.batch_size, **counts, "compute_s": compute_s,
                     "wall_s": time.perf_counter() - t0})
    if out is not None:
        from creatio.store.netcdf import write_dataset

        write_dataset(ds, out)
    return ds


def compute_family(resolved: Any, family: Family, batches: Sequence[str | Path] = (),
                   store: str | Path | None = None) -> Any:
    """Every member: read from the batch files when given (the workflow's), else every batch
    computed here (with the store). One dataset over all members, in flat order."""
    import xarray as xr

    from creatio.store.netcdf import read_dataset

    if batches:
        parts = []
        for path in batches:
            ds, _ = read_dataset(path)
            if ds.attrs.get("config_sha256") != resolved.sha256:
                raise ConfigError("family", str(path), "was computed for another config of "
                                  f"scene {resolved.id}: rerun its batch job")
            parts.append(ds)
    else:
        parts = [run_batch(resolved, family, k, store=store) for k in range(family.n_batches)]
    ds = xr.concat(parts, dim="member", data_vars="all", coords="minimal",
                   combine_attrs="drop_conflicts")
    if list(ds.member.values) != list(range(family.size)):
        raise ConfigError("family", f"{ds.sizes['member']} members",
                          f"the batches do not hold the {family.size} members of the family")
    counts = {c: int(sum(int(p.attrs.get(c, 0)) for p in parts))
              for c in ("computed", "reused", "refused")}
    ds.attrs = counts
    return ds


def attach(scene_ds: Any, family: Family, members: Any) -> Any:
    """The scene dataset with its family: ``family_<name>`` per member, one variable per
    axis giving each member's value, the axes and the scene's own member as attributes.
    The frames run to the longest member (the scene's own padded with NaN beyond its end)."""
    import numpy as np

    frames = max(scene_ds.sizes["frame"], members.sizes["frame"])
    interval = float(scene_ds.attrs["frame_interval"])
    if scene_ds.sizes["frame"] < frames:
        scene_ds = scene_ds.pad(frame=(0, frames - scene_ds.sizes["frame"]))
    if members.sizes["frame"] < frames:
        members = members.pad(frame=(0, frames - members.sizes["frame"]))
    scene_ds = scene_ds.assign_coords(time=("frame", np.arange(frames) * interval,
                                            scene_ds.time.attrs))
    from creatio.store import cf

    out = scene_ds.copy()
    for name, var in members.data_vars.items():
        var = var.copy()
        described = cf.VARIABLES.get(str(name), (str(name).replace("_", " "), None))
        var.attrs["long_name"] = f"{var.attrs.get('long_name') or described[0]}, per member"
        if var.dtype.kind in "fiu" and "units" not in var.attrs and described[1]:
            var.attrs["units"] = described[1].replace(cf.L, "m")  # sphere scenes are in m
        out[f"family_{name}"] = var
    out = out.assign_coords(member=("member", members.member.values, {
        "long_name": "index of the member in the row-major product of the axes",
        "units": "1"}))
    for a in family.axes:
        idx = [family.unravel(m)[family.axes.index(a)] for m in range(family.size)]
        values = [a.values[i] for i in idx]
        units = cf.CONFIG_UNITS.get(a.key)
        numeric = units is not None and all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in values)
        # a value of a key whose unit is known is a number; any other is written as its label
        out[f"family_{a.dim}"] = (
            "member", np.array(values, float) if numeric else
            np.array([a.labels[i] for i in idx], dtype=object).astype(str),
            {"long_name": f"{a.key} of each member", **({"units": units} if numeric else {})})
    out.attrs.update({
        "family_axes": json.dumps(family.spec()),
        "family_base_member": family.base_member,
        "family_size": family.size,
        "family_computed": int(members.attrs.get("computed", 0)),
        "family_reused": int(members.attrs.get("reused", 0)),
        "family_refused": int(members.attrs.get("refused", 0)),
        "family_figures": json.dumps({k: [v[0], v[1], FIGURE_MEANING[k]]
                                      for k, v in FIGURES.items()}),
    })
    return out
