"""scripts/bench_scene_family.py runs (its other scripts' smoke tests are in
tests/scripts/test_scripts.py): three switches of the family slider of a page built here."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_bench_scene_family_three_switches(need_chromium, scenes) -> None:
    page = scenes["en02"] / "index.html"
    proc = subprocess.run([sys.executable, "scripts/bench_scene_family.py", str(page),
                           "--switches", "3"], cwd=REPO, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "3 switches" in proc.stdout and "ERRORS" not in proc.stdout
