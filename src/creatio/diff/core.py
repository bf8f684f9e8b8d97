"""`creatio diff A B`: compare two datasets, two trees (data dirs, releases) or two releases.

Like nccmp with tolerances, plus what creatio records: per variable the largest absolute and
relative differences, their RMS, where the largest sits and how many values are beyond
tolerance; structure (dimensions, coordinates, variables, dtypes, units); attributes; the
resolved configs key by key; provenance; and the JSON report figures, metrics-diff style.

A value differs when |a - b| > atol + rtol * |b| (b from B, as numpy.isclose; NaN vs NaN is
equal, NaN vs a number is not). Exit status as nccmp: 0 nothing beyond tolerance, 1
differences (or a damaged release), 2 error.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import math
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.errors import Parser
from creatio.pipeline.provenance import VOLATILE_ATTRS
from creatio.pipeline.release import (
    MANIFEST,
    ReleaseError,
    find_release,
    is_version,
    read_manifest,
    sha256_file,
    verify_release,
)
from creatio.store.atomic import atomic_write
from creatio.store.regular import read_json

__all__ = ["DamagedRelease", "DiffError", "Tolerance", "compare_arrays", "diff", "main",
           "render_text"]

FORMAT = "creatio-diff/1"
CATEGORIES = ("structure", "data", "config", "attrs", "reports", "provenance", "added")
COUNTED = ("structure", "data", "config", "attrs", "reports")
PROVENANCE_ATTRS = ("source", "creatio_version", "git_commit", "git_dirty")
CONFIG_ATTRS = ("config_yaml", "config_sha256")
ROWS = 6  # rows per section in the text report (all with --verbose)


class DiffError(Exception):
    """The comparison cannot be made (unreadable file, missing release, bad argument)."""


class DamagedRelease(DiffError):
    """A release side does not match its manifest (a file missing, changed or unlisted):
    nothing is compared against it, and the exit status is 1, as `creatio release verify`'s."""


# ------------------------------------------------------------------------------ tolerance
@dataclass(frozen=True)
class Tolerance:
    """Global atol/rtol and per-name overrides (fnmatch patterns; the last match wins)."""

    atol: float = 0.0
    rtol: float = 0.0
    overrides: tuple[tuple[str, float, float], ...] = ()

    def get(self, name: str) -> tuple[float, float]:
        """(atol, rtol) for a variable, attribute or report key (or any dotted prefix of it)."""
        parts = name.split(".")
        prefixes = [".".join(parts[: i + 1]) for i in range(len(parts))]
        for pattern, atol, rtol in reversed(self.overrides):
            if any(fnmatch.fnmatchcase(p, pattern) for p in prefixes):
                return atol, rtol
        return self.atol, self.rtol

    def as_dict(self) -> dict[str, Any]:
        """The tolerances as JSON."""
        return {"atol": self.atol, "rtol": self.rtol,
                "overrides": {p: {"atol": a, "rtol": r} for p, a, r in self.overrides}}


def parse_tol(text: str, rtol: float) -> tuple[str, float, float]:
    """NAME=ATOL[,RTOL] -> (NAME, ATOL, RTOL); RTOL defaults to the global rtol."""
    name, sep, values = text.partition("=")
    parts = values.split(",")
    try:
        if not sep or not name or len(parts) > 2:
            raise ValueError
        atol = float(parts[0])
        r = float(parts[1]) if len(parts) == 2 else rtol
    except ValueError:
        raise DiffError(f"--tol {text!r}: expected NAME=ATOL or NAME=ATOL,RTOL, e.g. "
                        "fd_error=1e-12,1e-6") from None
    if not (atol >= 0 and r >= 0 and math.isfinite(atol) and math.isfinite(r)):
        raise DiffError(f"--tol {text!r}: tolerances must be finite and >= 0")
    return name, atol, r


# ------------------------------------------------------------------------------ values
def _jsonable(x: Any) -> Any:
    """Plain JSON value: numpy scalars unwrapped, non-finite floats as 'nan'/'inf'/'-inf'."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    if isinstance(x, bytes):
        return x.decode(errors="replace")
    return x


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float | np.integer | np.floating) and not isinstance(
        x, bool | np.bool_)


def compare_arrays(a: Any, b: Any, atol: float = 0.0,
                   rtol: float = 0.0) -> tuple[dict[str, Any], int | None]:
    """Statistics (max abs, max rel |a-b|/|b|, RMS, counts beyond tolerance, NaN mismatches;
    unequal count for strings) of two same-shape arrays, and the flat index of the largest."""
    a, b = np.asarray(a), np.asarray(b)
    n = int(a.size)
    if a.dtype.kind in "biufc" and b.dtype.kind in "biufc":
        kind = np.complex128 if "c" in (a.dtype.kind + b.dtype.kind) else np.float64
        x, y = a.astype(kind).ravel(), b.astype(kind).ravel()
        with np.errstate(all="ignore"):
            nan_a, nan_b = np.isnan(x), np.isnan(y)
            both = ~nan_a & ~nan_b
            same = x == y
            absd = np.where(both & ~same, np.abs(x - y), 0.0)
            absd = np.where(np.isnan(absd), np.inf, absd)
            rel = np.where(absd == 0.0, 0.0, absd / np.abs(y))
            rel = np.where(np.isnan(rel), np.inf, rel)
            infinite = ~same & (np.isinf(x) | np.isinf(y))  # equal only to the same infinity
            over = both & ((absd > atol + rtol * np.abs(y)) | infinite)
            mismatch = nan_a ^ nan_b
            rms = float(np.sqrt(np.mean(absd[both] ** 2))) if both.any() else 0.0
        differ = int(n - np.count_nonzero(same | (nan_a & nan_b)))
        beyond = int(np.count_nonzero(over | mismatch))
        max_abs = float(absd.max()) if n else 0.0
        where = (int(np.argmax(absd)) if max_abs > 0 else
                 int(np.argmax(mismatch)) if mismatch.any() else None)
        stats: dict[str, Any] = {
            "n": n, "n_differ": differ, "n_beyond": beyond,
            "max_abs": max_abs, "max_rel": float(rel.max()) if n else 0.0, "rms": rms,
            "nan_mismatch": int(mismatch.sum()),
            "nan_appeared": int(np.count_nonzero(nan_b & ~nan_a)),
            "nan_disappeared": int(np.count_nonzero(nan_a & ~nan_b)),
        }
        if where is not None:
            stats["a_at"], stats["b_at"] = x[where].item(), y[where].item()
    else:
        try:
            ne = np.asarray(a != b, dtype=bool).ravel()
        except (TypeError, ValueError):  # no elementwise comparison (e.g. number vs string)
            ne = np.ones(n, bool)
        if ne.shape != (n,):
            ne = np.ones(n, bool)
        differ = int(np.count_nonzero(ne))
        where = int(np.argmax(ne)) if differ else None
        stats = {"n": n, "n_differ": differ, "n_beyond": differ}
        if where is not None and a.shape == b.shape:
            stats["a_at"], stats["b_at"] = a.ravel()[where].item(), b.ravel()[where].item()
    stats["status"] = ("identical" if not stats["n_differ"] and not stats.get("nan_mismatch")
                       else "beyond" if stats["n_beyond"] else "within")
    stats["atol"], stats["rtol"] = atol, rtol
    return stats, where


def _location(da: xr.DataArray, where: int | None) -> dict[str, Any]:
    """{dim: coordinate value (or index)} of a flat index into da."""
    if where is None or da.ndim == 0:
        return {}
    out = {}
    for dim, i in zip(da.dims, np.unravel_index(where, da.shape), strict=True):
        out[str(dim)] = da[dim].values[i].item() if dim in da.coords else int(i)
    return out


def _values_differ(old: Any, new: Any, atol: float, rtol: float) -> tuple[bool, bool]:
    """(differs at all, differs beyond tolerance) for two attribute or report values."""
    if _is_number(old) and _is_number(new):
        stats, _ = compare_arrays(np.array([old]), np.array([new]), atol, rtol)
        return stats["status"] != "identical", stats["status"] == "beyond"
    if isinstance(old, np.ndarray) or isinstance(new, np.ndarray):
        a, b = np.asarray(old), np.asarray(new)
        if a.shape != b.shape:
            return True, True
        stats, _ = compare_arrays(a, b, atol, rtol)
        return stats["status"] != "identical", stats["status"] == "beyond"
    try:
        differs = bool(np.any(old != new))
    except (TypeError, ValueError):
        differs = True
    return differs, differs


def _flatten(obj: Any, prefix: str = "", index_lists: bool = True) -> dict[str, Any]:
    """Nested dicts (and lists, as key[i]) to {dotted.key: leaf}."""
    out: dict[str, Any] = {}
    if isinstance(obj, dict) and obj:
        for k, v in obj.items():
            out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k), index_lists))
    elif isinstance(obj, list) and obj and (
            index_lists or any(isinstance(v, dict | list) for v in obj)):
        for i, v in enumerate(obj):
            out.update(_flatten(v, f"{prefix}[{i}]", index_lists))
    else:
        out[prefix] = obj
    return out


def _rel_change(old: float, new: float) -> float | None:
    if old == new:
        return 0.0
    return (new - old) / abs(old) if old else None


# ------------------------------------------------------------------------------ datasets
def _structure(kind: str, name: str, message: str, old: Any = None, new: Any = None) -> dict:
    return {"kind": kind, "name": name, "old": old, "new": new, "message": message}


def _attr_entry(var: str | None, name: str, old: Any, new: Any, beyond: bool,
                category: str) -> dict[str, Any]:
    entry: dict[str, Any] = {"variable": var, "name": name, "old": old, "new": new,
                             "beyond": beyond, "category": category}
    if _is_number(old) and _is_number(new):
        entry["change"] = float(new) - float(old)
    return entry


def _diff_attrs(a: dict, b: dict, var: str | None, tol: Tolerance, all_attrs: bool,
                skip: Iterable[str] = ()) -> list[dict[str, Any]]:
    """Changed, added and removed attributes, each with its category."""
    missing = object()
    out = []
    for name in sorted(set(a) | set(b)):
        if name in skip:
            continue
        volatile = name in VOLATILE_ATTRS
        if volatile and not all_attrs:
            continue
        old, new = a.get(name, missing), b.get(name, missing)
        provenance = var is None and (name in PROVENANCE_ATTRS or name.startswith("version_"))
        category = "provenance" if provenance else "attrs"
        if old is missing and not provenance:  # new since A: reported, not a difference
            category = "added"
        if old is missing or new is missing:
            out.append(_attr_entry(var, name, None if old is missing else old,
                                   None if new is missing else new, True, category))
            continue
        differs, beyond = _values_differ(old, new, *tol.get(name))
        if differs:
            out.append(_attr_entry(var, name, old, new, beyond, category))
    return out


def _diff_config(a: dict, b: dict) -> list[dict[str, Any]]:
    """Resolved configs compared key by key (flattened: sphere.mu)."""
    missing = object()
    fa, fb = _flatten(a or {}, index_lists=False), _flatten(b or {}, index_lists=False)
    out = []
    for key in sorted(set(fa) | set(fb)):
        old, new = fa.get(key, missing), fb.get(key, missing)
        if old is missing:
            out.append({"key": key, "old": None, "new": new, "change": "added"})
        elif new is missing:
            out.append({"key": key, "old": old, "new": None, "change": "removed"})
        elif _values_differ(old, new, 0.0, 0.0)[0]:
            out.append({"key": key, "old": old, "new": new, "change": "changed"})
    return out


def _compare_variable(name: str, va: xr.DataArray, vb: xr.DataArray,
                      tol: Tolerance) -> tuple[dict[str, Any] | None, str | None]:
    """Statistics of one variable, or the reason it could not be compared."""
    note = None
    if va.shape != vb.shape:
        try:
            va, vb = xr.align(va.reset_coords(drop=True), vb.reset_coords(drop=True),
                              join="inner")
        except (ValueError, TypeError):
            return None, f"shape {va.shape} -> {vb.shape}"
        if va.shape != vb.shape or va.size == 0:
            return None, f"shape {va.shape} -> {vb.shape}, no common coordinates"
        note = f"compared on the {va.size} points with common coordinates"
    stats, where = compare_arrays(va.values, vb.values, *tol.get(name))
    stats["at"] = _location(vb, where)
    if note:
        stats["compared_on"] = note
    return stats, None


def diff_datasets(a: xr.Dataset, b: xr.Dataset, config_a: dict, config_b: dict,
                  tol: Tolerance, all_attrs: bool = False) -> dict[str, Any]:
    """Everything that differs between two datasets (A old, B new), by category. A is first
    mapped onto B's conventions where a documented change explains a difference
    (creatio.diff.conventions): those changes are reported as provenance."""
    from creatio.diff.conventions import apply_conventions, encoding_notes

    encoding = encoding_notes(a, b)
    a, conventions = apply_conventions(a, b)
    structure: list[dict[str, Any]] = []
    for dim in sorted(set(a.sizes) | set(b.sizes), key=str):
        na, nb = a.sizes.get(dim), b.sizes.get(dim)
        if na is None:
            structure.append(_structure("dim_added", dim, f"dimension {dim} added ({nb})",
                                        None, nb))
        elif nb is None:
            structure.append(_structure("dim_removed", dim, f"dimension {dim} removed ({na})",
                                        na, None))
        elif na != nb:
            structure.append(_structure("dim_changed", dim, f"dimension {dim}: {na} -> {nb}",
                                        na, nb))
    data: dict[str, Any] = {}
    not_compared: list[dict[str, str]] = []
    attrs: list[dict[str, Any]] = []
    names_a, names_b = set(a.variables), set(b.variables)
    for name in sorted(names_a - names_b, key=str):
        what = "coordinate" if name in a.dims else "variable"
        structure.append(_structure(f"{what}_removed", name, f"{what} {name} removed"))
    added: list[str] = []
    for name in sorted(names_b - names_a, key=str):
        what = "coordinate" if name in b.dims else "variable"
        if what == "variable" and all(d in a.dims for d in b[name].dims):
            added.append(f"variable {name}")  # a new output on the same dimensions
        else:
            structure.append(_structure(f"{what}_added", name, f"{what} {name} added"))
    compared = 0
    for name in sorted(names_a & names_b, key=str):
        va, vb = a[name], b[name]
        index = name in a.dims and name in b.dims
        if va.dims != vb.dims:
            structure.append(_structure("dims", name, f"{name} dimensions {va.dims} -> "
                                        f"{vb.dims}", list(va.dims), list(vb.dims)))
            not_compared.append({"name": name, "reason": "dimensions changed"})
            continue
        if va.dtype != vb.dtype:
            structure.append(_structure("dtype", name, f"{name} dtype {va.dtype} -> {vb.dtype}",
                                        str(va.dtype), str(vb.dtype)))
        ua, ub = va.attrs.get("units"), vb.attrs.get("units")
        if ua != ub:
            structure.append(_structure("units", name, f"{name} units {ua!r} -> {ub!r}", ua, ub))
        attrs += _diff_attrs(va.attrs, vb.attrs, name, tol, all_attrs, skip=("units",))
        if index and va.shape != vb.shape:
            old, new = va.values.tolist(), vb.values.tolist()
            old_set, new_set = set(old), set(new)
            gained = [v for v in new if v not in old_set]
            removed = [v for v in old if v not in new_set]
            structure.append(_structure(
                "coordinate_values", name,
                f"coordinate {name}: {len(removed)} values removed {removed[:4]}, "
                f"{len(gained)} added {gained[:4]}", removed, gained))
            continue
        stats, reason = _compare_variable(name, va, vb, tol)
        if stats is None:
            not_compared.append({"name": name, "reason": reason or ""})
            continue
        compared += 1
        if index and stats["status"] == "beyond":
            structure.append(_structure(
                "coordinate_values", name,
                f"coordinate {name} values differ: {stats['n_beyond']}/{stats['n']} beyond "
                f"tolerance, max abs {_num(stats.get('max_abs'))}", None, None))
        elif stats["status"] != "identical":
            data[name] = stats
    global_attrs = _diff_attrs(a.attrs, b.attrs, None, tol, all_attrs, skip=CONFIG_ATTRS)
    attrs = global_attrs + attrs
    added += [f"attribute {x['variable'] + ':' if x['variable'] else ''}{x['name']} = "
              f"{_val(x['new'], 30)}" for x in attrs if x["category"] == "added"]
    config_all = _diff_config(config_a, config_b)
    added += [f"config {c['key']} = {_val(c['new'], 30)}" for c in config_all
              if c["change"] == "added"]
    config = [c for c in config_all if c["change"] != "added"]
    sha_a, sha_b = a.attrs.get("config_sha256"), b.attrs.get("config_sha256")
    if not config_all and sha_a != sha_b:
        config.append({"key": "config_sha256", "old": sha_a, "new": sha_b, "change": "changed"})
    provenance = [x for x in attrs if x["category"] == "provenance"] + conventions + encoding
    result: dict[str, Any] = {
        "kind": "dataset",
        "structure": structure,
        "data": data,
        "not_compared": not_compared,
        "variables_compared": compared,
        "config": config,
        "attrs": [x for x in attrs if x["category"] == "attrs"],
        "provenance": provenance,
        "added": added,
    }
    result["counts"] = {
        "structure": len(structure),
        "data": sum(1 for s in data.values() if s["status"] == "beyond"),
        "config": len(config),
        "attrs": sum(1 for x in result["attrs"] if x["beyond"]),
        "reports": 0,
        "provenance": len(provenance),
        "added": len(added),
    }
    return result


def diff_reports(a: dict, b: dict, tol: Tolerance) -> dict[str, Any]:
    """JSON report figures old, new, change and relative change; flags beyond tolerance."""
    missing = object()
    fa, fb = _flatten(a), _flatten(b)
    figures = []
    for key in sorted(set(fa) | set(fb)):
        old, new = fa.get(key, missing), fb.get(key, missing)
        if old is missing or new is missing:
            figures.append({"key": key, "old": None if old is missing else old,
                            "new": None if new is missing else new, "beyond": True,
                            "status": "added" if old is missing else "removed"})
            continue
        differs, beyond = _values_differ(old, new, *tol.get(key))
        if not differs:
            continue
        entry = {"key": key, "old": old, "new": new, "beyond": beyond, "status": "changed"}
        if _is_number(old) and _is_number(new):
            entry["change"] = float(new) - float(old)
            entry["rel_change"] = _rel_change(float(old), float(new))
        figures.append(entry)
    for f in figures:  # the config's hash: judged key by key in the datasets' comparison
        f["category"] = ("provenance" if f["key"] in CONFIG_ATTRS
                         else "added" if f["status"] == "added" else "reports")
    counts = dict.fromkeys(CATEGORIES, 0)
    for f in figures:
        counts[f["category"]] += f["beyond"]
    return {"kind": "report", "figures": figures, "compared": len(set(fa) & set(fb)),
            "counts": counts}


# ------------------------------------------------------------------------------ operands
@dataclass
class Side:
    """One side of a comparison: a dataset, a report, a directory tree or a release."""

    spec: str
    kind: str
    path: Path
    manifest: dict[str, Any] | None = None
    files: dict[str, Path] = field(default_factory=dict)

    def describe(self) -> dict[str, Any]:
        """The side as JSON."""
        out: dict[str, Any] = {"spec": self.spec, "kind": self.kind, "path": str(self.path)}
        if self.manifest:
            out["version"] = self.manifest.get("version")
            out["created"] = self.manifest.get("created")
        return out

    @property
    def label(self) -> str:
        """Short human description."""
        if self.kind == "release" and self.manifest:
            return f"release {self.manifest.get('version')} ({self.path})"
        return f"{self.kind} {self.path}"


def tree_files(root: Path) -> dict[str, Path]:
    """By relative path: studies/**/*.nc and reports/*.json of a data or release directory
    (so not runs/, releases/, sweeps/, reports/diff/); elsewhere every *.nc and *.json."""
    if (root / "studies").is_dir() or (root / "reports").is_dir():
        found = [*root.glob("studies/**/*.nc"), *root.glob("reports/*.json")]
    else:
        found = [p for p in root.rglob("*") if p.suffix in (".nc", ".json")
                 and p.name != MANIFEST
                 and not {"runs", "releases"} & set(p.relative_to(root).parts[:-1])]
    return {p.relative_to(root).as_posix(): p for p in sorted(found)
            if p.is_file() and not any(part.startswith(".")
                                       for part in p.relative_to(root).parts)}


def resolve_side(spec: str, data_dir: str | Path = "data") -> Side:
    """A file, a directory, a release version or 'latest' (in <data_dir>/releases)."""
    path = Path(spec)
    if path.exists() and not path.is_file() and not path.is_dir():
        raise DiffError(f"{spec}: not a regular file (a FIFO, a device or a socket): creatio "
                        "compares regular files only")
    if path.is_file():
        if path.name == MANIFEST:
            path = path.parent
        elif path.suffix == ".nc":
            return Side(spec, "dataset", path)
        elif path.suffix == ".json":
            return Side(spec, "report", path)
        else:
            raise DiffError(f"{spec}: not a dataset (.nc) or a report (.json)")
    if path.is_dir():
        if (path / MANIFEST).exists():  # read_manifest refuses one that is not a file
            try:
                manifest = read_manifest(path)
            except ReleaseError as e:
                raise DiffError(str(e)) from None
            return Side(spec, "release", path, manifest, tree_files(path))
        return Side(spec, "tree", path, None, tree_files(path))
    if spec == "latest" or is_version(spec):
        try:
            release = find_release(spec, data_dir)
            return Side(spec, "release", release, read_manifest(release), tree_files(release))
        except ReleaseError as e:
            raise DiffError(str(e)) from None
    raise DiffError(f"{spec}: no such file or directory, and not a release version "
                    "(MAJOR.MINOR.PATCH) or 'latest'")


def path_study(rel: str) -> str:
    """The study a relative path belongs to: studies/<study>/..., benchmarks/<study>/...,
    reports/<study>[_...].json (the longest registered id the file name starts with)."""
    from creatio.studies import registry

    parts = rel.split("/")
    if len(parts) > 2 and parts[0] in ("studies", "benchmarks"):
        return parts[1]
    stem = Path(rel).stem
    for study in sorted(registry.STUDIES, key=len, reverse=True):
        if stem == study or stem.startswith(f"{study}_"):
            return study
    return stem.split("_")[0]


def _load_dataset(path: Path) -> tuple[xr.Dataset, dict]:
    from creatio.store.netcdf import read_dataset

    try:
        return read_dataset(path)
    except Exception as e:  # noqa: BLE001 - any unreadable file is the same error
        raise DiffError(f"cannot read dataset {path}: {e}") from None


def _load_report(path: Path) -> dict:
    try:
        data = read_json(path)
    except (OSError, ValueError) as e:
        raise DiffError(f"cannot read report {path}: {e}") from None
    if not isinstance(data, dict):
        raise DiffError(f"{path}: a report must be a JSON object")
    return data


def _compare_files(pa: Path, pb: Path, kind: str, tol: Tolerance,
                   all_attrs: bool) -> dict[str, Any]:
    if kind == "dataset":
        (da, ca), (db, cb) = _load_dataset(pa), _load_dataset(pb)
        result = diff_datasets(da, db, ca, cb, tol, all_attrs)
    else:
        result = diff_reports(_load_report(pa), _load_report(pb), tol)
    result["a"], result["b"] = str(pa), str(pb)
    return result


def diff(
    a: str,
    b: str,
    *,
    data_dir: str | Path = "data",
    tol: Tolerance | None = None,
    all_attrs: bool = False,
    strict_provenance: bool = False,
    studies: Sequence[str] | None = None,
) -> dict[str, Any]:
    """Compare A (old) with B (new): the report as JSON-able data, ``exit_code`` 1 when a
    counted category (see EPILOG) has differences. Raises DiffError on errors."""
    tol = tol or Tolerance()
    sa, sb = resolve_side(a, data_dir), resolve_side(b, data_dir)
    single = {"dataset", "report"}
    if (sa.kind in single) != (sb.kind in single) or (sa.kind in single and sa.kind != sb.kind):
        raise DiffError(f"cannot compare a {sa.kind} ({a}) with a {sb.kind} ({b}): give two "
                        "datasets, two reports, or two directories/releases")
    warnings: list[str] = []
    if sa.kind in single:
        key = sb.path.name if sa.path.name == sb.path.name else f"{sa.path.name} vs {sb.path.name}"
        pairs = {key: (sa.path, sb.path)}
        added: list[str] = []
        removed: list[str] = []
        omitted: list[str] = []
    else:
        fa, fb = sa.files, sb.files
        if studies:
            wanted = set(studies)
            unknown = wanted - {path_study(r) for r in (*fa, *fb)}
            if unknown:
                raise DiffError(f"--studies: no files of {', '.join(sorted(unknown))} in "
                                f"{a} or {b}")
            fa = {r: p for r, p in fa.items() if path_study(r) in wanted}
            fb = {r: p for r, p in fb.items() if path_study(r) in wanted}
        left_out = {o["path"] for s in (sa, sb) if s.manifest
                    for o in s.manifest.get("omitted", [])}
        only_a, only_b = sorted(set(fa) - set(fb)), sorted(set(fb) - set(fa))
        omitted = [r for r in (*only_a, *only_b) if r in left_out]
        removed = [r for r in only_a if r not in left_out]
        added = [r for r in only_b if r not in left_out]
        pairs = {r: (fa[r], fb[r]) for r in sorted(set(fa) & set(fb))}
        for side in (sa, sb):
            if side.manifest:
                _check_release(side)
    datasets: dict[str, Any] = {}
    reports: dict[str, Any] = {}
    identical: list[str] = []
    for rel, (pa, pb) in pairs.items():
        kind = "dataset" if pa.suffix == ".nc" else "report"
        if sha256_file(pa) == sha256_file(pb):
            identical.append(rel)
            continue
        result = _compare_files(pa, pb, kind, tol, all_attrs)
        (datasets if kind == "dataset" else reports)[rel] = result
    counted = COUNTED + (("provenance", "added") if strict_provenance else ())
    counts = dict.fromkeys(CATEGORIES, 0)
    counts["structure"] = len(removed)
    counts["added"] = len(added)  # new files since A (a new study): reported, not counted
    changed, unchanged = [], list(identical)
    for rel, result in {**datasets, **reports}.items():
        for cat, n in result["counts"].items():
            counts[cat] += n
        result["differences"] = sum(result["counts"][c] for c in counted)
        (changed if result["differences"] else unchanged).append(rel)
    total = sum(counts[c] for c in counted)
    return _jsonable({
        "format": FORMAT,
        "a": sa.describe(),
        "b": sb.describe(),
        "tolerance": tol.as_dict(),
        "options": {"all_attrs": all_attrs, "strict_provenance": strict_provenance,
                    "studies": list(studies) if studies else None},
        "files": {"added": added, "removed": removed, "omitted": omitted,
                  "unchanged": sorted(unchanged), "identical": sorted(identical),
                  "changed": sorted(changed)},
        "datasets": datasets,
        "reports": reports,
        "provenance": _aggregate_provenance(datasets),
        "warnings": warnings,
        "counts": counts,
        "counted": list(counted),
        "differences": total,
        "exit_code": 1 if total else 0,
    })


def _check_release(side: Side) -> None:
    """Refuse a release whose files no longer match its manifest (a file missing, changed
    or not listed): a comparison with it would pass off damage as a difference, or a
    missing file as nothing to compare (which exited 0)."""
    problems = verify_release(side.path)
    if problems:
        more = f" (and {len(problems) - 2} more)" if len(problems) > 2 else ""
        raise DamagedRelease(f"{side.label} does not match its {MANIFEST}: "
                             f"{'; '.join(problems[:2])}{more}: restore it from git "
                             "(`creatio release verify` lists every problem)")


def _aggregate_provenance(datasets: dict[str, Any]) -> list[dict[str, Any]]:
    """Provenance changes grouped across datasets (the same commit change on every file)."""
    groups: dict[tuple[str, str, str], dict[str, Any]] = {}
    for rel, result in datasets.items():
        for p in result["provenance"]:
            key = (p["name"], json.dumps(_jsonable(p["old"])), json.dumps(_jsonable(p["new"])))
            group = groups.setdefault(key, {"name": p["name"], "old": p["old"], "new": p["new"],
                                            "files": []})
            for extra in ("kind", "why"):
                if extra in p:
                    group[extra] = p[extra]
            group["files"].append(rel)
    # documented convention changes first, then versions and commits, then stored encodings
    order = {"convention": 0, "encoding": 2}
    return sorted(groups.values(), key=lambda g: order.get(g.get("kind", ""), 1))


# ------------------------------------------------------------------------------ text
def _num(x: Any) -> str:
    if isinstance(x, str):
        return x
    if x is None:
        return "-"
    if isinstance(x, float):
        if not math.isfinite(x):
            return str(x)
        return "0" if x == 0 else f"{x:.3g}" if 1e-3 <= abs(x) < 1e5 else f"{x:.2e}"
    return str(x)


def _val(x: Any, width: int = 40) -> str:
    """A value in full (floats by repr, so a one-ulp change shows), shortened if long."""
    s = repr(x) if isinstance(x, float) else json.dumps(x) if isinstance(x, list | dict) \
        else str(x)
    s = s.replace("\n", "\\n")
    return s if len(s) <= width else s[: width - 3] + "..."


def _short(x: Any) -> str:
    return f"{x:.6g}" if isinstance(x, float) else _val(x, 12)


def _more(items: Sequence[Any], verbose: bool) -> tuple[Sequence[Any], list[str]]:
    if verbose or len(items) <= ROWS:
        return items, []
    return items[:ROWS], [f"      ... {len(items) - ROWS} more (--verbose or --json)"]


def _dataset_lines(rel: str, r: dict[str, Any], verbose: bool) -> list[str]:
    counts = r["counts"]
    parts = ", ".join(f"{c} {counts[c]}" for c in COUNTED if counts[c])
    head = f"{rel}: {r['differences']} difference(s)" + (f" ({parts})" if parts else "")
    within = [n for n, s in r["data"].items() if s["status"] == "within"]
    if not r["differences"]:
        head += f"; {len(within)} variable(s) within tolerance" if within else ""
    lines = [head]
    if r["config"]:
        shown, more = _more(r["config"], verbose)
        lines += [f"  config     {c['key']}: {_val(c['old'], 30)} -> {_val(c['new'], 30)}"
                  for c in shown] + more
    if r["structure"]:
        shown, more = _more(r["structure"], verbose)
        lines += [f"  structure  {s['message']}" for s in shown] + more
    if r["not_compared"]:
        names = ", ".join(x["name"] for x in r["not_compared"])
        lines.append(f"  structure  not compared (shape changed): {_val(names, 70)}")
    rows = [(n, s) for n, s in r["data"].items() if verbose or s["status"] == "beyond"]
    rows.sort(key=lambda ns: -(ns[1].get("max_rel", 0.0) if isinstance(
        ns[1].get("max_rel"), float) else math.inf))
    if rows:
        shown, more = _more(rows, verbose)
        w = min(max(len("variable"), *(len(n) for n, _ in shown)) + 1, 32)
        lines.append(f"  data       {'variable':<{w}}{'max abs':>9}{'max rel':>9}{'rms':>9}"
                     f"{'beyond':>12}  at max: coordinates (a -> b)")
        for name, s in shown:
            at = " ".join(f"{k}={_short(v)}" for k, v in s.get("at", {}).items())
            ab = f" ({_short(s['a_at'])} -> {_short(s['b_at'])})" if "a_at" in s else ""
            nan = (f" NaN appeared {s['nan_appeared']}, vanished {s['nan_disappeared']}"
                   if s.get("nan_mismatch") else "")
            nan += " [on common coordinates]" if "compared_on" in s else ""
            lines.append(f"             {_val(name, w - 1):<{w}}{_num(s.get('max_abs')):>9}"
                         f"{_num(s.get('max_rel')):>9}{_num(s.get('rms')):>9}"
                         f"{s['n_beyond']:>6}/{s['n']:<5} {at}{ab}{nan}")
        lines += more
    if r.get("added"):
        shown, more = _more(r["added"], verbose)
        lines += [f"  added      {x} (new since A: not counted)" for x in shown] + more
    attrs = [x for x in r["attrs"] if verbose or x["beyond"]]
    if attrs:
        shown, more = _more(attrs, verbose)
        for x in shown:
            name = f"{x['variable']}:{x['name']}" if x["variable"] else x["name"]
            change = f" (change {_num(x['change'])})" if "change" in x else ""
            lines.append(f"  attrs      {name}: {_val(x['old'], 30)} -> {_val(x['new'], 30)}"
                         f"{change}" + ("" if x["beyond"] else " within tolerance"))
        lines += more
    return lines


def _report_lines(rel: str, r: dict[str, Any], verbose: bool) -> list[str]:
    beyond = [f for f in r["figures"] if f["beyond"] and f["category"] == "reports"]
    head = f"{rel}: {len(beyond)} figure(s) beyond tolerance"
    within = len(r["figures"]) - len(beyond)
    if within:
        head += f", {within} changed within tolerance"
    lines = [head]
    rows = r["figures"] if verbose else beyond
    new = [f["key"] for f in r["figures"] if f["category"] == "added"]
    if new:
        lines.append(f"  added      {_val(', '.join(new), 70)} (new since A: not counted)")
    if rows:
        lines.append(f"  {'figure':<30}{'old':>24}{'new':>24}{'change':>10}{'rel':>10}")
        shown, more = _more(rows, verbose)
        for f in shown:
            flag = "" if f["beyond"] else "  within tolerance"
            lines.append(f"  {_val(f['key'], 29):<30}{_val(f['old'], 23):>24}"
                         f"{_val(f['new'], 23):>24}{_num(f.get('change')):>10}"
                         f"{_num(f.get('rel_change')):>10}{flag}")
        lines += more
    return lines


def render_text(result: dict[str, Any], verbose: bool = False) -> str:
    """The report a person reads in one screen (everything with verbose)."""
    a, b, tol, files = result["a"], result["b"], result["tolerance"], result["files"]

    def label(side: dict) -> str:
        return (f"release {side['version']} ({side['path']})" if side["kind"] == "release"
                else f"{side['kind']} {side['path']}")

    over = ", ".join(f"{p} {v['atol']:g},{v['rtol']:g}" for p, v in tol["overrides"].items())
    lines = [f"creatio diff   A: {label(a)}   B: {label(b)}",
             f"tolerance: |a - b| > atol + rtol*|b| with atol {tol['atol']:g}, rtol "
             f"{tol['rtol']:g}" + (f"\n           per name (atol,rtol): {over}" if over else "")]
    compared = len(files["unchanged"]) + len(files["changed"])
    summary = (f"files: {compared} compared ({len(files['identical'])} byte-identical, "
               f"{len(files['unchanged']) - len(files['identical'])} unchanged, "
               f"{len(files['changed'])} changed), {len(files['added'])} added, "
               f"{len(files['removed'])} removed")
    if files["omitted"]:
        summary += f", {len(files['omitted'])} left out of the release by design"
    lines.append(summary)
    for sign, key in (("+", "added"), ("-", "removed")):
        shown, more = _more(files[key], verbose)
        lines += [f"  {sign} {rel}" for rel in shown] + more
    for rel, r in result["datasets"].items():
        if r["differences"] or verbose:
            lines += [""] + _dataset_lines(rel, r, verbose)
    for rel, r in result["reports"].items():
        if r["differences"] or verbose:
            lines += [""] + _report_lines(rel, r, verbose)
    if result["provenance"]:
        counted = "counted: --strict-provenance" if "provenance" in result["counted"] \
            else "not counted without --strict-provenance"
        lines += ["", f"provenance ({counted})"]
        shown, more = _more(result["provenance"], verbose)
        for p in shown:
            lines.append(f"  {p['name']}: {_val(p['old'], 30)} -> {_val(p['new'], 30)} "
                         f"({len(p['files'])} dataset(s))")
        lines += more
    new = {rel: r for rel, r in {**result["datasets"], **result["reports"]}.items()
           if r["counts"].get("added")}
    if new and not verbose:
        lines += ["", "new since A (not counted without --strict-provenance): "
                  + "; ".join(f"{rel}: {_new_since(r)}" for rel, r in new.items())]
    for w in result["warnings"]:
        lines.append(f"warning: {w}")
    counts = result["counts"]
    parts = ", ".join(f"{c} {counts[c]}" for c in result["counted"] if counts[c])
    lines += ["", f"result: {result['differences']} difference(s) beyond tolerance"
              + (f" ({parts})" if parts else "") + f" -> exit {result['exit_code']}"]
    return "\n".join(lines) + "\n"


def _new_since(r: dict[str, Any]) -> str:
    """The names of what a file gained since A (variables, attributes, config keys, figures)."""
    if r["kind"] == "report":
        names = [f["key"] for f in r["figures"] if f["category"] == "added"]
    else:
        names = [x.split(" = ")[0].split(" ", 1)[1] for x in r["added"]]
    return _val(", ".join(names), 80)


# ------------------------------------------------------------------------------ CLI
DESCRIPTION = """\
Compare A (old) with B (new): two datasets (.nc), two JSON reports, two directories (a data
directory or a release), or two releases. A and B may each be a path, a release version
(looked up in DATA_DIR/releases/) or 'latest' (the newest release by version order).

  creatio diff 0.1.0 0.2.0                    two releases
  creatio diff latest data                    the newest release against the current data/
  creatio diff a.nc b.nc --atol 1e-12 --rtol 1e-9 --tol fd_error=1e-9,1e-6
  creatio diff 0.1.0 data --json > diff.json
  creatio diff latest data --studies ct02,en01 --atol 1e-12 --rtol 1e-9 \
      --tol 'fd_error*=1e-8' --tol observed_order=0.25 --tol 'feature_*_error=1e-7' \
      --tol 'pattern_*fd*=1e-10'           the CI regression check of the quick studies

An existing path is taken first, then a version. In a data directory the compared files
are studies/**/*.nc and reports/*.json (runs/, releases/, sweeps/, logs/ and reports/diff/
are ignored); files are paired by relative path. Files a release leaves out by design
(listed under 'omitted' in its MANIFEST.json, e.g. the dt/2 partner datasets) are not
reported as added.
"""

EPILOG = """\
tolerance: a value differs when |a - b| > atol + rtol * |b| (b from B, as numpy.isclose);
NaN against NaN is equal, NaN against a number is a difference. --tol NAME=ATOL[,RTOL]
overrides both for the variables, attributes and report keys NAME matches: NAME is an
fnmatch pattern matched against the name and each dotted prefix of a report key, so
'fd_error' covers the variable fd_error and the report figures fd_error.c_R.0.01 ...;
'*_error' covers every name ending in _error. The last matching --tol wins.

counted as differences (exit 1): files added or removed; dimension, coordinate, variable,
dtype and units changes; variable values beyond tolerance (NaN mismatches included); any
change of the resolved config (shown key by key: sphere.mu: 0.15 -> 0.3); attribute
changes beyond tolerance (numeric attributes use the tolerances); report figures beyond
tolerance, added or removed. Reported but not counted: provenance (creatio_version,
git_commit, git_dirty, source, version_*; counted with --strict-provenance) and changes
within tolerance. Volatile attributes (history, date_created) are ignored unless
--all-attrs, which compares and counts them. Byte-identical files are skipped.

exit status: 0 no difference beyond tolerance, 1 differences, or a release side that does
not match its MANIFEST.json (a file missing, changed or unlisted: nothing is compared), 2
error (unreadable file, missing release, bad argument). --exit-zero turns differences' 1
into 0 (for writing reports), never a damaged release's.
"""


def _nonnegative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (value >= 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be finite and >= 0: {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of `creatio diff`."""
    ap = Parser(prog="creatio diff", description=DESCRIPTION, epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a", metavar="A", help="old side: dataset, report, directory, release "
                                           "version or 'latest'")
    ap.add_argument("b", metavar="B", help="new side, same forms (e.g. data)")
    ap.add_argument("--atol", type=_nonnegative, default=0.0, help="absolute tolerance "
                    "(default 0)")
    ap.add_argument("--rtol", type=_nonnegative, default=0.0, help="relative tolerance "
                    "(default 0)")
    ap.add_argument("--tol", action="append", default=[], metavar="NAME=ATOL[,RTOL]",
                    help="tolerances for the names matching the pattern NAME (repeatable)")
    ap.add_argument("--all-attrs", action="store_true",
                    help="also compare (and count) the volatile attributes history, "
                         "date_created")
    ap.add_argument("--strict-provenance", action="store_true",
                    help="count provenance changes (version, commit, libraries) as "
                         "differences")
    ap.add_argument("--studies", metavar="ID[,ID...]",
                    help="compare only these studies' files (directories and releases)")
    ap.add_argument("--data-dir", type=Path, default=Path("data"),
                    help="where release versions are looked up: DATA_DIR/releases/ "
                         "(default: data)")
    ap.add_argument("--json", action="store_true",
                    help="print the report as JSON instead of text")
    ap.add_argument("--text-out", type=Path, metavar="PATH", help="also write the text "
                    "report to PATH")
    ap.add_argument("--json-out", type=Path, metavar="PATH", help="also write the JSON "
                    "report to PATH")
    ap.add_argument("-q", "--quiet", action="store_true", help="print nothing on stdout")
    ap.add_argument("-v", "--verbose", action="store_true",
                    help="list everything: changes within tolerance, all rows")
    ap.add_argument("--exit-zero", action="store_true",
                    help="exit 0 even when differences are found (errors still exit 2)")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    """`creatio diff`: print the comparison and return 0 (same), 1 (differences), 2 (error)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    try:
        overrides = tuple(parse_tol(t, args.rtol) for t in args.tol)
        studies = [s for s in (args.studies or "").split(",") if s] or None
        result = diff(args.a, args.b, data_dir=args.data_dir,
                      tol=Tolerance(args.atol, args.rtol, overrides),
                      all_attrs=args.all_attrs, strict_provenance=args.strict_provenance,
                      studies=studies)
        text = render_text(result, args.verbose)
        as_json = json.dumps(result, indent=2) + "\n"
        for path, content in ((args.text_out, text), (args.json_out, as_json)):
            if path is not None:
                with atomic_write(path) as fh:
                    fh.write(content)
    except DamagedRelease as e:
        print(f"creatio diff: {e}", file=sys.stderr)
        return 1
    except DiffError as e:
        print(f"creatio diff: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"creatio diff: {e}", file=sys.stderr)
        return 2
    if not args.quiet:
        sys.stdout.write(as_json if args.json else text)
    return 0 if args.exit_zero else result["exit_code"]
