"""One entry point to everything built: ``data/index.html``, ``creatio ls``, ``creatio open``.

The pipeline writes results in stable folders for the default configs (``data/studies``,
``data/reports``, ``data/scenes``, ``data/benchmarks``) and in hash-named ones for the rest
(``data/runs/<config hash>/``, ``data/sweeps/<study>-<sweep hash>/``,
``data/calibration/<track>-<hash>/``). Each hash-named folder gets a small ``overrides.json``
beside its files (:func:`record_run`, :func:`record_sweep`, written by the jobs that make the
folder): what made it, as given and as the resolved config differs from the default.
:func:`scan` lists every built study, run, sweep, scene, calibration and benchmark with its
overrides, status and files; :func:`write_index` writes the static page (offline, relative
links) with the targets not built yet and the command that builds each (:func:`unbuilt`),
:func:`main` is `creatio ls` / `creatio open`. Scanning reads small files only (JSON
reports, NetCDF attributes), and only regular files (a FIFO in their place is skipped with a
note): no numba, nothing recomputed.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import html
import json
import sys
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from creatio.errors import Parser
from creatio.store.regular import NotRegularFile, check_regular, read_json, read_text

__all__ = ["CALIBRATION_FILES", "INDEX", "RECORD", "Entry", "changes", "main",
           "record_calibration", "record_run", "record_sweep", "refresh_index", "render_table",
           "scan", "unbuilt", "write_index"]

#: The record beside a hash-named folder's files.
RECORD = "overrides.json"
#: The index page, in the data directory.
INDEX = "index.html"
#: Kinds of result, in the order the index lists them.
KINDS = ("study", "run", "sweep", "scene", "calibration", "benchmark")
#: Where `creatio calibrate` writes by default (one folder per track and fit), and the files
#: of a calibration folder by link name (creatio.pipeline.calibrate, creatio.reports.calibration).
CALIBRATION_DIR = "calibration"
CALIBRATION_FILES = (("report", "calibration.md"), ("figure", "calibration.png"),
                     ("summary", "calibration.json"), ("dataset", "calibration.nc"))


# ------------------------------------------------------------------------------ records
def _flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(obj, Mapping) and obj:
        out: dict[str, Any] = {}
        for k, v in obj.items():
            out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    return {prefix: obj}


def changes(default: Mapping[str, Any], config: Mapping[str, Any]) -> dict[str, list[Any]]:
    """{dotted key: [default value, this value]} where a resolved config differs from its
    default (what an override changed, however it was spelled)."""
    a, b = _flatten(default), _flatten(config)
    missing = None
    return {k: [a.get(k, missing), b.get(k, missing)] for k in sorted(set(a) | set(b))
            if a.get(k, missing) != b.get(k, missing)}


def _write(path: Path, text: str) -> Path:
    """Write through a temporary sibling and a rename (creatio.pipeline.provenance, imported here:
    the Snakefile imports this module, and planning stays free of xarray)."""
    from creatio.store.atomic import atomic_write

    with atomic_write(path) as fh:
        fh.write(text)
    return path


def _write_json(path: Path, data: Mapping[str, Any]) -> Path:
    return _write(path, json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")


def record_run(root: str | Path, kind: str, name: str, config: Mapping[str, Any],
               default: Mapping[str, Any], overrides: Sequence[str] | None,
               sha256: str, data_dir: str | Path = "data") -> Path | None:
    """Write ``<root>/overrides.json`` for a run folder (``data/runs/<hash>``): the study or
    scene, its config hash, the overrides as given (None when unknown: `creatio run`) and the
    keys its resolved config changes. Nothing for the default root (the data directory)."""
    root = Path(root)
    if root == Path(data_dir):
        return None
    diff = changes(default, config)
    return _write_json(root / RECORD, {
        "kind": kind, "name": name, "config_sha256": sha256,
        "overrides": list(overrides) if overrides is not None
        else [f"{k}={v[1]}" for k, v in diff.items()],
        "changes": diff,
    })


def record_sweep(outdir: str | Path, study: str, axes: Sequence[tuple[str, Sequence[Any]]],
                 base: Sequence[str], points: int, points_run: int) -> Path:
    """Write ``data/sweeps/<name>/overrides.json``: the study, the swept axes, the overrides
    applied to every point, how many points ran."""
    return _write_json(Path(outdir) / RECORD, {
        "kind": "sweep", "name": Path(outdir).name, "study": study,
        "sweep": [f"{k}={','.join(str(v) for v in values)}" for k, values in axes],
        "overrides": list(base), "points": points, "points_run": points_run,
    })


def record_calibration(outdir: str | Path, study: str, track: str | Path, fit: Sequence[str],
                       overrides: Sequence[str], sha256: str) -> Path:
    """Write ``<outdir>/overrides.json`` for a calibration folder (`creatio calibrate`): the
    study, the track fitted, the keys fitted, the study's overrides and its config hash."""
    return _write_json(Path(outdir) / RECORD, {
        "kind": "calibration", "name": Path(outdir).name, "study": study,
        "track": str(track), "fit": list(fit), "overrides": list(overrides),
        "config_sha256": sha256,
    })


# ------------------------------------------------------------------------------ scanning
@dataclass
class Entry:
    """One built result: what it is, what made it, how it ended, where its files are."""

    kind: str
    name: str
    study: str
    overrides: list[str]
    status: str
    updated: float
    folder: str
    links: dict[str, str] = field(default_factory=dict)

    @property
    def main(self) -> str:
        """The file to open first (a page, a report, a table), relative to the data dir."""
        for key in ("page", "report", "table", "figure", "dataset"):
            if key in self.links:
                return self.links[key]
        return self.folder

    def as_json(self) -> dict[str, Any]:
        """The entry as plain JSON (`creatio ls --json`)."""
        return {**asdict(self), "main": self.main}


def _rel(path: Path, data_dir: Path) -> str:
    return path.relative_to(data_dir).as_posix()


def _mtime(paths: Sequence[Path]) -> float:
    return max((p.stat().st_mtime for p in paths if p.exists()), default=0.0)


def _regular(path: Path) -> bool:
    """Whether path is a regular file to list; a note when something else stands there."""
    if path.is_file():
        return True
    if path.exists():
        _note(f"{path}: not a regular file: skipped")
    return False


def _note(text: str) -> None:
    """Keep a note for the end of the scan (`creatio ls` prints each on one line)."""
    notes = _ATTRS.get("notes")
    if isinstance(notes, list) and text not in notes:
        notes.append(text)


def _json(path: Path) -> dict[str, Any]:
    """A small JSON object of a result (a record, a report); {} when absent or unreadable,
    with a note when it is not a regular file (a FIFO would block the whole listing)."""
    try:
        data = read_json(path)
    except NotRegularFile as e:
        _note(f"{e}: skipped")
        return {}
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


#: The attributes the index reads of a result's NetCDF file (a sweep's, a scene's status).
LISTED_ATTRS = ("status", "sweep", "base_overrides", "study", "points_run", "points")
#: Where those attributes are kept between runs, beside the index, by file identity (inode,
#: size, modification time): opening a file with netCDF4 costs about 7 ms and the library
#: 0.1 s to import, for every listed result at the end of every run.
ATTR_CACHE = ".index-attrs.json"
_ATTRS: dict[str, Any] = {}


def _nc_attrs(path: Path) -> dict[str, Any]:
    """The listed attributes of a NetCDF file: kept from an earlier read of the same file
    (during :func:`scan`), else read."""
    kept = _ATTRS.get("files")
    if kept is None:
        return _read_attrs(path)
    try:
        st = path.stat()
    except OSError:
        return {}
    stamp = [st.st_ino, st.st_size, st.st_mtime_ns]
    entry = kept.get(str(path))
    if isinstance(entry, list) and len(entry) == 2 and entry[0] == stamp:
        _ATTRS["seen"].add(str(path))
        return dict(entry[1])
    attrs = _read_attrs(path)
    kept[str(path)] = [stamp, attrs]
    _ATTRS["seen"].add(str(path))
    _ATTRS["changed"] = True
    return attrs


def _plain(value: Any) -> Any:
    """A netCDF attribute or variable as JSON: numbers, text, lists of them (numpy's
    scalars and arrays as Python's)."""
    return value.tolist() if hasattr(value, "tolist") else value


def _read_attrs(path: Path) -> dict[str, Any]:
    """:data:`LISTED_ATTRS` of a NetCDF file (netCDF4, no data read but a status
    variable); {} if unreadable."""
    try:
        out = _nc_all_attrs(path)
    except NotRegularFile as e:
        _note(f"{e}: skipped")
        return {}
    except Exception:  # noqa: BLE001 - an unreadable file is listed as such
        return {}
    return {k: _plain(v) for k, v in out.items() if k in LISTED_ATTRS}


def _nc_all_attrs(path: Path) -> dict[str, Any]:
    """Global attributes of a NetCDF file, and its status variable as text."""
    import netCDF4

    check_regular(path)  # netCDF4 would wait forever on a FIFO
    with netCDF4.Dataset(path) as nc:
        out = {k: nc.getncattr(k) for k in nc.ncattrs()}
        if "status" in nc.variables and "status" not in out:
            var = nc.variables["status"]
            var.set_auto_chartostring(True)
            out["status"] = [str(s) for s in var[:].ravel()]
        return out


def _report_status(report: dict[str, Any], datasets: Sequence[Path]) -> str:
    """A study's status: its report's, else its first dataset's, else "ok" (the kinematic
    studies always complete: a report is their whole result)."""
    status = report.get("status")
    if isinstance(status, str):
        return status
    found = {str(_nc_attrs(p).get("status", "")) for p in datasets[:1]} - {""}
    return found.pop() if len(found) == 1 else "ok"


def _study_entries(root: Path, data_dir: Path, kind: str, overrides: list[str],
                   prefix: str) -> list[Entry]:
    """The studies (and analyses) with files under an output root."""
    from creatio.studies import registry

    out = []
    for study in registry.STUDIES.values():
        base = root / study.kind.dataset_dir / study.id
        datasets = sorted(p for p in base.glob("*.nc") if _regular(p)) if base.is_dir() else []
        reports_dir = root / study.kind.report_dir
        reports = [p for p in (reports_dir / f"{study.id}{s}" for s in study.kind.reports)
                   if p.is_file()]
        if not datasets and not reports:
            continue
        links: dict[str, str] = {}
        for key, suffix in (("report", ".html"), ("markdown", ".md"), ("figure", ".png"),
                            ("summary", ".json")):
            p = reports_dir / f"{study.id}{suffix}"
            if p.is_file():
                links[key] = _rel(p, data_dir)
        if "report" not in links and "markdown" in links:
            links["report"] = links.pop("markdown")
        if datasets:
            links["dataset"] = _rel(datasets[0], data_dir)
        status = _report_status(_json(reports_dir / f"{study.id}.json"), datasets)
        if not reports:
            status = f"{status}; report not built"
        what = "benchmark" if study.kind.name == "analysis" and kind == "study" else kind
        out.append(Entry(what, f"{prefix}{study.id}", study.id, overrides, status,
                         _mtime([*datasets, *reports]), _rel(root, data_dir) if root !=
                         data_dir else ".", links))
    compare = [root / "reports" / f"compare_en02_en02r{s}" for s in (".md", ".png")]
    if kind == "study" and compare[0].is_file():
        out.append(Entry("study", "compare_en02_en02r", "en02, en02r", overrides,
                         "ok", _mtime(compare), ".",
                         {k: _rel(p, data_dir) for k, p in zip(("report", "figure"), compare,
                                                                strict=True) if p.is_file()}))
    return out


def _scene_entries(root: Path, data_dir: Path, overrides: list[str],
                   prefix: str) -> list[Entry]:
    out = []
    for folder in sorted((root / "scenes").glob("*")) if (root / "scenes").is_dir() else []:
        if not folder.is_dir() or folder.name == "members":
            continue
        files = {k: folder / f for k, f in (("page", "index.html"), ("poster", "poster.png"),
                                            ("animation", "animation.webp"),
                                            ("dataset", "scene.nc"))}
        present = {k: p for k, p in files.items() if p.is_file()}
        if not present:
            continue
        runs = _nc_attrs(present["dataset"]).get("status", []) if "dataset" in present else []
        runs = [runs] if isinstance(runs, str) else list(runs)
        bad = sorted({s for s in runs if s != "ok"})
        status = "ok" if "page" in present and not bad else (
            ", ".join(bad) if bad else "page not built")
        out.append(Entry("scene", f"{prefix}scenes/{folder.name}", folder.name, overrides,
                         status, _mtime(list(present.values())), _rel(folder, data_dir),
                         {k: _rel(p, data_dir) for k, p in present.items()}))
    return out


def _run_overrides(root: Path) -> list[str]:
    """A run folder's overrides: its record's, else what its configs change (older runs)."""
    record = _json(root / RECORD)
    if isinstance(record.get("overrides"), list):
        return [str(o) for o in record["overrides"]]
    from creatio.pipeline.config import resolve

    out: list[str] = []
    for config in sorted((root / "configs").glob("*.yaml")):
        try:
            import yaml

            data = yaml.safe_load(read_text(config)) or {}
            default = resolve(config.stem).data
        except NotRegularFile as e:
            _note(f"{e}: skipped")
            continue
        except Exception:  # noqa: BLE001 - a config no longer valid: say so, list the rest
            out.append(f"({config.name}: not comparable with today's default)")
            continue
        out += [f"{k}={v[1]}" for k, v in changes(default, data).items()]
    return out


def _sweep_entries(data_dir: Path) -> list[Entry]:
    out = []
    sweeps = data_dir / "sweeps"
    for folder in sorted(sweeps.glob("*")) if sweeps.is_dir() else []:
        nc, md, png = folder / "sweep.nc", folder / "sweep.md", folder / "sweep.png"
        if not folder.is_dir() or not (nc.is_file() or (folder / "batches").is_dir()):
            continue
        record = _json(folder / RECORD)
        attrs = _nc_attrs(nc) if nc.is_file() else {}
        axes = record.get("sweep") or [
            f"{k}={','.join(str(x) for x in v)}"
            for k, v in json.loads(str(attrs.get("sweep", "[]")) or "[]")]
        base = record.get("overrides") or json.loads(str(attrs.get("base_overrides", "[]"))
                                                     or "[]")
        study = str(record.get("study") or attrs.get("study") or folder.name.split("-")[0])
        if nc.is_file():
            run = record.get("points_run", attrs.get("points_run"))
            total = record.get("points", attrs.get("points"))
            status = f"{run} of {total} points ran"
        else:
            status = "batches only (not aggregated)"
        links = {k: _rel(p, data_dir) for k, p in (("table", md), ("figure", png),
                                                   ("dataset", nc)) if p.is_file()}
        out.append(Entry("sweep", f"sweeps/{folder.name}", study,
                         [*(f"sweep {a}" for a in axes), *[str(b) for b in base]], status,
                         _mtime([nc, md, png, *folder.glob("batches/*.nc")]),
                         _rel(folder, data_dir), links))
    return out


def _strings(value: Any) -> list[str]:
    """The text items of a list read from JSON ([] for anything else)."""
    return [v for v in value if isinstance(v, str)] if isinstance(value, list) else []


def _calibration_entries(data_dir: Path) -> list[Entry]:
    """The calibrations `creatio calibrate` wrote under data_dir/calibration/ (one folder
    each): the study and track from the folder's record (overrides.json, when the command
    wrote one), else from its JSON report or dataset; the fit's status."""
    out = []
    base = data_dir / CALIBRATION_DIR
    for folder in sorted(base.glob("*")) if base.is_dir() else []:
        if not folder.is_dir():
            continue
        present = {k: folder / f for k, f in CALIBRATION_FILES if (folder / f).is_file()}
        if not present:
            continue
        record = _json(folder / RECORD)
        summary = _json(present["summary"]) if "summary" in present else {}
        attrs = _nc_attrs(present["dataset"]) if "dataset" in present else {}
        study = str(record.get("study") or summary.get("study") or attrs.get("study") or "?")
        track = record.get("track") or summary.get("track")
        fit = _strings(record.get("fit")) or _strings(list(summary.get("estimate") or {}))
        given = _strings(record.get("overrides"))
        overrides = [*([f"track={Path(str(track)).name}"] if track else []),
                     *([f"fit=[{','.join(fit)}]"] if fit else []),
                     *(o for o in given if not o.startswith(("track=", "fit=", "study=")))]
        status = str(summary.get("status") or attrs.get("status") or "ok")
        if "summary" not in present:
            status = f"{status}; report not built"
        out.append(Entry("calibration", f"{CALIBRATION_DIR}/{folder.name}", study, overrides,
                         status, _mtime(list(present.values())), _rel(folder, data_dir),
                         {k: _rel(p, data_dir) for k, p in present.items()}))
    return out


def scan(data_dir: str | Path = "data", notes: list[str] | None = None) -> list[Entry]:
    """Every built result under data_dir: default studies and benchmarks, runs (each
    data/runs/<hash>/ with its overrides), sweeps, scenes, calibrations; in KINDS order,
    then by name. The attributes it reads of NetCDF files are kept in
    data_dir/:data:`ATTR_CACHE`; what it skipped (a file that is not a regular file) is
    added to notes, one line each."""
    data_dir = Path(data_dir)
    cache = data_dir / ATTR_CACHE
    try:
        kept = read_json(cache)
    except (OSError, ValueError):
        kept = {}
    _ATTRS.update(files=kept if isinstance(kept, dict) else {}, seen=set(), changed=False,
                  notes=[])
    try:
        entries = _scan(data_dir)
        if notes is not None:
            notes.extend(_ATTRS["notes"])
        files, seen = _ATTRS["files"], _ATTRS["seen"]
        if _ATTRS["changed"] or set(files) - seen:  # new reads, or files gone
            with contextlib.suppress(OSError):
                _write(cache, json.dumps({k: v for k, v in files.items() if k in seen},
                                         sort_keys=True))
    finally:
        _ATTRS.clear()
    return entries


def _scan(data_dir: Path) -> list[Entry]:
    entries = _study_entries(data_dir, data_dir, "study", [], "")
    entries += _scene_entries(data_dir, data_dir, [], "")
    runs = data_dir / "runs"
    for root in sorted(runs.glob("*")) if runs.is_dir() else []:
        if not root.is_dir():
            continue
        overrides = _run_overrides(root)
        prefix = f"runs/{root.name}/"
        entries += _study_entries(root, data_dir, "run", overrides, prefix)
        entries += _scene_entries(root, data_dir, overrides, prefix)
    entries += _sweep_entries(data_dir)
    entries += _calibration_entries(data_dir)
    from creatio.studies import registry

    order = {s: i for i, s in enumerate(registry.STUDIES)}  # the notebook's order
    return sorted(entries, key=lambda e: (KINDS.index(e.kind), e.name.rsplit("/", 1)[0]
                                          if "/" in e.name else "", order.get(e.study, 99),
                                          e.name))


# ------------------------------------------------------------------------------ output
def _when(t: float) -> str:
    if not t:
        return "-"
    return _dt.datetime.fromtimestamp(t).strftime("%Y-%m-%d %H:%M")


def render_table(entries: Sequence[Entry], data_dir: str | Path = "data") -> str:
    """The entries as a terminal table (`creatio ls`): kind, name, status, overrides,
    updated, the file to open."""
    if not entries:
        return f"nothing built under {data_dir} yet: `make all` (or `snakemake all -c 2`)\n"
    rows = [("KIND", "NAME", "STATUS", "OVERRIDES", "UPDATED", "OPEN")]
    for e in entries:
        rows.append((e.kind, e.name, e.status, " ".join(e.overrides) or "default",
                     _when(e.updated), f"{Path(data_dir) / e.main}"))
    caps = (11, 36, 28, 44, 16, 200)
    widths = [min(cap, max(len(r[i]) for r in rows)) for i, cap in enumerate(caps)]

    def cut(text: str, width: int) -> str:
        return text if len(text) <= width else text[: width - 3] + "..."

    lines = ["  ".join(cut(c, w).ljust(w) for c, w in zip(r, widths, strict=True)).rstrip()
             for r in rows]
    return "\n".join(lines) + f"\n{len(entries)} result(s); index page: " \
        f"{Path(data_dir) / INDEX}\n"


_CSS = """
body{font:14px/1.45 system-ui,sans-serif;margin:1.5em;color:#222;max-width:90em}
h1{font-size:1.4em;margin:0 0 .2em}h2{font-size:1.1em;margin:1.4em 0 .4em}
p.lead{color:#555;margin:.2em 0 1em}
table{border-collapse:collapse;width:100%}
th,td{border-bottom:1px solid #ddd;padding:.35em .6em;text-align:left;vertical-align:top}
th{background:#f4f4f4;font-weight:600}td.name{font-family:ui-monospace,monospace}
code{background:#f4f4f4;padding:0 .25em;border-radius:3px;font-size:.92em}
.status{display:inline-block;padding:0 .45em;border-radius:3px;background:#e6f4ea;color:#1e6b34}
.status.warn{background:#fdecea;color:#a1281b}.status.info{background:#eef2f8;color:#2d4b7c}
a{color:#1a56b0;text-decoration:none;margin-right:.7em}a:hover{text-decoration:underline}
.empty{color:#777}
"""

_TITLES = {"study": "Studies (default configs)", "run": "Runs with overrides (data/runs/)",
           "sweep": "Sweeps (data/sweeps/)", "scene": "Scenes",
           "calibration": "Calibrations (data/calibration/)",
           "benchmark": "Benchmarks (data/benchmarks/)"}
_HOW = {"study": "make all", "run": "snakemake all -c 2 --config 'overrides=[...]'",
        "sweep": "snakemake sweep_en02_mu -c 2", "scene": "snakemake scenes -c 2",
        "calibration": "creatio calibrate study=en02 track=TRACK.csv",
        "benchmark": "snakemake benchmarks -c 1"}
#: The calibration of the committed example track (snakemake calibrate_example).
EXAMPLE_CALIBRATION = f"{CALIBRATION_DIR}/en02_example"


def unbuilt(entries: Sequence[Entry], data_dir: str | Path = "data") -> list[tuple[str, str,
                                                                                  str]]:
    """The targets the workflow knows that have no result under data_dir yet, as (target,
    what it makes, the command that builds it): the default studies, the studies beyond
    the notebook, EN-05, the example calibration, the benchmarks, the scenes, a sweep."""
    from creatio.pipeline.config import CONF_DIR
    from creatio.studies import registry

    built = {e.name for e in entries if e.kind in ("study", "benchmark", "calibration",
                                                    "scene")}
    kinds = {e.kind for e in entries}

    def missing(studies: Sequence[Any]) -> list[str]:
        return [s.id for s in studies if s.id not in built]

    out = []
    rows = (
        ("all", missing(registry.select(in_all=True)), "the notebook's studies",
         "make all (or snakemake all -c 2)"),
        ("beyond", missing(registry.beyond()),
         "the studies beyond the notebook", "snakemake beyond -c 2"),
        ("en05", missing(registry.select(kind="uncertainty")),
         "which inputs matter (Sobol' indices), the calibration round trip",
         "snakemake en05 -c 2"),
        ("calibrate_example", [] if EXAMPLE_CALIBRATION in built else [EXAMPLE_CALIBRATION],
         "the committed example track fitted (your own: creatio calibrate study=en02 "
         "track=TRACK.csv)", "snakemake calibrate_example -c 1"),
        ("benchmarks", missing(registry.select(kind="analysis")),
         "the analyses, timed on one core", "snakemake benchmarks -c 1"),
        ("scenes", [p.stem for p in sorted((CONF_DIR / "scene").glob("*.yaml"))
                    if f"scenes/{p.stem}" not in built], "the viewers",
         "snakemake scenes -c 2"),
        ("sweep_en02_mu", [] if "sweep" in kinds else ["sweep_en02_mu"],
         "the worked sweep of conf/sweeps/en02_mu.yaml", "snakemake sweep_en02_mu -c 2"),
    )
    for target, names, what, command in rows:
        if names:
            out.append((target, what if names == [target] else f"{what}: {', '.join(names)}",
                        command))
    return out


def _status_class(status: str) -> str:
    if status == "ok" or status.endswith("points ran") and status.split()[0] == status.split()[2]:
        return "status"
    if status in ("built",) or "points ran" in status:
        return "status info"
    return "status warn"


def render_html(entries: Sequence[Entry], data_dir: str | Path = "data") -> str:
    """The index page: one table per kind of result, links relative to the data directory
    (the page opens offline, from wherever data/ is)."""
    now = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    parts = [f"<h1>creatio results in <code>{html.escape(str(data_dir))}/</code></h1>",
             f"<p class=lead>{len(entries)} result(s), listed {now}. The same list in a "
             "terminal: <code>creatio ls</code>; one of them: <code>creatio open NAME</code>. "
             "Rewritten by the pipeline after every successful <code>snakemake</code> run."
             "</p>"]
    for kind in KINDS:
        rows = [e for e in entries if e.kind == kind]
        parts.append(f"<h2>{_TITLES[kind]}</h2>")
        if not rows:
            parts.append(f"<p class=empty>None built (<code>{_HOW[kind]}</code>).</p>")
            continue
        parts.append("<table><tr><th>name</th><th>study</th><th>overrides</th>"
                     "<th>status</th><th>updated</th><th>files</th></tr>")
        for e in rows:
            over = " ".join(f"<code>{html.escape(o)}</code>" for o in e.overrides) or "default"
            links = "".join(f"<a href='{html.escape(p)}'>{html.escape(k)}</a>"
                            for k, p in e.links.items())
            parts.append(f"<tr><td class=name>{html.escape(e.name)}</td>"
                         f"<td>{html.escape(e.study)}</td><td>{over}</td>"
                         f"<td><span class='{_status_class(e.status)}'>"
                         f"{html.escape(e.status)}</span></td><td>{_when(e.updated)}</td>"
                         f"<td>{links}</td></tr>")
        parts.append("</table>")
    todo = unbuilt(entries, data_dir)
    if todo:
        parts.append("<h2>Not built yet</h2><p class=lead>Targets of the workflow with no "
                     "result here; the command builds each (from the project directory).</p>"
                     "<table><tr><th>target</th><th>what</th><th>command</th></tr>")
        parts += [f"<tr><td class=name>{html.escape(t)}</td><td>{html.escape(w)}</td>"
                  f"<td><code>{html.escape(c)}</code></td></tr>" for t, w, c in todo]
        parts.append("</table>")
    return ("<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
            "<meta name=viewport content='width=device-width, initial-scale=1'>"
            f"<meta name=creatio-listing content='{_listing(entries)}'>"
            f"<title>creatio results</title><style>{_CSS}</style></head><body>"
            + "\n".join(parts) + "</body></html>\n")


def _listing(entries: Sequence[Entry]) -> str:
    text = json.dumps([e.as_json() for e in entries], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def write_index(data_dir: str | Path = "data", out: str | Path | None = None) -> Path:
    """Write the index page (default ``<data_dir>/index.html``) and return its path."""
    data_dir = Path(data_dir)
    out = Path(out) if out is not None else data_dir / INDEX
    return _write(out, render_html(scan(data_dir), data_dir))


def refresh_index(data_dir: str | Path = "data") -> Path | None:
    """Rewrite the index page if what it lists changed (after any successful Snakemake run:
    a sweep, scenes, benchmarks); None when there is no data directory."""
    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        return None
    page = data_dir / INDEX
    entries = scan(data_dir)
    try:
        current = read_text(page)
    except OSError:
        current = ""
    if f"name=creatio-listing content='{_listing(entries)}'" not in current:
        _write(page, render_html(entries, data_dir))
    return page


# ------------------------------------------------------------------------------ CLI
class NotFound(LookupError):
    """No result, or more than one, answers to the name given to `creatio open`."""


def _find(entries: Sequence[Entry], name: str) -> Entry:
    """The entry called name: exact, else the only one whose name ends with or contains it."""
    for test in (lambda e: e.name == name, lambda e: e.name.endswith(f"/{name}"),
                 lambda e: name in e.name):
        found = [e for e in entries if test(e)]
        if len(found) == 1:
            return found[0]
        if len(found) > 1:
            raise NotFound(f"{name!r} matches " + ", ".join(e.name for e in found[:6])
                           + (" ..." if len(found) > 6 else "") + ": say which")
    known = ", ".join(e.name for e in entries[:8]) or "nothing is built yet (make all)"
    raise NotFound(f"no result named {name!r} (creatio ls lists them: {known})")


def main(argv: Sequence[str]) -> int:
    """`creatio ls [--json]` and `creatio open NAME [--browser]`."""
    command, rest = argv[0], list(argv[1:])
    ap = Parser(prog=f"creatio {command}")
    ap.add_argument("--data-dir", type=Path, default=Path("data"),
                    help="the data directory (default: data)")
    if command == "ls":
        ap.description = ("Every built study, run, sweep, scene and benchmark with its "
                          "overrides, status and the file to open (the index page's list).")
        ap.add_argument("--json", action="store_true", help="print the list as JSON")
    else:
        ap.description = ("The file to open of one result (a report, a page, a table): its "
                          "path, or opened in the browser.")
        ap.add_argument("name", help="a name `creatio ls` prints (or a unique part of it)")
        ap.add_argument("--browser", action="store_true",
                        help="open it in the default browser instead of printing its path")
    args = ap.parse_args(rest)
    notes: list[str] = []
    entries = scan(args.data_dir, notes)
    for note in notes:
        print(f"creatio {command}: note: {note}", file=sys.stderr)
    if command == "ls":
        if args.json:
            print(json.dumps([e.as_json() for e in entries], indent=2, default=str))
        else:
            sys.stdout.write(render_table(entries, args.data_dir))
        return 0
    try:
        entry = _find(entries, args.name)
    except NotFound as e:
        print(f"creatio open: {e}", file=sys.stderr)
        return 2
    path = (args.data_dir / entry.main).resolve()
    if args.browser:
        import webbrowser

        if webbrowser.open(path.as_uri()):
            return 0
        print("creatio open: no browser available; the file is:", file=sys.stderr)
    print(path)
    return 0
