"""EN-07 (docs/aerospace.md): the scaled config against the factors, the similarity check (and
that it fails when eps is not scaled), the residual as a tilt in a run, the requirement
search's boundary confirmed by direct runs, the interfaces against the point-mass closed
form, and the refusal of bad platform and scale values in one line with exit code 2."""

from __future__ import annotations

import copy
import math
import subprocess
import sys
from functools import cache
from typing import Any

import numpy as np
import pytest

from creatio.errors import ConfigError
from creatio.model.similarity import pull_vector
from creatio.pipeline.config import resolve
from creatio.studies import en07
from creatio.studies.schema import vary


@cache
def config(*overrides: str) -> Any:
    """EN-07's config composed from conf/ by Hydra and validated."""
    return resolve("en07", list(overrides)).obj


def _short(cfg: Any, duration: float) -> Any:
    """The base at the similarity's tolerances, run for `duration` of its cycle."""
    sim = cfg.study.similarity
    return vary(cfg.bases["en02"], {"solver.method": sim.method, "solver.rtol": sim.rtol,
                                    "solver.atol": sim.atol, "study.duration": duration})


def test_scale_config_applies_the_factors() -> None:
    base = config().bases["en02"]
    c = en07.scale_config(base, 0.5, 2.0)
    assert (c.geometry.R0, c.geometry.dR, c.geometry.A) == (0.34, 0.86, 0.09)
    assert c.sphere.b == 0.06 and c.study.initial.R == 0.215
    assert c.sphere.g == pytest.approx(2 * 9.81, rel=1e-15)
    assert c.phases.T == pytest.approx(60.0, rel=1e-15)        # 120 s x sqrt(0.5 / 2)
    assert c.solver.dt == pytest.approx(0.001, rel=1e-15)
    assert c.sphere.eps == pytest.approx(0.01, rel=1e-15)      # x sqrt(0.5 x 2) = 1
    assert (c.sphere.m, c.sphere.mu, c.geometry.Ka) == (1.0, 0.15, 6)
    pd = en07.scale_control(config().study.control, 2.0)
    assert (pd.omega_max, pd.omega_c, pd.omega_n) == (4.0, 6.0, 40.0)
    assert pd.delta_max_deg == 10.0


@pytest.mark.parametrize(("s", "a"), [(0.5, 2.0), (2.0, 0.5), (0.3, 5.0)])
def test_similarity_scaled_run_equals_the_base_in_scaled_units(s: float, a: float) -> None:
    """Centre at t' over s is the base's centre at t, within rtol x max |X| (both dop853 at
    rtol 1e-10); the pull of the scaled run is the base confinement P = m a with g = 0."""
    cfg = config()
    base = _short(cfg, 20.0)
    ref = en07._base_pull_dataset(base)
    scaled = en07._base_pull_dataset(en07.scale_config(base, s, a))
    X0 = ref["centre"].values
    assert scaled.sizes["time"] == ref.sizes["time"] == 201
    err = np.max(np.abs(scaled["centre"].values / s - X0))
    assert err <= cfg.study.similarity.rtol * np.max(np.abs(X0))
    assert np.ptp(X0[:, 0]) > 0.05  # the sphere moved: the check compares a real motion


def test_similarity_fails_when_eps_is_not_scaled() -> None:
    """The check has teeth: the same scaled run with eps left at the base's value is off by
    two orders of magnitude more than the bound."""
    cfg = config()
    base = _short(cfg, 20.0)
    ref = en07._base_pull_dataset(base)
    scaled = en07.scale_config(base, 0.5, 8.0)     # velocity factor 2
    wrong = vary(scaled, {"sphere.eps": base.sphere.eps})
    bad = en07._base_pull_dataset(wrong)
    err = np.max(np.abs(bad["centre"].values / 0.5 - ref["centre"].values))
    assert err > 100 * cfg.study.similarity.rtol * np.max(np.abs(ref["centre"].values))


def test_residual_along_x_runs_as_the_tilt() -> None:
    """A pull g cos(beta) along -z plus a residual g sin(beta) along x is EN-06's tilt by
    beta: the two runs agree to rounding."""
    beta = math.radians(12.0)
    base = vary(config().bases["en02"], {"study.duration": 10.0})
    tilt = vary(base, {"sphere.beta_deg": 12.0})
    g, b, p = pull_vector(9.81 * math.cos(beta), 9.81 * math.sin(beta), (1.0, 0.0, 0.0))
    composed = vary(base, {"sphere.g": g, "sphere.beta_deg": math.degrees(b),
                           "sphere.psi_deg": math.degrees(p)})
    a, _ = en07.transport(tilt)
    c, _ = en07.transport(composed)
    assert np.max(np.abs(a["centre"].values - c["centre"].values)) <= 1e-12
    assert np.max(np.abs(a["centre"].values - en07.transport(base)[0]["centre"].values)) > 1e-3


def test_requirement_boundary_is_confirmed_by_direct_runs() -> None:
    """Drop tower, quintic: the search's inside point carries, its outside point does not,
    each run again here; the scale lies within the bracket and the search range."""
    cfg = config("study.requirements.rel_tol=0.05")
    p = cfg.study.platforms["drop_tower"]
    d = en07.search(cfg, p, "quintic")
    assert d.feasible and d.inside is not None and d.outside is not None
    T = en07.budget(cfg, p)
    assert T == pytest.approx(4.7 / 1.2, rel=1e-15)
    residual = (p.residual_g, p.unit_direction())
    inside, _ = en07.transport(en07.transport_config(cfg, "quintic", *d.inside, T, residual))
    outside, _ = en07.transport(en07.transport_config(cfg, "quintic", *d.outside, T,
                                                      residual))
    assert en07.carries(inside) and not en07.carries(outside)
    ratio = max(d.inside[0], d.outside[0]) / min(d.inside[0], d.outside[0])
    assert 1.0 < ratio <= 1.05
    assert 0.1 <= d.scale < 1.0 and d.pull_g == 3.0
    assert d.binding == "window+preload_max"


@pytest.mark.long
def test_yaw_tends_to_the_point_mass_form_and_falls_as_one_over_inertia() -> None:
    """The host's yaw excursion over one transport: within 0.5 % of m rho^2 / (I_s + m rho^2)
    x the relative turn, closer for a slower transport (smaller radial excursion); 1 / I_s
    from 100 to 1000 kg m^2; H_z conserved to rounding."""
    cfg = config()
    rows = {}
    for T in (60.0, 240.0):
        ds = en07.interface_dataset(cfg, 10.0, T=T)
        rows[T] = en07.interface_row(ds, 10.0, 1.0)
    err = {T: abs(r["yaw_excursion_deg"] / abs(r["point_mass_yaw_deg"]) - 1.0)
           for T, r in rows.items()}
    assert rows[240.0]["radial_excursion_m"] < rows[60.0]["radial_excursion_m"]
    assert err[240.0] < err[60.0] < 5e-3
    big = {i: en07.interface_row(en07.interface_dataset(cfg, i, T=60.0), i, 1.0)
           for i in (100.0, 1000.0)}
    rho2 = big[100.0]["initial_radius_m"] ** 2
    assert big[100.0]["yaw_final_deg"] / big[1000.0]["yaw_final_deg"] == pytest.approx(
        (1000.0 + rho2) / (100.0 + rho2), rel=1e-2)
    for r in big.values():
        assert r["H_z_drift"] <= 1e-12 * max(1.0, r["stored_momentum_N_m_s"])


#: Bad values: (dotted key, value); dict keys (a platform's name) are path parts too.
BAD = [
    ("study.platforms.drop_tower.window_s", -1.0),
    ("study.platforms.parabolic_flight.residual_g", 1.5),
    ("study.platforms.space_station.residual_direction", [0.0, 0.0, 0.0]),
    ("study.platforms.sounding_rocket.residual_direction", [0.0, 0.0, 1.0]),
    ("study.platforms.drop_tower.preload_max_g", 0.0),
    ("study.similarity.scales", [0.5, 0.0]),
    ("study.similarity.pulls_g", [2.0]),
    ("study.requirements.scale_max", 0.05),
    ("study.requirements.scale_min", 1e-9),
    ("study.interfaces.scale", 5000.0),
    ("study.requirements.margin", 0.5),
]


@pytest.mark.parametrize(("key", "value"), BAD)
def test_bad_platform_and_scale_values_are_refused(key: str, value: Any) -> None:
    """Each bad value is refused by the study's rules, naming its key, in one line."""
    cfg = copy.deepcopy(config())
    *path, name = key.split(".")
    node: Any = cfg
    for part in path:
        node = node[part] if isinstance(node, dict) else getattr(node, part)
    setattr(node, name, value)
    with pytest.raises(ConfigError) as e:
        cfg.check()
    assert e.value.key == (f"{key}[1]" if key == "study.similarity.scales" else key)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(("override", "key"), [
    ("study.platforms.drop_tower.window_s=-1", "study.platforms.drop_tower.window_s"),
    ("study.requirements.scale_max=0.05", "study.requirements.scale_max"),
])
def test_bad_overrides_are_refused_at_composition(override: str, key: str) -> None:
    """The same rules on the path a user takes: Hydra's composition, then validation."""
    with pytest.raises(ConfigError) as e:
        resolve("en07", [override])
    assert e.value.key == key


@pytest.mark.long
def test_bad_value_exits_2_in_one_line_and_writes_nothing(tmp_path: Any) -> None:
    out = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en07",
                          "study.platforms.drop_tower.window_s=-1"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "study.platforms.drop_tower.window_s=-1.0" in lines[0] and "> 0 s" in lines[0]
    assert not any(tmp_path.iterdir())


@pytest.mark.long
def test_peak_strain_is_scale_free() -> None:
    """EN-06's membrane strain maximum (h = 0) over the cycle: the same at s = 0.5 and 1 (the
    strain of a uniformly scaled surface is unchanged), within the maximum's rtol."""
    cfg = config("study.strain.n_alpha=48", "study.strain.n_R=9", "study.strain.n_t=25")
    one, half = en07.strain_maximum(cfg, 1.0), en07.strain_maximum(cfg, 0.5)
    assert half.value == pytest.approx(one.value, rel=1e-6)
    assert half.R == pytest.approx(0.5 * one.R, rel=1e-6, abs=1e-9)
    assert 0.1 < one.value < 3.0
