"""A run that must compile says so first (creatio.dynamics.jit.ensure_compiled): one line
naming the specialisation and about how long it takes, from the last compile recorded on
this machine, else the table of measured figures; a cached specialisation prints nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from creatio.dynamics import jit

#: A module with one cached function, compiled through ensure_compiled in a fresh process.
MODULE = '''
from creatio.dynamics.jit import ensure_compiled, njit


@njit(cache=True)
def triple(x):
    return 3.0 * x


ensure_compiled(triple, (2.0,), "a test function")
print(triple(2.0), sum(triple.stats.cache_hits.values()), sum(triple.stats.cache_misses.values()))
'''


def _run(tmp_path: Path, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "CREATIO_NUMBA_CACHE": str(cache),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    env.pop("NUMBA_CACHE_DIR", None)
    return subprocess.run([sys.executable, "-c", "import tripled"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)


def test_an_uncached_specialisation_is_announced_once_then_loaded(tmp_path: Path) -> None:
    (tmp_path / "tripled.py").write_text(MODULE)
    cache = tmp_path / "cache"
    first = _run(tmp_path, cache)
    assert first.returncode == 0, first.stderr
    (line,) = first.stderr.strip().splitlines()
    assert line.startswith("creatio: compiling a test function (triple, not in the cache ")
    # no figure recorded yet for this name: the table's largest, and it says where it is from
    worst = max(jit.COMPILE_SECONDS.values())
    assert f"): about {jit._duration(worst)} (measured for the " in line
    assert first.stdout.split() == ["6.0", "0", "1"]  # compiled once: one miss, no hit
    recorded = json.loads((cache / "compile_times.json").read_text())
    assert set(recorded) == {"triple"} and 0.0 <= recorded["triple"] < 300.0
    second = _run(tmp_path, cache)
    assert second.returncode == 0 and second.stderr == ""  # loaded from the cache: silent
    assert second.stdout.split() == ["6.0", "1", "0"]


def test_the_estimate_is_the_last_compile_here_else_the_measured_table(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CREATIO_NUMBA_CACHE", str(tmp_path))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    # nothing recorded: the figure of the entry's stepper kind (the longest matching name)
    assert jit.compile_estimate("_radau5_rot_en")[0] == jit.COMPILE_SECONDS["radau5"]
    assert (jit.compile_estimate("_radau_sphere_structure")[0]
            == jit.COMPILE_SECONDS["radau_high_order"])
    assert jit.compile_estimate("_hybrid_control")[0] == jit.COMPILE_SECONDS["hybrid"]
    jit._record("_radau_rot_en", 12.34)
    # kept at the cache's root, beside the per-source directories: it outlives an edit
    assert (tmp_path / "compile_times.json").is_file()
    assert jit.compile_estimate("_radau_rot_en") == (12.3, "its last compile here")
    assert jit.compile_estimate("_explicit_rot_en")[0] == jit.COMPILE_SECONDS["explicit"]
    (tmp_path / "compile_times.json").write_text("{not json")
    assert jit.compile_estimate("_radau5_rot_en")[0] == jit.COMPILE_SECONDS["radau5"]
