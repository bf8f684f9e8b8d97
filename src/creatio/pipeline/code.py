"""Code versions: a short hash of the sources that make one kind of output.

A Snakemake rule carries the version of its kind as a parameter (``code=``), so new code
reruns what it would compute differently; a sweep batch records the version it was computed
with, and a point is reused only by the same version (creatio.pipeline.sweep).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

__all__ = ["CODE", "code_version", "package_version"]


# The sources whose change changes a rule's outputs (relative to the package): a rule
# carries their hash as a parameter, so new code reruns what it would compute differently.
CODE = {
    "datasets": ("model", "dynamics", "studies", "store", "pipeline/run.py",
                 "pipeline/provenance.py", "pipeline/sweep.py", "pipeline/points.py",
                 "pipeline/checks.py"),
    "reports": ("reports", "store", "pipeline/run.py", "pipeline/provenance.py",
                "pipeline/checks.py"),
    "scenes": ("scenes", "store", "pipeline/provenance.py"),
}


@functools.cache
def code_version(kind: str, package: Path | None = None) -> str:
    """A short hash of the sources that make one kind of output (see CODE), read from the
    installed package or from package."""
    package = package or Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for part in CODE[kind]:
        target = package / part
        for path in sorted(target.rglob("*.py")) if target.is_dir() else [target]:
            if path.is_file():
                h.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:12]


def package_version(package: Path | None = None) -> str:
    """A short hash of every source of the package, read now (not cached): what a warm
    worker (creatio.pipeline.worker) was started with must equal it, or it serves no one.
    Wider than any one kind of code_version, since the worker runs every command."""
    package = package or Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        if "__pycache__" not in path.parts and path.is_file():
            h.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:12]
