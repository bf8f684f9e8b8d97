"""Provenance of what the pipeline writes: the resolved config (YAML) and its sha256, the
package version, the git commit and dirty flag, library versions, the command and the
creation time, so that reading a dataset back tells exactly how it was made. The files
themselves are written and read below the pipeline and the reports, by creatio.store."""

from __future__ import annotations

import contextlib
import datetime as _dt
import functools
import platform
import shlex
import subprocess
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import creatio

__all__ = ["VOLATILE_ATTRS", "command_line", "git_state", "library_versions", "provenance"]

REPO_ROOT = Path(__file__).resolve().parents[3]
LIBRARIES = ("numpy", "scipy", "xarray", "netCDF4", "numba", "hydra-core", "snakemake")
# Attributes that change on every run; diffs ignore them unless asked.
VOLATILE_ATTRS = ("history", "date_created")


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


