"""The package's layers: imports go one way, the numeric core stays free of the pipeline's
libraries, and planning a workflow loads neither the compiler nor xarray."""

from __future__ import annotations

import ast
import functools
import os
import re
import subprocess
import sys
from pathlib import Path

import creatio

PACKAGE = Path(creatio.__file__).resolve().parent

#: Each layer and the layers it may import (its own included), from the top down: the
#: pipeline runs studies and writes their reports, the reports read datasets, and the
#: dataset store (files, NetCDF, CF) sits below every layer that reads or writes results.
#: No layer imports one above it, and there is no allowance. cli dispatches to everything.
ALLOWED = {
    "model": {"model"},
    "dynamics": {"model", "dynamics"},
    "studies": {"model", "dynamics", "studies"},
    "store": {"store"},
    "reports": {"model", "dynamics", "studies", "store", "reports"},
    "pipeline": {"model", "dynamics", "studies", "store", "reports", "pipeline"},
    "diff": {"model", "dynamics", "studies", "store", "pipeline", "diff"},
    "scenes": {"model", "dynamics", "studies", "store", "reports", "pipeline", "scenes"},
}
#: Top-level modules every layer may import.
SHARED = {"errors", "__init__"}


@functools.cache
def _parse(text: str) -> ast.Module:
    """A source's syntax tree, parsed once for the three checks that walk every module."""
    return ast.parse(text)


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    """(module, names) of every `import creatio...` / `from creatio... import ...` in a file."""
    out = []
    for node in ast.walk(_parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module == "creatio" or node.module.startswith("creatio."):
                out.append((node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names if a.name.startswith("creatio")]
    return out


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_imports_go_one_way_and_no_private_names_cross_packages():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        layer = rel.parts[0] if len(rel.parts) > 1 else rel.stem
        if layer not in ALLOWED:
            continue
        for module, names in _imports(path):
            target = _layer(module)
            if module == "creatio":  # from creatio import <subpackage> (or __version__)
                targets = {n for n in names if n != "__version__"}
            else:
                targets = {target}
            for t in targets:
                if t not in ALLOWED[layer] | SHARED:
                    bad.append(f"{rel}: imports {module} ({t}) from layer {layer}")
            if target != layer:
                bad += [f"{rel}: imports private {module}.{n}" for n in names
                        if n.startswith("_") and n != "__version__"]
    assert not bad, "\n".join(bad)


def _upward_strings(path: Path, layer: str) -> list[str]:
    """Every string constant of a file that starts with ``creatio.<layer>`` for a layer this
    file's layer may not import: an import path by name (importlib, a registry entry) is as
    much an arrow up as an import statement, and the import test cannot see it."""
    allowed = ALLOWED[layer] | SHARED
    bad = []
    for node in ast.walk(_parse(path.read_text())):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            m = re.match(r"creatio\.(\w+)", node.value)
            if m and m.group(1) in ALLOWED and m.group(1) not in allowed:
                bad.append(f"line {node.lineno}: {node.value!r}")
    return bad


def test_no_lower_layer_names_a_higher_one_in_a_string():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        layer = rel.parts[0] if len(rel.parts) > 1 else rel.stem
        if layer in ALLOWED:
            bad += [f"{rel}: {b}" for b in _upward_strings(path, layer)]
    assert not bad, "\n".join(bad)


def test_the_string_check_catches_a_planted_name(tmp_path):
    """The check itself: a registry entry naming a report writer planted in the studies'
    layer is caught, in a plain string and in an f-string; the same text in a docstring's
    prose, or naming the studies' own layer, is not."""
    planted = tmp_path / "planted.py"
    planted.write_text('"""Writers live in creatio.reports.registry."""\n'
                       'W = "creatio.reports.sphere:write_report"\n'
                       'name = "x"\nF = f"creatio.pipeline.{name}:run"\n'
                       'OK = "creatio.studies.sphere:run"\n')
    assert [b.split(":")[0] for b in _upward_strings(planted, "studies")] == ["line 2",
                                                                               "line 4"]
    assert _upward_strings(planted, "pipeline") == []


def _import_graph() -> dict[str, set[str]]:
    """Every creatio module -> the creatio modules it imports anywhere, functions included.
    ``from creatio.a import b`` is an arrow to creatio.a.b where that is a module, else to
    creatio.a (importing a submodule runs its package's __init__ first whatever it names,
    so that alone is no arrow to the package)."""
    modules: dict[str, Path] = {}
    for path in PACKAGE.rglob("*.py"):
        parts = ("creatio", *path.relative_to(PACKAGE).with_suffix("").parts)
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph: dict[str, set[str]] = {}
    for mod, path in modules.items():
        deps: set[str] = set()
        for module, names in _imports(path):
            subs = {f"{module}.{n}" for n in names} & modules.keys()
            deps |= subs if subs and len(subs) == len(names) else {module} | subs
        graph[mod] = {d for d in deps if d in modules and d != mod}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every import circle, each once, as the path from its first module in sorted order
    (a depth-first search that only visits modules after the start: Johnson's idea without
    the blocking, which a graph of a few hundred modules does not need)."""
    order = {m: i for i, m in enumerate(sorted(graph))}
    found: list[list[str]] = []

    def walk(start: str, path: list[str]) -> None:
        for nxt in sorted(graph[path[-1]]):
            if nxt == start:
                found.append(list(path))
            elif order[nxt] > order[start] and nxt not in path:
                walk(start, [*path, nxt])

    for module in sorted(graph):
        walk(module, [module])
    return found


def test_cycles_finds_circles_of_any_length():
    """The search itself, on a graph with a 2-, a 3- and a 4-circle sharing modules and a
    long acyclic chain: exactly those three circles, each once."""
    graph = {"a": {"b"}, "b": {"a", "c"}, "c": {"d"}, "d": {"b", "e"}, "e": {"f"},
             "f": {"g", "h"}, "g": {"h"}, "h": {"i"}, "i": {"e"}, "z": {"a"}}
    assert sorted(_cycles(graph)) == [["a", "b"], ["b", "c", "d"], ["e", "f", "g", "h", "i"],
                                      ["e", "f", "h", "i"]]
    graph["i"] = set()
    assert sorted(_cycles(graph)) == [["a", "b"], ["b", "c", "d"]]


def test_no_import_circle_of_any_length():
    """No module imports, at the top or inside a function, one that leads back to it: a
    circle of three or four (scenes' compute -> needs -> config -> family -> compute) is as
    much a circle as two modules importing each other."""
    circles = [" -> ".join([*c, c[0]]) for c in _cycles(_import_graph())]
    assert circles == [], "\n".join(circles)


def _loaded_after(code: str) -> set[str]:
    """Which of the heavy libraries a fresh interpreter has loaded after running code (the
    config cache off, so that planning really composes)."""
    probe = (f"{code}\nimport sys\nprint(' '.join(m for m in ('numba', 'xarray', 'matplotlib', "
             "'hydra', 'snakemake', 'scipy') if m in sys.modules))")
    env = {**os.environ, "CREATIO_CONFIG_CACHE": "off"}
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, env=env).stdout
    return set(out.split())


def test_numeric_core_imports_no_pipeline_library():
    loaded = _loaded_after("import creatio.model.surface, creatio.model.cavity, "
                           "creatio.model.sphere, creatio.dynamics.simulation")
    assert "numba" in loaded  # the compiled half really was imported
    assert not loaded & {"xarray", "matplotlib", "hydra", "snakemake"}, loaded


def test_planning_a_workflow_loads_neither_the_compiler_nor_xarray():
    loaded = _loaded_after("from creatio.pipeline.planning import plan\nplan()")
    assert "hydra" in loaded  # planning composed the configs
    assert not loaded & {"numba", "xarray", "matplotlib"}, loaded


def test_planning_an_explorable_scene_loads_neither_the_compiler_nor_xarray():
    """A scene with a family, overridden (its page size checked, its studies' links
    composed), as `snakemake scenes --config 'overrides=[...]'` plans it."""
    loaded = _loaded_after("from creatio.scenes.plan import SceneRuns\n"
                           "runs = SceneRuns(['sphere.mu=0.2741'], ['en02'])\n"
                           "runs.targets()\n"
                           "assert runs.family(runs.plans['en02'].root, 'en02')")
    assert "hydra" in loaded
    assert not loaded & {"numba", "xarray", "matplotlib"}, loaded
