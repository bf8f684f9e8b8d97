"""Gravity as a vector: the membrane's mounting tilt (docs/model.md s.4, "Gravity as a vector").

A level membrane (no tilt, or beta = 0) must reproduce the release bit for bit; under a tilt
the sphere obeys the tilted gravity exactly where the answer is known in closed form (a
frictionless sphere on a flat membrane), and the energy identity with V = -m g . X closes
at the scheme's truncation level, falling at fourth order with dt (RK4).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.dynamics import simulate
from creatio.errors import ConfigError
from creatio.model.sphere import normal_reaction, normal_reaction_tilted, tilted_gravity
from creatio.pipeline.config import resolve
from creatio.studies import sphere as en02

RELEASE = Path(__file__).resolve().parents[2] / "data" / "releases" / "0.2.0"


def test_tilted_gravity_has_magnitude_g_and_is_minus_z_when_level() -> None:
    """|g_vec| = g toward azimuth psi, dipping by beta; at beta = 0 exactly (0, 0, -g)."""
    gx, gy, gz = tilted_gravity(9.81, math.radians(2.0), math.radians(30.0))
    assert math.hypot(gx, gy, gz) == pytest.approx(9.81, rel=1e-15)
    assert math.degrees(math.atan2(gy, gx)) == pytest.approx(30.0, rel=1e-13)
    assert math.degrees(math.atan2(math.hypot(gx, gy), -gz)) == pytest.approx(2.0, rel=1e-13)
    assert tilted_gravity(9.81, 0.0, 1.0) == (0.0, 0.0, -9.81)
    args = (0.3, -0.2, 0.93, 0.4, -0.7, 1.1)
    assert normal_reaction_tilted(2.0, 0.0, 0.0, 9.81, *args) == normal_reaction(2.0, 9.81, *args)


def test_a_level_config_keeps_its_text_and_hash() -> None:
    """The new keys are left out of the canonical text while null: the default config's
    sha256 is still the one the release recorded (so every output keeps its address)."""
    res = resolve("en02")
    manifest = json.loads((RELEASE / "MANIFEST.json").read_text())
    assert res.sha256 == manifest["studies"]["en02"]["config_sha256"]
    assert "beta_deg" not in res.yaml and "psi_deg" not in res.yaml


@pytest.mark.parametrize("overrides", [[], ["sphere.beta_deg=0", "sphere.psi_deg=30"]])
def test_a_level_run_is_the_release_bit_for_bit(overrides: list[str]) -> None:
    """EN-02 at dt = 2 ms, level (keys absent, or beta = 0 with an azimuth), equals the
    committed release dataset in every variable, exactly."""
    ref = xr.open_dataset(RELEASE / "studies" / "en02" / "en02_dt0.002.nc")
    ds = en02.run(resolve("en02", overrides).obj, 0.002)
    assert sorted(ds.data_vars) == sorted(ref.data_vars)
    for name in ref.data_vars:
        np.testing.assert_array_equal(ds[name].values, ref[name].values, err_msg=name)
    for name in ("max_energy_residual", "min_normal_reaction", "max_slip_speed"):
        assert ds.attrs[name] == ref.attrs[name]
    assert "tilt_beta_deg" not in ds.attrs


@pytest.mark.parametrize(("beta_deg", "psi_deg"), [(5.0, 120.0), (20.0, -75.0)])
def test_a_frictionless_sphere_slides_down_a_tilted_flat_membrane(beta_deg: float,
                                                                  psi_deg: float) -> None:
    """On a flat still membrane (A = 0) without friction the centre moves by
    g sin(beta) t^2 / 2 toward psi, and N = m g cos(beta), whatever the start's angle (to
    RK4's truncation in the polar (R, alpha): about 1e-12 m at 2 ms, 4e-15 m at 0.5 ms)."""
    cfg = resolve("en02", ["geometry.A=0", "sphere.mu=0", f"sphere.beta_deg={beta_deg}",
                           f"sphere.psi_deg={psi_deg}", "study.duration=0.3",
                           "solver.output_interval=0.05"]).obj
    res = simulate(cfg.sphere_problem(0.0005))
    assert res.counts.status == "ok" and res.histories.t[-1] == pytest.approx(0.3)
    beta, psi = math.radians(beta_deg), math.radians(psi_deg)
    slide = 0.5 * 9.81 * math.sin(beta) * res.histories.t[:, None] ** 2
    expected = slide * np.array([math.cos(psi), math.sin(psi), 0.0])
    np.testing.assert_allclose(res.histories.X - res.histories.X[0], expected, rtol=0.0, atol=1e-13)
    np.testing.assert_allclose(res.histories.N, 9.81 * math.cos(beta), rtol=1e-13)


def test_the_energy_residual_falls_at_fourth_order_under_tilt() -> None:
    """beta = 2 deg toward psi = 30 deg, a short cycle (T = 8 s), RK4 at dt, dt/2, dt/4:
    E - E0 - W_surface + D_friction with V = -m g . X stays at truncation level and its
    maximum falls as dt^4 (a potential missing the horizontal part would not converge)."""
    cfg = resolve("en02", ["sphere.beta_deg=2", "sphere.psi_deg=30", "phases.T=8"]).obj
    residuals = []
    for dt in (0.002, 0.001, 0.0005):
        ds = en02.run(cfg, dt)
        assert ds.attrs["status"] == "ok" and ds.attrs["tilt_beta_deg"] == pytest.approx(2.0)
        residuals.append(float(ds.attrs["max_energy_residual"]))
        # the tilt is felt: N sits near m g cos(beta), below the level m g
        assert ds.attrs["min_normal_reaction"] < 9.81 * math.cos(math.radians(1.0))
    orders = np.log2(np.array(residuals[:-1]) / np.array(residuals[1:]))
    assert residuals[-1] < 1e-10
    assert all(3.5 < p < 5.0 for p in orders), (residuals, orders)
    assert abs(orders[-1] - 4.0) < 0.5, (residuals, orders)


@pytest.mark.parametrize(("override", "words"), [
    ("sphere.beta_deg=-1", "sphere.beta_deg=-1.0: must lie in [0, 90)"),
    ("sphere.beta_deg=90", "sphere.beta_deg=90.0: must lie in [0, 90)"),
    ("sphere.beta_deg=nan", "sphere.beta_deg=nan: must be a finite number"),
    ("sphere.beta_deg=inf", "sphere.beta_deg=inf: must be a finite number"),
    ("sphere.beta_deg=abc", "could not be converted to Float"),
    ("sphere.psi_deg=nan", "sphere.psi_deg=nan: must be a finite number"),
    ("sphere.psi_deg=-inf", "sphere.psi_deg=-inf: must be a finite number"),
])
def test_a_bad_tilt_is_refused_naming_key_value_and_rule(override: str, words: str) -> None:
    """Each bad value of the new keys is a ConfigError naming the key, the value, the rule."""
    with pytest.raises(ConfigError) as err:
        resolve("en02", [override])
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("study", ["en02g", "en03", "en02f"])
def test_a_tilt_is_refused_where_the_model_does_not_carry_it(study: str) -> None:
    """An equilibrium start, a free structure and flight keep gravity along -z: a tilt
    there is refused by its key, never run with gravity silently level."""
    with pytest.raises(ConfigError, match=r"sphere\.beta_deg=2\.0: the run refuses it"):
        resolve(study, ["sphere.beta_deg=2"])
    resolve(study, ["sphere.beta_deg=0"])


@pytest.mark.long
@pytest.mark.parametrize("override", ["sphere.beta_deg=-0.5", "sphere.beta_deg=95",
                                      "sphere.psi_deg=nan", "sphere.beta_deg=[1,2]"])
def test_the_cli_refuses_a_bad_tilt_in_one_line_and_writes_nothing(tmp_path: Path,
                                                                   override: str) -> None:
    """creatio run with a bad tilt: exit 2, one line naming the key, nothing written."""
    proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en02", override],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert override.split("=")[0] in lines[0] and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []
