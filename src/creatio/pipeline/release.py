"""Versioned releases: freeze the default datasets and reports into data/releases/<version>/.

A release mirrors the data/ layout (``studies/<study>/*.nc``, ``reports/*``) so that
``creatio diff`` pairs its files with data/ by relative path, and carries a MANIFEST.json
with each file's sha256, size, study, resolved-config hash and the package version, commit
and library versions that made it. Releases are committed to the repository, so they hold
what a regression check and a reader need and nothing that is derived again cheaply:

* each study's dataset at its configured step (the dt/refine convergence partner of a
  dynamic study is left out: its figures are in the study's JSON report);
* the JSON reports (the contract) and the markdown reports.

Figures, CSV tables and partner datasets are listed in the manifest under ``omitted`` with
their sha256, so the whole state of data/ at release time is still fingerprinted.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import functools
import hashlib
import json
import os
import re
import shutil
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from creatio.errors import Parser, ReleaseError, one_line_errors
from creatio.store.regular import NotRegularFile, check_regular, open_regular, read_json

__all__ = [
    "released_studies",
    "MANIFEST",
    "Layout",
    "ReleaseError",
    "StudyFiles",
    "default_layout",
    "find_release",
    "list_releases",
    "main",
    "make_release",
    "parse_version",
    "clean_stale_releases",
    "verify_release",
    "workflow_against",
    "workflow_diff_options",
    "workflow_outputs",
    "workflow_release_digest",
    "workflow_version",
]

MANIFEST = "MANIFEST.json"
FORMAT = "creatio-release/1"
VERSION_RE = re.compile(r"(0|[1-9]\d*)\.(0|[1-9]\d*)\.(0|[1-9]\d*)(?:(a|b|rc)(0|[1-9]\d*))?")
VERSION_HELP = "MAJOR.MINOR.PATCH, optionally with a pre-release suffix a1, b2 or rc1 (0.2.0rc1)"
RELEASED_REPORTS = (".json", ".md")
PRE_ORDER = {"a": 0, "b": 1, "rc": 2}
READ_ONLY = 0o444


# ------------------------------------------------------------------------------ versions
def parse_version(text: str) -> tuple[int, int, int, int, int, int]:
    """Sort key of a release version; ReleaseError if it is not MAJOR.MINOR.PATCH[a|b|rcN]."""
    m = VERSION_RE.fullmatch(str(text))
    if m is None:
        raise ReleaseError(f"invalid release version {text!r}: use {VERSION_HELP}")
    major, minor, patch, pre, n = m.groups()
    final = (1, 0, 0) if pre is None else (0, PRE_ORDER[pre], int(n))
    return (int(major), int(minor), int(patch), *final)


def is_version(text: str) -> bool:
    """Whether text is a valid release version string."""
    return VERSION_RE.fullmatch(str(text)) is not None


def releases_dir(data_dir: str | Path = "data") -> Path:
    """Where releases live: <data_dir>/releases."""
    return Path(data_dir) / "releases"


def list_releases(data_dir: str | Path = "data") -> list[Path]:
    """Release directories (those with a MANIFEST.json), oldest to newest by version order;
    one whose manifest is not a regular file is listed too, for its readers to refuse (the
    newest is not passed over for an older one)."""
    root = releases_dir(data_dir)
    if not root.is_dir():
        return []
    found = [p for p in root.iterdir()
             if p.is_dir() and is_version(p.name) and (p / MANIFEST).exists()]
    return sorted(found, key=lambda p: parse_version(p.name))


def find_release(spec: str, data_dir: str | Path = "data") -> Path:
    """The release directory of a version string or of ``latest`` (the newest by version)."""
    known = list_releases(data_dir)
    names = ", ".join(p.name for p in known) or "none"
    if spec == "latest":
        if not known:
            raise ReleaseError(f"no release in {releases_dir(data_dir)} (make one with "
                               "`creatio release VERSION`)")
        return known[-1]
    parse_version(spec)
    path = releases_dir(data_dir) / spec
    if not (path / MANIFEST).is_file():
        if (path / MANIFEST).exists():
            raise ReleaseError(f"{path / MANIFEST} is not a regular file: restore the release "
                               "from git")
        raise ReleaseError(f"no release {spec} in {releases_dir(data_dir)} (available: {names})")
    return path


def read_manifest(release: str | Path) -> dict[str, Any]:
    """The parsed MANIFEST.json of a release directory."""
    path = Path(release) / MANIFEST
    try:
        manifest = read_json(path)
    except FileNotFoundError:
        raise ReleaseError(f"{release} is not a release: no {MANIFEST}") from None
    except NotRegularFile as e:
        raise ReleaseError(f"{e}: restore the release from git") from None
    except (OSError, ValueError) as e:
        raise ReleaseError(f"cannot read {path}: {e}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ReleaseError(f"{path}: not a {FORMAT} manifest")
    files = manifest.get("files")
    if not isinstance(files, list) or not all(
            isinstance(f, dict) and isinstance(f.get("path"), str)
            and isinstance(f.get("sha256"), str) for f in files):
        raise ReleaseError(f"{path}: damaged manifest (every file needs a path and a sha256): "
                           "restore it from git")
    omitted = manifest.get("omitted", [])
    if not isinstance(omitted, list) or not all(
            isinstance(f, dict) and isinstance(f.get("path"), str) for f in omitted):
        raise ReleaseError(f"{path}: damaged manifest (every omitted file needs a path): "
                           "restore it from git")
    seen: set[str] = set()
    for rel in [f["path"] for f in files] + [f["path"] for f in omitted]:
        if not _inside(rel):
            raise ReleaseError(f"{path}: damaged manifest: path {rel!r} lies outside the "
                               "release (a manifest names files below its own directory): "
                               "restore it from git")
        if rel in seen:
            raise ReleaseError(f"{path}: damaged manifest: path {rel!r} is listed twice (a "
                               "manifest lists each file once): restore it from git")
        seen.add(rel)
    if not isinstance(manifest.get("studies", {}), dict):
        raise ReleaseError(f"{path}: damaged manifest (studies must be a mapping): restore "
                           "it from git")
    name = Path(release).name
    if is_version(name) and manifest.get("version") != name:
        raise ReleaseError(f"{path}: says version {manifest.get('version')!r} but lies in "
                           f"{name}/: restore it from git")
    return manifest


def _inside(rel: str) -> bool:
    """Whether a manifest path names a file below the release: relative, normalised, no
    '..', no hidden part (``../../../../etc/hostname`` was followed)."""
    from pathlib import PurePosixPath

    path = PurePosixPath(rel)
    return (bool(rel) and "\\" not in rel and not path.is_absolute()
            and path.as_posix() == rel
            and not any(part in ("..", ".") or part.startswith(".") for part in path.parts))


def released_studies(spec: str = "latest", data_dir: str | Path = "data") -> list[str]:
    """The studies a release holds (a version or latest), in its manifest's order."""
    return list(read_manifest(find_release(spec, data_dir))["studies"])


def sha256_file(path: str | Path) -> str:
    """Hex sha256 of a regular file's bytes (NotRegularFile for a FIFO or a device)."""
    with open_regular(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


# ------------------------------------------------------------------------------ layout
@dataclass(frozen=True)
class StudyFiles:
    """One study's default files, relative to the data directory (primary dataset first)."""

    study: str
    config_sha256: str
    datasets: tuple[str, ...]
    reports: tuple[str, ...]


@dataclass(frozen=True)
class Layout:
    """Every study's default files plus the cross-study reports (EN-02/EN-02R comparison)."""

    studies: tuple[StudyFiles, ...]
    shared: tuple[str, ...] = ()


@functools.cache
def default_layout() -> Layout:
    """The default-config files of every study, as `snakemake all` writes them."""
    from creatio.pipeline.planning import compare_targets, plan

    plans = plan()

    def rel(path: str) -> str:
        return Path(path).relative_to("data").as_posix()

    studies = tuple(
        StudyFiles(p.study, p.sha256, tuple(rel(d) for d in p.datasets),
                   tuple(rel(r) for r in p.reports))
        for p in plans.values()
    )
    return Layout(studies, tuple(rel(p) for p in compare_targets(plans)))


def _attrs(path: Path) -> dict[str, Any]:
    """Global attributes of a NetCDF file, without loading its data."""
    import xarray as xr

    try:
        check_regular(path)
        with xr.open_dataset(path, engine="netcdf4") as ds:
            return dict(ds.attrs)
    except Exception as e:  # noqa: BLE001 - any unreadable file is refused the same way
        raise ReleaseError(f"cannot read {path}: {e}") from None


def _plain(value: Any) -> Any:
    """A NetCDF attribute as a JSON value."""
    return value.item() if hasattr(value, "item") else value


def _provenance(attrs: dict[str, Any]) -> dict[str, Any]:
    """Package version, commit and library versions recorded in a dataset's attributes."""
    return {
        "creatio_version": str(attrs.get("creatio_version", "")),
        "git_commit": str(attrs.get("git_commit", "")),
        "git_dirty": int(_plain(attrs.get("git_dirty", 1))),
        "libraries": {k.removeprefix("version_"): str(v) for k, v in attrs.items()
                      if k.startswith("version_")},
    }


def _stale(path: str, found: str, expected: str) -> str:
    return (f"{path} was made from config {found[:12] or '?'} but the default config is now "
            f"{expected[:12]}")


def _omission(rel: str, study: str, primary: str) -> str:
    if rel.endswith(".nc"):
        return (f"dt/refine convergence partner of {primary}: its figures are in "
                f"reports/{study}.json (creatio release --with-partners keeps it)")
    if rel.endswith(".png"):
        return "figure, drawn again from the datasets by `snakemake all`"
    return "table derived from the dataset and the JSON report"


def make_release(
    version: str,
    data_dir: str | Path = "data",
    *,
    layout: Layout | None = None,
    with_partners: bool = False,
) -> tuple[Path, dict[str, Any], list[str]]:
    """Freeze the default datasets and reports into <data_dir>/releases/<version>/.

    Returns (directory, manifest, warnings); ReleaseError, before writing, if it cannot."""
    from creatio import __version__
    from creatio.pipeline.provenance import git_state, library_versions

    parse_version(version)
    data_dir = Path(data_dir)
    dest = releases_dir(data_dir) / version
    clean_stale_releases(data_dir)
    if dest.exists():
        newest = list_releases(data_dir)
        hint = f" (the newest is {newest[-1].name})" if newest else ""
        raise ReleaseError(f"release {version} already exists at {dest}: releases are never "
                           f"overwritten; choose a new version{hint}")
    layout = default_layout() if layout is None else layout

    kept: list[tuple[str, StudyFiles | None]] = []
    omitted: list[tuple[str, StudyFiles]] = []
    for sf in layout.studies:
        datasets = sf.datasets if with_partners else sf.datasets[:1]
        kept += [(d, sf) for d in datasets]
        omitted += [(d, sf) for d in sf.datasets if d not in datasets]
        for r in sf.reports:
            (kept if Path(r).suffix in RELEASED_REPORTS else omitted).append((r, sf))
    kept += [(r, None) for r in layout.shared if Path(r).suffix in RELEASED_REPORTS]

    missing = [(rel, sf) for rel, sf in kept if not (data_dir / rel).is_file()]
    # kept or only fingerprinted, an empty file is a killed writer's, never an output
    empty = [rel for rel, _ in [*kept, *omitted] if (data_dir / rel).is_file()
             and (data_dir / rel).stat().st_size == 0]
    if empty:
        raise ReleaseError(f"cannot release {version}: empty files in {data_dir} (a killed "
                           f"writer?): {', '.join(empty)}: remove them and run "
                           "`snakemake all -c 2`")
    if missing:
        raise ReleaseError(
            f"cannot release {version}: missing default outputs in {data_dir}:\n"
            + "".join(f"  {data_dir / rel} ({sf.study if sf else 'comparison'} "
                      f"{'dataset' if rel.endswith('.nc') else 'report'})\n"
                      for rel, sf in missing)
            + "`snakemake all -c 2` makes them (default configs, no overrides)")

    studies: dict[str, dict[str, Any]] = {}
    stale: list[str] = []
    file_attrs: dict[str, dict[str, Any]] = {}
    for sf in layout.studies:
        for rel in sf.datasets if with_partners else sf.datasets[:1]:
            attrs = _attrs(data_dir / rel)
            file_attrs[rel] = attrs
            found = str(attrs.get("config_sha256", ""))
            if found != sf.config_sha256 or attrs.get("study") != sf.study:
                stale.append(_stale(str(data_dir / rel), found, sf.config_sha256))
        report = next((r for r in sf.reports if r.endswith(".json")), None)
        if report is not None:
            try:
                found = str(read_json(data_dir / report).get("config_sha256"))
            except (OSError, ValueError, AttributeError) as e:
                raise ReleaseError(f"cannot read {data_dir / report}: {e}") from None
            if found != sf.config_sha256:
                stale.append(_stale(str(data_dir / report), found, sf.config_sha256))
        primary = file_attrs[sf.datasets[0]]
        studies[sf.study] = {"config_sha256": sf.config_sha256,
                             "datasets": list(sf.datasets[:1] if not with_partners
                                              else sf.datasets),
                             **_provenance(primary)}
    if stale:
        raise ReleaseError(f"cannot release {version}: out of date with the configs:\n"
                           + "".join(f"  {s}\n" for s in stale)
                           + "bring data/ up to date with `snakemake all -c 2`")

    warnings = []
    dirty = sorted(s for s, info in studies.items() if info["git_dirty"])
    if dirty:
        warnings.append(f"datasets of {', '.join(dirty)} were made from a source tree with "
                        "uncommitted changes (git_dirty = 1)")
    commits = sorted({info["git_commit"] for info in studies.values()})
    if len(commits) > 1:
        warnings.append(f"datasets were made at {len(commits)} different commits: "
                        + ", ".join(c[:10] for c in commits))

    commit, tree_dirty = git_state()
    now = _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat()
    files = []
    for rel, sf in kept:
        src = data_dir / rel
        entry: dict[str, Any] = {
            "path": rel,
            "kind": "dataset" if rel.endswith(".nc") else "report",
            "study": sf.study if sf else None,
            "sha256": sha256_file(src),
            "size": src.stat().st_size,
        }
        if sf is not None:
            attrs = file_attrs.get(rel)
            entry["config_sha256"] = sf.config_sha256
            entry.update(_provenance(attrs) if attrs else
                         {k: v for k, v in studies[sf.study].items()
                          if k not in ("config_sha256", "datasets")})
        files.append(entry)
    manifest: dict[str, Any] = {
        "format": FORMAT,
        "version": version,
        "created": now,
        "source": str(data_dir),
        "made_by": {"creatio_version": __version__, "git_commit": commit,
                    "git_dirty": int(tree_dirty), "libraries": library_versions()},
        "total_size": sum(f["size"] for f in files),
        "studies": studies,
        "files": files,
        "omitted": [
            {"path": rel, "study": sf.study,
             "sha256": sha256_file(data_dir / rel) if (data_dir / rel).is_file() else None,
             "size": (data_dir / rel).stat().st_size if (data_dir / rel).is_file() else None,
             "reason": _omission(rel, sf.study, sf.datasets[0])}
            for rel, sf in omitted
        ],
        "warnings": warnings,
    }

    tmp = dest.with_name(f".{version}.tmp-{os.getpid()}")
    try:
        for entry in files:
            out = tmp / entry["path"]
            out.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(data_dir / entry["path"], out)
            if sha256_file(out) != entry["sha256"]:
                raise ReleaseError(f"{data_dir / entry['path']} changed while it was copied")
            out.chmod(READ_ONLY)
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
        (tmp / MANIFEST).chmod(READ_ONLY)
        try:
            tmp.rename(dest)
        except OSError:
            raise ReleaseError(f"release {version} already exists at {dest}: releases are "
                               "never overwritten") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
    return dest, manifest, warnings


def clean_stale_releases(data_dir: str | Path = "data") -> list[Path]:
    """Remove the temporary directories (``.VERSION.tmp-PID``) of releases whose maker no
    longer runs (a SIGKILL leaves one behind: it never becomes a release); returns them."""
    from creatio.store.atomic import clean_stale

    root = releases_dir(data_dir)
    stale = list(root.glob(".*.tmp-*")) if root.is_dir() else []
    for tmp in stale:
        m = re.fullmatch(r"\.(.+)\.tmp-\d+", tmp.name)
        if m and is_version(m.group(1)):
            clean_stale(root / m.group(1))
    return [t for t in stale if not t.exists()]


# ------------------------------------------------------------------------------ verify
def verify_release(release: str | Path) -> list[str]:
    """Problems found checking a release against its manifest as a whole (empty when it is
    intact): each listed file a regular file of the listed size and sha256, never empty; a
    dataset a readable NetCDF file of the study and config its entry names, whatever the
    digests say (a rewritten entry matches a damaged file); a JSON report a JSON object;
    every study's datasets listed; the total size the sum; no file that is not listed."""
    release = Path(release)
    manifest = read_manifest(release)
    problems = []
    listed = set()
    sizes = []
    for entry in manifest["files"]:
        rel = entry["path"]
        listed.add(rel)
        path = release / rel
        if not path.exists():
            problems.append(f"{rel}: missing")
            continue
        try:
            size, digest = _size_digest(path)
        except NotRegularFile as e:
            problems.append(f"{rel}: {e.strerror}")
            continue
        except OSError as e:
            problems.append(f"{rel}: cannot be read ({e.strerror or e})")
            continue
        stated = entry.get("size")
        if digest != entry["sha256"]:
            problems.append(f"{rel}: sha256 {digest[:12]} != manifest {entry['sha256'][:12]}"
                            f" (size {size}, manifest {stated})")
            continue
        if not isinstance(stated, int) or isinstance(stated, bool) or stated != size:
            problems.append(f"{rel}: size {size} != manifest {stated!r}")
        sizes.append(size)
        problems += [f"{rel}: {p}" for p in _content_problems(path, entry, size)]
    total = manifest.get("total_size")
    if (isinstance(total, int) and not isinstance(total, bool) and len(sizes) == len(listed)
            and total != sum(sizes)):
        problems.append(f"{MANIFEST}: total_size {total} != {sum(sizes)}, the sum of the "
                        "listed sizes")
    for study, info in manifest.get("studies", {}).items():
        named = info.get("datasets") if isinstance(info, dict) else None
        for rel in named if isinstance(named, list) else []:
            if rel not in listed:
                problems.append(f"{MANIFEST}: study {study}'s dataset {rel!r} is not among "
                                "the listed files")
    for path in sorted(release.rglob("*")):
        rel = path.relative_to(release).as_posix()
        if rel == MANIFEST or rel in listed or path.is_dir():
            continue
        if path.is_file():
            problems.append(f"{rel}: not in the manifest")
        else:
            problems.append(f"{rel}: not a regular file, and not in the manifest")
    return problems


def _size_digest(path: Path) -> tuple[int, str]:
    """(size, hex sha256) of a regular file, both from the one descriptor read."""
    with open_regular(path, "rb") as fh:
        return os.fstat(fh.fileno()).st_size, hashlib.file_digest(fh, "sha256").hexdigest()


def _content_problems(path: Path, entry: Mapping[str, Any], size: int) -> list[str]:
    """What is wrong with a listed file's content, whatever its entry says: empty (a release
    never holds an empty file), a dataset that is not a readable NetCDF file of the entry's
    study and config, a JSON report that is not a JSON object."""
    rel = entry["path"]
    is_nc = rel.endswith(".nc")
    if entry.get("kind") not in (None, "dataset" if is_nc else "report"):
        return [f"listed as a {entry.get('kind')!r} (a .nc file is a dataset, any other a "
                "report)"]
    if size == 0:
        return ["empty (a release never holds an empty file)"]
    if rel.endswith(".json"):
        try:
            ok = isinstance(read_json(path), dict)
        except (OSError, ValueError):
            ok = False
        return [] if ok else ["not a readable JSON report (a JSON object)"]
    if not is_nc:
        return []
    import netCDF4

    try:
        with netCDF4.Dataset(path) as nc:
            attrs = {k: nc.getncattr(k) for k in ("study", "config_sha256") if k in nc.ncattrs()}
    except Exception as e:  # noqa: BLE001 - whatever the library says, it is not readable
        return [f"not a readable NetCDF dataset ({str(e).splitlines()[0] if str(e) else e!r})"]
    out = []
    for key in ("study", "config_sha256"):
        if entry.get(key) and str(attrs.get(key, "")) != str(entry[key]):
            out.append(f"a dataset of {key} {str(attrs.get(key, '?'))[:12]!r}, listed as "
                       f"{str(entry[key])[:12]!r}")
    return out


# -------------------------------------------------------------- the workflow's release rules
@one_line_errors
def workflow_outputs(plans: Mapping[str, Any], whole: bool = False) -> list[str]:
    """Every file `snakemake all` makes with the default configs; refuses overrides, and
    with whole (a release holds every study) a subset of the studies."""
    from creatio.pipeline.planning import compare_targets, default_studies

    overridden = [p.study for p in plans.values() if p.root != "data"]
    if overridden:
        raise ReleaseError(f"releases and diffs use the default configs, and {overridden} "
                           "have overrides: run without --config overrides=...")
    absent = [s for s in default_studies() if s not in plans]
    if whole and absent:
        raise ReleaseError(f"a release holds every study and {absent} are not selected: run "
                           "without --config studies=...")
    return [f for p in plans.values() for f in (*p.datasets, *p.reports)] + \
        compare_targets(plans)


@one_line_errors
def workflow_version(config: Mapping[str, Any], data_dir: str | Path = "data") -> str:
    """The version `snakemake release` makes: given, valid and not released yet."""
    version = str(config.get("version", ""))
    if not version:
        raise ReleaseError("snakemake release needs --config version=MAJOR.MINOR.PATCH")
    parse_version(version)
    if (releases_dir(data_dir) / version).exists():
        raise ReleaseError(f"release {version} already exists in {releases_dir(data_dir)}: "
                           "releases are never overwritten; choose a new version")
    return version


@one_line_errors
def workflow_against(config: Mapping[str, Any], data_dir: str | Path = "data") -> str:
    """The release `snakemake diff` compares data/ with: a version or latest, which exists."""
    against = str(config.get("against", ""))
    if not against:
        raise ReleaseError("snakemake diff needs --config against=VERSION (or against=latest)")
    return find_release(against, data_dir).name


@one_line_errors
def workflow_release_digest(version: str, data_dir: str | Path = "data") -> str:
    """A hash of what a release holds now (each listed file's bytes, or its absence): the
    diff rule's parameter, so that an edited, deleted or restored release file reruns the
    diff (which then refuses a release that no longer matches its manifest)."""
    release = releases_dir(data_dir) / version
    h = hashlib.sha256()
    for entry in read_manifest(release)["files"]:
        path = release / entry["path"]
        h.update(entry["path"].encode() + b"\0")
        h.update(sha256_file(path).encode() if path.is_file() else b"missing")
    return h.hexdigest()[:16]


@one_line_errors
def workflow_diff_options(config: Mapping[str, Any], plans: Mapping[str, Any]) -> str:
    """`creatio diff` options from --config atol=, rtol=, tol=[...] and the selected studies."""
    import shlex

    from creatio.pipeline.planning import default_studies

    opts = [f"--{k} {shlex.quote(str(config[k]))}" for k in ("atol", "rtol") if k in config]
    tols = config.get("tol", [])
    opts += [f"--tol {shlex.quote(str(t))}" for t in ([tols] if isinstance(tols, str) else tols)]
    if set(plans) != set(default_studies()):
        opts.append(f"--studies {','.join(plans)}")
    return " ".join(opts)


# ------------------------------------------------------------------------------ CLI
DESCRIPTION = """\
Freeze the default datasets and reports of every study into data/releases/VERSION/,
with a MANIFEST.json (per file: sha256, size, study, config hash, creatio version, git
commit, library versions). Releases are committed to the repository and never overwritten.

  creatio release VERSION [--data-dir DIR] [--with-partners]   make a release
  creatio release verify VERSION|latest|DIR                    check files against MANIFEST
  creatio release list                                         known releases, oldest first
"""

EPILOG = f"""\
VERSION is {VERSION_HELP}.
A release keeps each study's dataset at its configured dt, the JSON and markdown reports
(~0.9 MB for the four studies); figures, CSV tables and the dt/refine partner datasets are
listed in the manifest with their sha256 but not copied (--with-partners copies the
partners too). The files are written read-only.

exit status: 0 done (verify: intact); 1 verify found a missing, changed, unreadable or
unexpected file; 2 error (invalid version, release exists, missing or out-of-date data,
damaged or unreadable manifest).

Compare releases with `creatio diff 0.1.0 0.2.0` or with the current data: `creatio diff
latest data`."""


def _create_parser() -> argparse.ArgumentParser:
    ap = Parser(prog="creatio release", description=DESCRIPTION,
                                 epilog=EPILOG,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("version", metavar="VERSION", help="release version, e.g. 0.2.0")
    ap.add_argument("--data-dir", type=Path, default=Path("data"),
                    help="data directory holding studies/ and reports/ (default: data); the "
                         "release goes to DATA_DIR/releases/VERSION")
    ap.add_argument("--with-partners", action="store_true",
                    help="also copy the dt/refine convergence-partner datasets (~0.7 MB)")
    return ap


def _verify_parser() -> argparse.ArgumentParser:
    ap = Parser(
        prog="creatio release verify",
        description="Check a release against its MANIFEST.json as a whole: every file's size "
                    "and sha256, each dataset a readable NetCDF file of its study and config, "
                    "each file listed once.",
        epilog="exit status: 0 intact, 1 a file is missing, changed, unreadable or not in the "
               "manifest, 2 no such release or a damaged or unreadable manifest.")
    ap.add_argument("release", metavar="VERSION|latest|DIR",
                    help="a release version, 'latest', or a release directory")
    ap.add_argument("--data-dir", type=Path, default=Path("data"),
                    help="where releases/ is looked up for a version (default: data)")
    return ap


def _list_parser() -> argparse.ArgumentParser:
    ap = Parser(prog="creatio release list",
                                 description="List the releases, oldest to newest.")
    ap.add_argument("--data-dir", type=Path, default=Path("data"),
                    help="where releases/ is looked up (default: data)")
    return ap


def _kb(n: Any) -> str:
    if not isinstance(n, int | float) or isinstance(n, bool):
        return "? kB"
    return f"{n / 1000:.0f} kB" if n < 1_000_000 else f"{n / 1e6:.2f} MB"


def _list_line(path: Path) -> str:
    """One release as a line of `creatio release list`; a damaged manifest, or one with
    null fields, is listed as such instead of ending the listing."""
    try:
        m = read_manifest(path)
    except ReleaseError as e:
        return f"{path.name:<10} damaged: {e}"
    commits = sorted({str((s or {}).get("git_commit") or "?")[:10]
                      for s in m.get("studies", {}).values() if isinstance(s, dict | None)})
    return (f"{m['version']:<10} {str(m.get('created') or '?'):<26} "
            f"{len(m['files']):>3} files {_kb(m.get('total_size')):>8}"
            f"  commit {', '.join(commits) or '?'}")


def _release_path(spec: str, data_dir: Path) -> Path:
    path = Path(spec)
    if path.is_dir():
        return path
    return find_release(spec, data_dir)


def main(argv: Sequence[str] | None = None) -> int:
    """`creatio release`: make, verify or list releases; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    command = argv[0] if argv and argv[0] in ("create", "verify", "list") else "create"
    if argv and argv[0] == command:
        argv = argv[1:]
    try:
        if command == "verify":
            args = _verify_parser().parse_args(argv)
            path = _release_path(args.release, args.data_dir)
            problems = verify_release(path)
            if problems:
                more = f" (and {len(problems) - 3} more)" if len(problems) > 3 else ""
                print(f"creatio release verify: {path}: {len(problems)} problem(s): "
                      f"{'; '.join(problems[:3])}{more}: restore the release from git "
                      "(git checkout -- PATH)", file=sys.stderr)
                return 1
            n = len(read_manifest(path)["files"])
            print(f"{path}: {n} files match {MANIFEST}")
            return 0
        if command == "list":
            args = _list_parser().parse_args(argv)
            for path in list_releases(args.data_dir):
                print(_list_line(path))
            return 0
        args = _create_parser().parse_args(argv)
        dest, manifest, warnings = make_release(args.version, args.data_dir,
                                                with_partners=args.with_partners)
    except ReleaseError as e:
        print(f"creatio release: {e}", file=sys.stderr)
        return 2
    for w in warnings:
        print(f"creatio release: warning: {w}", file=sys.stderr)
    print(f"release {args.version}: {len(manifest['files'])} files, "
          f"{_kb(manifest['total_size'])}, in {dest} ({len(manifest['omitted'])} derived files "
          f"fingerprinted in {MANIFEST}, not copied)\ncommit it: git add {dest}")
    return 0
