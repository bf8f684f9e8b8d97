"""The page's one third-party script: three.js, bundled and minified once, inlined in every page.

``web/package.json`` and ``web/package-lock.json`` pin three.js and esbuild exactly (with
their integrity hashes); :func:`build_library` installs them with ``npm ci`` in a scratch
directory (nothing lands in the source tree, no install scripts run) and bundles
``web/three-entry.js`` (only the classes the viewer uses, plus OrbitControls) into one
minified IIFE that defines ``THREE``. The bundle is a build product (``snakemake scenes``
writes it to ``data/scenes/lib/three.min.js``); pages inline it, so they open offline.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from creatio.store.regular import read_bytes

__all__ = ["WEB", "build_library", "library_inputs", "web_file"]

#: The viewer's sources: page template, viewer script and style, npm manifest and lock.
WEB = Path(__file__).resolve().parent / "web"

#: What the bundle is built from (a change to any of them rebuilds it).
INPUTS = ("package.json", "package-lock.json", "three-entry.js")


def web_file(name: str) -> str:
    """The text of one of the viewer's source files."""
    return (WEB / name).read_text(encoding="utf-8")


def library_inputs() -> list[Path]:
    """The files the bundle is built from."""
    return [WEB / name for name in INPUTS]


def build_library(out: str | Path, npm: str | None = None) -> Path:
    """Install the pinned three.js and esbuild (``npm ci``) in a scratch directory and bundle
    the viewer's three.js entry into ``out`` (minified, licence comments kept).

    Raises RuntimeError naming the missing tool or the failed command.
    """
    npm = npm or shutil.which("npm")
    node = shutil.which("node")
    if npm is None or node is None:
        raise RuntimeError("building the scene pages' three.js bundle needs Node.js and npm "
                           "(Debian: apt-get install nodejs npm)")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="creatio-web-") as tmp:
        for name in INPUTS:
            shutil.copy2(WEB / name, Path(tmp) / name)
        env = {**os.environ, "npm_config_update_notifier": "false"}
        _run([npm, "ci", "--ignore-scripts", "--no-audit", "--no-fund", "--loglevel=error"],
             tmp, env)
        target = Path(tmp) / "bundle.js"
        script = ("require('esbuild').buildSync({entryPoints: ['three-entry.js'], bundle: true,"
                  " minify: true, format: 'iife', globalName: 'THREE', legalComments: 'inline',"
                  f" target: ['es2020'], outfile: {str(target)!r}}})")
        _run([node, "-e", script], tmp, env)
        tmp_out = out.with_name(f".{out.name}.tmp-{os.getpid()}")
        shutil.copyfile(target, tmp_out)
        os.replace(tmp_out, out)
    return out


def _run(cmd: list[str], cwd: str, env: dict[str, str]) -> None:
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd[:3])} failed ({done.returncode}):\n"
                           f"{done.stderr.strip()[-2000:]}")


def digest(path: str | Path) -> str:
    """sha256 of a file (the page records the bundle's)."""
    return hashlib.sha256(read_bytes(path)).hexdigest()
