"""NetCDF dataset I/O: atomic writes, CF-1.10 metadata (creatio.pipeline.cf), full provenance.

Every dataset carries the resolved config (YAML) and its sha256, the package version, the
git commit and dirty flag, library versions and the creation time, so that reading it back
tells exactly how it was made.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import functools
import json
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
import yaml

import creatio
from creatio.pipeline import cf

__all__ = [
    "atomic_path",
    "atomic_save",
    "atomic_write",
    "clean_stale",
    "command_line",
    "git_state",
    "provenance",
    "read_dataset",
    "write_dataset",
]

REPO_ROOT = Path(__file__).resolve().parents[3]
LIBRARIES = ("numpy", "scipy", "xarray", "netCDF4", "numba", "hydra-core", "snakemake")
# Attributes that change on every run; diffs ignore them unless asked.
VOLATILE_ATTRS = ("history", "date_created")
SMALL_BYTES = 4096


@functools.cache
def git_state() -> tuple[str, bool]:
    """(commit, dirty) of the source tree, or ("unknown", True) outside a git checkout."""
    try:
        commit = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=REPO_ROOT, capture_output=True, text=True,
            check=True,
        ).stdout.strip()
        status = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no", "--", "src", "conf",
             "Snakefile", "workflows", "pyproject.toml", "constraints.txt"],
            cwd=REPO_ROOT, capture_output=True, text=True, check=True,
        ).stdout
        return commit, bool(status.strip())
    except (OSError, subprocess.CalledProcessError):
        return "unknown", True


def library_versions() -> dict[str, str]:
    """Versions of Python and the numeric/workflow libraries in use."""
    out = {"python": platform.python_version()}
    for lib in LIBRARIES:
        try:
            out[lib] = version(lib)
        except PackageNotFoundError:
            out[lib] = "absent"
    return out


#: Entry points that are the `creatio` command (the console script, `python -m creatio.cli`
#: as the Snakefile calls it, the Hydra apps that set argv[0] to "creatio run").
_CREATIO_ENTRIES = ("creatio", "cli.py", "__main__.py")
#: Arguments longer than this (a config passed as YAML text) are shortened in `history`.
_ARG_WIDTH = 80


def command_line(argv: list[str] | None = None) -> str:
    """The command that is running, as a person would type it: ``creatio task dataset en02
    data/studies/en02/en02_dt0.002.nc ...``, not the absolute path of cli.py; paths inside
    the working directory relative to it, long arguments shortened."""
    argv = list(sys.argv if argv is None else argv)
    if not argv:
        return "python"
    head = argv[0]
    if Path(head).name in _CREATIO_ENTRIES or head.startswith("creatio "):
        head = head if head.startswith("creatio ") else "creatio"
    else:
        head = Path(head).name
    cwd = Path.cwd()
    args = []
    for arg in argv[1:]:
        if arg.startswith("/"):
            with contextlib.suppress(ValueError):
                arg = str(Path(arg).relative_to(cwd))
        if len(arg) > _ARG_WIDTH:
            arg = arg[: _ARG_WIDTH - 3].replace("\n", " ") + "..."
        args.append(shlex.quote(arg))
    return " ".join([head, *args])


def provenance(study: str, config_yaml: str, config_sha256: str, title: str) -> dict[str, Any]:
    """CF-style global attributes plus provenance for one study dataset."""
    commit, dirty = git_state()
    now = _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat()
    attrs: dict[str, Any] = {
        "Conventions": "CF-1.10",
        "title": title or study,
        "institution": "creatio",
        "source": f"creatio {creatio.__version__}",
        "history": f"{now} created by creatio {creatio.__version__}: {command_line()}",
        "references": f"CREATIO technical notebook, study {study.upper()}",
        "study": study,
        "creatio_version": creatio.__version__,
        "git_commit": commit,
        "git_dirty": int(dirty),
        "config_yaml": config_yaml,
        "config_sha256": config_sha256,
        "date_created": now,
    }
    attrs.update({f"version_{k.replace('-', '_')}": v for k, v in library_versions().items()})
    return attrs


def atomic_path(path: Path) -> Path:
    """A temporary sibling of path, to be renamed over it once complete."""
    return path.with_name(f".{path.name}.tmp-{os.getpid()}")


def clean_stale(path: Path) -> None:
    """Remove temporary siblings of path left by a process that no longer runs (a kill)."""
    for tmp in path.parent.glob(f".{path.name}.tmp-*"):
        m = re.match(r".*\.tmp-(\d+)", tmp.name)
        if m and int(m.group(1)) != os.getpid() and not _alive(int(m.group(1))):
            with contextlib.suppress(OSError):
                if tmp.is_dir():
                    shutil.rmtree(tmp)
                else:
                    tmp.unlink()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _no_space(path: Path, error: Exception) -> OSError:
    """The cause of a failed write where the library names none ("NetCDF: HDF error"): a
    full disk is named as such."""
    try:
        free = shutil.disk_usage(path.parent).free
    except OSError:
        free = -1
    if isinstance(error, OSError) and error.errno in (errno.ENOSPC, errno.EDQUOT):
        return OSError(error.errno, os.strerror(error.errno), str(path))
    if 0 <= free < 1 << 20:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return OSError(errno.EIO, f"could not be written ({error})", str(path))


@contextlib.contextmanager
def atomic_write(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[Any]:
    """Open a temporary sibling of path for writing and rename it over path when the block
    ends without error: a killed or failed writer never leaves a partial or empty file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(path)
    tmp = atomic_path(path)
    try:
        with tmp.open(mode, **kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_save(path: str | Path, save: Any) -> Path:
    """Call save(temporary path) (a figure's savefig, say) and rename the result over path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    clean_stale(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}{path.suffix}")  # keeps the format
    try:
        save(tmp)
        if not tmp.is_file() or tmp.stat().st_size == 0:
            raise OSError(errno.EIO, "nothing was written", str(path))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _netcdf_attr(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, Mapping | list | tuple) and not isinstance(value, str):
        return json.dumps(value)
    if value is None:
        return ""
    return value


def _encoding(ds: xr.Dataset) -> dict[Any, dict[str, Any]]:
    """Storage of each variable: CF's (text as character arrays, coordinates without
    _FillValue), and compression for what is large; small variables are stored
    contiguously (chunk indexes and compression headers would cost more than they save)."""
    encoding = cf.encoding(ds)
    for name, var in ds.variables.items():
        if var.dtype.kind not in "fiub" and not cf.is_string(var):
            continue
        if var.size == 0:  # HDF5 refuses contiguous storage of nothing (an empty event table)
            continue
        size = var.nbytes
        if cf.is_string(var):
            size = var.size * max((len(str(v).encode()) for v in np.ravel(var.values)),
                                  default=1)
        encoding[name].update({"zlib": True, "complevel": 4} if size > SMALL_BYTES
                              else {"contiguous": True})
    return encoding


def write_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ds as compressed CF-1.10 NetCDF4 atomically (temp file, then rename); the
    metadata are made CF-conformant here, once for every dataset (creatio.pipeline.cf)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    ds = ds.copy()
    ds.attrs = {k: _netcdf_attr(v) for k, v in ds.attrs.items()}
    for var in ds.variables.values():
        var.attrs = {k: _netcdf_attr(v) for k, v in var.attrs.items()}
    ds = cf.conform(ds)
    encoding = _encoding(ds)
    clean_stale(path)
    tmp = atomic_path(path)
    try:
        try:
            ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
        except (OSError, RuntimeError) as e:  # netCDF4 reports a full disk as "HDF error"
            raise _no_space(path, e) from None
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def read_dataset(path: str | Path) -> tuple[xr.Dataset, dict]:
    """Load a dataset fully into memory and return it with its resolved config, as its
    study made it: the units it stated and text labels as strings (cf.restore)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(errno.ENOENT, "no dataset here", str(path))
    try:
        # Times stay seconds (CF's reference date is a placeholder: docs/datasets.md).
        ds = cf.restore(xr.load_dataset(path, engine="netcdf4", decode_times=False))
        config = yaml.safe_load(ds.attrs.get("config_yaml", "")) or {}
    except Exception as e:  # noqa: BLE001 - truncated, not NetCDF, unreadable attrs
        raise OSError(errno.EIO, f"not a readable creatio dataset ({type(e).__name__}): "
                      "remove it and rerun the rule that makes it", str(path)) from None
    return ds, config
