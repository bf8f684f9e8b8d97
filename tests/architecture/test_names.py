"""Every module and file the project names exists: a renamed module leaves no stale name in
src, tests, docs, README, scripts, workflows or conf (a dotted creatio.<module> path, a
src/creatio/... or tests/... file path)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "src" / "creatio"

#: Where names of modules and files are written.
WHERE = ("src", "tests", "docs", "scripts", "workflows", "conf", "README.md", "Snakefile",
         "Makefile", ".ci", "pyproject.toml")
#: A dotted module path, possibly broken across a line before a dot (the house style).
DOTTED = re.compile(r"\bcreatio((?:\n?\.)[A-Za-z_][A-Za-z_0-9]*)+")
#: A file path under src/creatio or tests, or a page of docs/.
FILE = re.compile(r"\b(?:(?:src/creatio|tests)/[A-Za-z_0-9/]+\.py|docs/[A-Za-z_0-9]+\.md)\b")


def _files() -> list[Path]:
    """The tracked text files of WHERE but this one (its planted old names are the test's)."""
    out = subprocess.run(["git", "ls-files", *WHERE], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout.split()
    return [ROOT / f for f in out if not f.endswith((".png", ".nc", ".webp", ".mp4", ".gz"))
            and ROOT / f != Path(__file__).resolve()]


def _resolves(parts: list[str]) -> bool:
    """True when creatio.<parts> names a module or package, or an attribute written in one;
    a first part that is no module of the package (creatio.yaml, creatio.__file__) is prose."""
    if not ((PACKAGE / parts[0]).is_dir() or (PACKAGE / f"{parts[0]}.py").is_file()):
        return True
    path = PACKAGE
    for i, part in enumerate(parts):
        if (path / part).is_dir():
            path = path / part
            continue
        if (path / f"{part}.py").is_file():
            path = path / f"{part}.py"
            rest = parts[i + 1:]
            return not rest or _defines(path, rest[0])
        init = path / "__init__.py"
        return init.is_file() and _defines(init, part)
    return True


def _defines(module: Path, name: str) -> bool:
    """True when the module's text binds name (def, class, assignment or import); a dunder
    (__file__) every module has."""
    if name.startswith("__"):
        return True
    text = module.read_text()
    return re.search(rf"(^|\W){re.escape(name)}\b", text) is not None


def names_in(text: str) -> list[str]:
    """Every dotted module path or file path of a text that names nothing."""
    bad = []
    for m in DOTTED.finditer(text):
        parts = re.sub(r"\s", "", m.group(0)).removeprefix("creatio").strip(".").split(".")
        if not _resolves(parts):
            bad.append(f"creatio.{'.'.join(parts)}")
    bad += [m.group(0) for m in FILE.finditer(text) if not (ROOT / m.group(0)).exists()]
    return bad


def stale(files: list[Path]) -> list[str]:
    """`file: name` for every name of a module or file that does not exist."""
    bad = []
    for f in files:
        try:
            text = f.read_text()
        except (UnicodeDecodeError, OSError):
            continue
        bad += [f"{f.relative_to(ROOT)}: {name}" for name in names_in(text)]
    return bad


def test_no_stale_module_or_file_name() -> None:
    """No name of a module or file that does not exist, anywhere the project writes one."""
    assert stale(_files()) == []


@pytest.mark.parametrize("planted", [
    "see creatio.dynamics.solvers.hybrid.run_flight",
    "see creatio.pipeline.io",
    "see creatio.dynamics.solvers\n.radau_vo, the stepper",
    "see tests/dynamics/solvers/test_radau.py",
    "see docs/solvers.md",
])
def test_a_planted_stale_name_is_found(planted: str) -> None:
    """The check fails on an old name (a module or a test file renamed away) and passes the
    new one."""
    assert names_in(planted)
    assert names_in("see creatio.dynamics.solvers.flight.run_flight, creatio.pipeline"
                    ".provenance and tests/dynamics/solvers/test_radau5.py") == []
