"""Fixtures of the scene tests: the three.js bundle, the scenes built once into a temporary
directory (datasets and pages, no media), and Chromium where it is installed."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from chromium import executable

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def library(tmp_path_factory) -> Path:
    """The pages' three.js bundle: the workflow's if built, else built here (needs npm)."""
    built = REPO / "data" / "scenes" / "lib" / "three.min.js"
    if built.is_file():
        return built
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.skip("no three.js bundle and no Node.js/npm to build one "
                    "(snakemake data/scenes/lib/three.min.js)")
    from creatio.scenes.assets import build_library

    return build_library(tmp_path_factory.mktemp("lib") / "three.min.js")


@pytest.fixture(scope="session")
def scenes(tmp_path_factory, library) -> dict[str, Path]:
    """Every registered scene's scene.nc and index.html, default configs (the explorable
    ones with their default families), computed here (no study dataset reused); not the
    scenes that draw a study's dataset (test_scene_en04.py builds EN-04's from a small one)."""
    from creatio.scenes import registry
    from creatio.scenes.config import resolve
    from creatio.scenes.run import write_page, write_scene_dataset

    root = tmp_path_factory.mktemp("scenes")
    out = {}
    for scene in (s.id for s in registry.SCENES.values() if s.reads is None):
        d = root / scene
        write_scene_dataset(resolve(scene), d / "scene.nc", store=root / "members")
        write_page(d / "scene.nc", d / "index.html", library)
        out[scene] = d
    return out


@pytest.fixture(scope="session")
def need_chromium() -> str:
    """The Chromium binary; the test skips where there is none (CI installs Debian's)."""
    exe = executable()
    if exe is None:
        pytest.skip("chromium is not installed (apt-get install -y chromium)")
    return exe
