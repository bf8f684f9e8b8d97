"""The ``control`` group (docs/model.md s.12.2) on the sphere studies: off by default and then
absent from the canonical config (every released config keeps its sha256), on with
``control=pd`` with gains from the design rule, refused settings in one line each."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from creatio.errors import ConfigError
from creatio.pipeline.config import applicable, resolve
from creatio.studies import en04

ROOT = Path(__file__).resolve().parents[2]


def test_prescribed_configs_keep_the_release_hashes() -> None:
    """With the group off, each released study's canonical YAML hashes as release 0.2.0
    recorded it (outputs are keyed by it), and the YAML never names the group."""
    manifest = json.loads((ROOT / "data/releases/0.2.0/MANIFEST.json").read_text())
    assert set(manifest["studies"]) >= {"ct02", "en01", "en02", "en02r"}
    for study, entry in manifest["studies"].items():
        resolved = resolve(study)
        assert resolved.sha256 == entry["config_sha256"], study
        assert "control" not in resolved.yaml
    # a study whose bases embed EN-02's config (EN-04) leaves the null group out there too
    assert "control: null" not in resolve("en04").yaml


def test_control_pd_builds_the_design_rule_controller() -> None:
    """control=pd: EN-04's default controller; K_theta = omega_c^2 / k_alpha and K_omega =
    2 zeta_c omega_c / k_alpha with k_alpha the rolling sphere's still-cavity frequency
    squared, computed here from its closed form (docs/model.md s.12.3)."""
    resolved = resolve("en02", ["control=pd"])
    c = resolved.obj.control
    assert (c.omega_max, c.delta_max_deg, c.omega_c, c.omega_n, c.zeta_c, c.zeta) == (
        2.0, 10.0, 3.0, 20.0, 1.0, 1.0)
    assert c.u_max is None and c.theta_goal_deg == -360.0 and c.arrival_tol_deg == 2.0
    assert "control:" in resolved.yaml and resolved.sha256 != resolve("en02").sha256
    cfg = resolved.obj
    g, sp = cfg.geometry, cfg.sphere
    k = 2.0 * math.pi * g.Kr / g.dR
    R_c = (0.5 * math.pi - 0.0 + 2.0 * math.pi * round((k * 0.43 - 0.5 * math.pi) /
                                                        (2.0 * math.pi))) / k
    kappa = g.A * g.Ka ** 2 / (g.R0 + R_c) ** 2
    k_alpha = sp.g * kappa / ((1.0 - sp.b * kappa) * 1.4)
    assert k_alpha == pytest.approx(99.90, abs=0.01)
    # the value EN-04's own design rule uses
    assert en04.closed_forms(cfg).roll_alpha ** 2 == pytest.approx(k_alpha, rel=1e-12)
    ctl = cfg.sphere_problem().model.control
    assert ctl.k_theta == pytest.approx(9.0 / k_alpha, rel=1e-12)
    assert ctl.k_omega == pytest.approx(6.0 / k_alpha, rel=1e-12)
    assert ctl.goal == pytest.approx(-2.0 * math.pi, rel=1e-15)
    assert ctl.alpha0 == pytest.approx(math.radians(30.0), rel=1e-15)
    assert ctl.delta_max == pytest.approx(math.radians(10.0), rel=1e-15)
    assert math.isinf(ctl.u_max)
    # every sphere study takes the group; the dt / refine partner is controlled too
    for study in ("en02r", "en02v"):
        assert resolve(study, ["control=pd"]).obj.sphere_problem().controlled
    assert cfg.sphere_problem(cfg.solver.dt / 2).controlled


@pytest.mark.parametrize("override, key, rule", [
    ("control.omega_c=-1", "control.omega_c", "> 0"),
    ("control.omega_n=0", "control.omega_n", "> 0"),
    ("control.omega_max=-2", "control.omega_max", "> 0"),
    ("control.zeta=-0.5", "control.zeta", ">= 0"),
    ("control.delta_max_deg=30", "control.delta_max_deg", "half a cavity"),
    ("control.delta_max_deg=-1", "control.delta_max_deg", "[0, 180 / Ka"),
    ("control.u_max=0", "control.u_max", "> 0"),
    ("control.u_max=-1", "control.u_max", "> 0"),
    ("control.theta_goal_deg=0", "control.theta_goal_deg", "nonzero"),
])
def test_refused_settings(override: str, key: str, rule: str) -> None:
    with pytest.raises(ConfigError) as e:
        resolve("en02", ["control=pd", override])
    assert e.value.key == key
    assert rule in str(e.value) and "\n" not in str(e.value)


def test_a_study_without_the_group_and_a_misspelled_form_are_refused() -> None:
    with pytest.raises(ConfigError, match="unknown key"):
        resolve("ct02", ["control=pd"])
    with pytest.raises(ConfigError, match="write control=pd"):
        resolve("en02", ["+control=pd"])
    # Snakemake's overrides go to the studies that have the key: the sphere studies only
    assert applicable("en02", ["control=pd"]) == ["control=pd"]
    assert applicable("ct02", ["control=pd"]) == []
    assert applicable("en02r", ["control=pd", "control.omega_n=40"]) == [
        "control=pd", "control.omega_n=40"]
    assert applicable("en01", ["control=pd", "control.omega_n=40"]) == []


def test_refusal_is_one_line_exit_2() -> None:
    for override in ("control.omega_c=-2", "control.delta_max_deg=30", "control.u_max=0"):
        proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en02",
                               "control=pd", override], capture_output=True, text=True,
                              timeout=120)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and override.split("=")[0] in lines[0]


def test_the_null_group_is_left_out_everywhere_a_config_is_keyed() -> None:
    """The canonical text of a scene whose bases embed a study config untyped (EN-04's scene)
    leaves the null group out too, and the config cache's rebuild (from_plain, then the check
    plain(obj) == data) accepts the data with the group left out and with it set."""
    from creatio.pipeline.config import from_plain, plain
    from creatio.scenes.config import resolve as resolve_scene
    from creatio.studies import registry

    assert "control: null" not in resolve_scene("en04").yaml
    for overrides in ([], ["control=pd"]):
        resolved = resolve("en02", overrides)
        obj = from_plain(registry.get("en02").schema, resolved.data)
        assert plain(obj) == resolved.data
        assert ("control" in resolved.data) == bool(overrides)
