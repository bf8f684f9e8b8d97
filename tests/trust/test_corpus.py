"""A regression corpus of bad inputs (issue 28, slow tier: `pytest -m slow`).

Every numeric key of every study's config at 0, -1, nan, inf, 1e300, 1e-300 and "abc", and
every string key with quotes and `${...}`: each is accepted, or refused as a ConfigError whose
message is one line naming a key ("invalid config: KEY=VALUE: rule"); nothing else may come
out (no ValueError from the numeric core, no MemoryError, no traceback). Most of it runs in
process, cheaply (the numeric values through creatio.studies.schema.vary, the validation every
sweep point meets; "abc", one numeric value per key in turn, and the strings through Hydra,
as `creatio run` composes them); a few cases go through the command line and Snakemake, where
the refusal must be one line, exit 2, with nothing written.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import is_dataclass
from pathlib import Path
from typing import Any

import pytest

from creatio.errors import ConfigError

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
VALUES = ("0", "-1", "nan", "inf", "1e300", "1e-300", "abc")
STRINGS = ("'a b'", "\"it's\"", "${oc.env:HOME}", "'${x}'", "a\\${y}")


def _studies() -> list[str]:
    from creatio.studies import registry

    return list(registry.STUDIES)


def _leaves(data: dict, prefix: str = "") -> Iterator[tuple[str, str]]:
    """(dotted key, "scalar" | "list" | "str") of every number, list of numbers and string;
    an analysis's bases (whole study configs, covered by the studies) left out."""
    for name, value in data.items():
        key = f"{prefix}{name}"
        if key == "bases":
            continue
        if isinstance(value, dict):
            yield from _leaves(value, f"{key}.")
        elif isinstance(value, bool):
            continue
        elif isinstance(value, int | float):
            yield key, "scalar"
        elif isinstance(value, list) and value and all(
                isinstance(x, int | float) and not isinstance(x, bool) for x in value):
            yield key, "list"
        elif isinstance(value, str):
            yield key, "str"


def _typed(text: str) -> Any:
    return {"nan": math.nan, "inf": math.inf}.get(text, text if text == "abc" else float(text))


def _one_line_refusal(error: Exception) -> str | None:
    """Why a refusal is not the one line it must be (None: it is)."""
    text = str(error)
    if not isinstance(error, ConfigError):
        return f"{type(error).__name__}: {text.splitlines()[0] if text else ''}"
    if "\n" in text or not text.startswith("invalid config: "):
        return f"not one line naming a key: {text!r}"
    return None


def _reachable(obj: Any, key: str) -> bool:
    """Whether vary can set the key (a path of dataclasses, not through a dict)."""
    node = obj
    for part in key.split(".")[:-1]:
        node = getattr(node, part, None)
        if not is_dataclass(node):
            return False
    return True


@pytest.mark.parametrize("study", _studies())
def test_every_numeric_key_at_every_bad_value_is_accepted_or_one_line(study):
    """In process, as a sweep point meets them (vary: types, finiteness, magnitudes, every
    rule): 7 values for each numeric key."""
    from creatio.pipeline.config import resolve
    from creatio.studies.schema import vary

    base = resolve(study)
    wrong = []
    for key, kind in _leaves(base.data):
        if kind == "str" or not _reachable(base.obj, key):
            continue
        for text in VALUES:
            value = _typed(text)
            try:
                vary(base.obj, {key: [value] if kind == "list" else value})
            except Exception as e:  # noqa: BLE001 - the corpus classifies every outcome
                why = _one_line_refusal(e)
                if why:
                    wrong.append(f"{key}={text}: {why}")
    assert wrong == []


@pytest.mark.parametrize("study", _studies())
def test_every_key_through_hydra_is_accepted_or_one_line(study, monkeypatch):
    """As `creatio run` composes them (Hydra, OmegaConf, validate): "abc" for every numeric
    key, one of the numeric values for each in turn, and quotes and interpolations for every
    string key (quotes accepted verbatim or refused by the key's rule, ${...} refused)."""
    from creatio.pipeline import config

    monkeypatch.setenv("CREATIO_CONFIG_CACHE", "off")
    base = config.resolve(study)
    wrong = []
    for i, (key, kind) in enumerate(_leaves(base.data)):
        if kind == "str":
            cases = [f"{key}={s}" for s in STRINGS]
        else:
            values = ("abc", VALUES[i % (len(VALUES) - 1)])
            cases = [f"{key}=[{v}]" if kind == "list" else f"{key}={v}" for v in values]
        for override in cases:
            try:
                resolved = config.resolve(study, [override])
            except Exception as e:  # noqa: BLE001 - the corpus classifies every outcome
                why = _one_line_refusal(e)
                if why:
                    wrong.append(f"{override}: {why}")
                elif "${" in override and "interpolations" not in str(e):
                    wrong.append(f"{override}: refused, but not as an interpolation: {e}")
                continue
            if "${" in override:
                wrong.append(f"{override}: an interpolation was accepted")
            elif kind == "str" and override.endswith(("'a b'", "\"it's\"")):
                got = resolved.data
                for part in key.split("."):
                    got = got[part]
                if got not in ("a b", "it's"):
                    wrong.append(f"{override}: the value became {got!r}")
    assert wrong == []


def _creatio(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "creatio.cli", *args], capture_output=True,
                          text=True, cwd=cwd, env={**os.environ, "CREATIO_DEBUG": ""})


@pytest.mark.parametrize("args", [
    ["run", "study=en02", "sphere.mu=abc"],
    ["run", "study=en02", "sphere.eps=1e-300"],
    ["run", "study=ct02", "geometry.A=inf"],
    ["run", "study=en01", "study.n_radii=-1"],
    ["run", "study=en02f", "study.cycles_s=[nan]"],
    ["run", "study=en03", "structure.inertia=0"],
    ["run", "study=en02", "study.title=${oc.env:HOME}"],
    ["run", "-m", "study=en02", "sphere.mu=0.1,abc", "sphere.g=1e300"],
    ["probe", "alpha=inf"],
    ["task", "dataset", "en02", "out.nc", "--override", "solver.dt=1e300"],
    ["run", "study=en04", "study.control.duration=1e9"],
    ["run", "study=en04", "study.control.extrema.n_alpha=10000000"],
    ["run", "study=en05", "study.sensitivity.base_sizes=[1048576]"],
    ["run", "study=en02g", "study.initial.alpha_deg=1e15"],
    ["run", "study=ct02", "study.title=${oc.env:HOME}", "--cfg", "job", "--resolve"],
    ["run", "study=en02", "sphere.mu=0,3"],
    ["run", "-m", "study=en02", "sphere.mu=range(0,0.3,abc)"],
])
def test_the_command_line_refuses_in_one_line_writing_nothing(tmp_path, args):
    proc = _creatio(*args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "invalid config: " in proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("entry", [
    'overrides=["sphere.eps=inf"]',
    'overrides=["geometry.R0=abc"]',
    "overrides=['study.title=''${oc.env:HOME}''']",
    'overrides=["sphere.muu=0.3"]',
    'overrides=["study.control.duration=1e9"]',
    'overrides=["sphere.mu=0,3"]',
    'studies=["en2"]',
    ("diff", "against=0.2.0", 'tol=["x=abc"]'),
    ("scenes", 'scenes=["en2"]'),
])
def test_snakemake_refuses_in_one_line_writing_nothing(tmp_path, entry):
    target, *entries = ("all", entry) if isinstance(entry, str) else entry
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(tmp_path),
         "-c", "1", target, "--config", *entries], capture_output=True, text=True,
        cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("creatio")]
    assert len(lines) == 1 and "invalid config: " in lines[0], proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("study", ["en04", "en05", "en02f", "en01"])
def test_every_size_through_hydra_is_refused_in_one_line(study, monkeypatch):
    """The size walk of test_boundary.py as `creatio run` composes it (Hydra, OmegaConf,
    validate): each size past its limit refused by its key, in one line, stating the limit."""
    from test_boundary import SIZES, WITH

    from creatio.pipeline import config

    monkeypatch.setenv("CREATIO_CONFIG_CACHE", "off")
    wrong = []
    for key, value in SIZES[study]:
        text = f"[{','.join(repr(v) for v in value)}]" if isinstance(value, list) else repr(value)
        overrides = [f"{key}={text}", *(f"{k}={v!r}" for k, v in WITH.get(key, {}).items())]
        try:
            config.resolve(study, overrides)
        except Exception as e:  # noqa: BLE001 - the corpus classifies every outcome
            why = _one_line_refusal(e)
            if why or not (e.key == key or e.key.startswith(f"{key}[")) or (
                    "more than" not in e.rule):
                wrong.append(f"{overrides}: {why or e}")
            continue
        wrong.append(f"{overrides}: accepted")
    assert wrong == []
