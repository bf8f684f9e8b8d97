"""EN-06's rib study at small sizes (creatio.studies.en06_ribs, creatio.reports.en06_ribs)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from creatio.errors import ConfigError
from creatio.model import ribs
from creatio.pipeline.config import resolve
from creatio.reports.en06_ribs import ribs_section
from creatio.studies.en06_ribs import ribs_dataset

RELEASE = Path(__file__).resolve().parents[2] / "data" / "releases" / "0.2.0"


@pytest.mark.long
def test_rib_study_small() -> None:
    cfg = resolve("en06").obj
    ds = ribs_dataset(cfg.bases["en02"], {"en02": cfg.study.surfaces["en02"]},
                      counts=[18, 36], refused=[12, 13], errors_N=24, seeds=3)
    sec = ribs_section(ds)
    assert sec["refused"][0]["reason"].endswith("N must be > 2 Ka = 12")
    assert sec["refused"][1]["reason"] == ""
    case18, case36 = sec["cases"]
    assert case18["shape_error_rel"] == ribs.shape_error(18, 6)
    assert case18["largest_alias"]["n"] == -1
    assert case36["h0"] > case18["h0"]
    assert ds.transport_error_m.sel(surface="en02", N=36) \
        < ds.transport_error_m.sel(surface="en02", N=18) / 8
    assert sec["ideal"]["final_angle_deg"] == pytest.approx(-330.0, abs=1e-3)
    spec = [c["N"] for c in sec["cases"] if c["within_spec"]]
    assert sec["smallest_N_within_spec"] == (min(spec) if spec else None)
    assert sec["errors"]["seeds"] == 3
    assert 0.0 <= sec["errors"]["fraction_within_spec"] <= 1.0


def test_the_rib_keys_keep_every_config_hash() -> None:
    """Left out of the canonical text while null: EN-02's hash is the release's."""
    manifest = json.loads((RELEASE / "MANIFEST.json").read_text())
    res = resolve("en02")
    assert res.sha256 == manifest["studies"]["en02"]["config_sha256"]
    assert "rib" not in res.yaml


def test_a_rib_config_builds_the_rib_surface() -> None:
    exact = resolve("en02", ["geometry.ribs=24"]).obj.geometry.surface()
    assert exact.ribs == ribs.Ribs(24)
    drawn = resolve("en02", ["geometry.ribs=24", "geometry.rib_seed=4",
                             "geometry.rib_sigma_e=0.02"]).obj.geometry.surface()
    e, d = ribs.rib_errors(24, 0.02, math.radians(1.0), 4)
    assert drawn.ribs == ribs.Ribs(24, tuple(e), tuple(d))


@pytest.mark.parametrize(("overrides", "words"), [
    (["geometry.ribs=12"], "geometry.ribs=12: must be an integer > 2 Ka = 12"),
    (["geometry.ribs=0"], "geometry.ribs=0: must be an integer > 2 Ka = 12"),
    (["geometry.ribs=-24"], "geometry.ribs=-24: must be an integer > 2 Ka = 12"),
    (["geometry.ribs=nan"], "could not be converted to Integer"),
    (["geometry.ribs=2.5"], "could not be converted to Integer"),
    (["geometry.ribs=24", "geometry.rib_degree=3"], "geometry.rib_degree=3: must be 5"),
    (["geometry.ribs=24", "geometry.rib_sigma_e=-0.1"],
     "geometry.rib_sigma_e=-0.1: must be finite and >= 0"),
    (["geometry.ribs=24", "geometry.rib_sigma_e=nan"], "geometry.rib_sigma_e=nan: must be a"),
    (["geometry.ribs=24", "geometry.rib_sigma_d_deg=inf"],
     "geometry.rib_sigma_d_deg=inf: must be a finite number"),
    (["geometry.ribs=24", "geometry.rib_seed=-3"], "geometry.rib_seed=-3: must be an integer"),
    (["geometry.ribs=24", "geometry.rib_seed=abc"], "could not be converted to Integer"),
    (["geometry.rib_seed=3"], "geometry.rib_seed=3: needs geometry.ribs"),
])
def test_a_bad_rib_key_is_refused_in_one_line(overrides: list[str], words: str) -> None:
    with pytest.raises(ConfigError) as err:
        resolve("en02", overrides)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_ribs_are_refused_with_flight() -> None:
    with pytest.raises(ConfigError, match=r"geometry\.ribs=24: the run refuses it: ribs = 24"):
        resolve("en02f", ["geometry.ribs=24"])


@pytest.mark.long
def test_the_cli_refuses_a_bad_rib_count_in_one_line_and_writes_nothing(
        tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en02",
                           "geometry.ribs=12"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "geometry.ribs=12" in lines[0] and "2 Ka = 12" in lines[0]
    assert list(tmp_path.iterdir()) == []
