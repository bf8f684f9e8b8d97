"""Stability map of the fixed-step explicit schemes: located breaks against the slip-mode
linear limit, its scaling with mu and eps, the scheme ratio, and the config validation.

The EN-02 sphere (m = 1 kg, g = 9.81 m/s^2) sits in a cavity bottom where N stays at m g
(to 5e-7), so the slip relaxes at lambda = 3.5 mu g / eps and a scheme with real stability
bound x breaks at dt = x / lambda: 1.25 x the a-priori estimate, whose N carries a 1.25
margin. Runs are 10 s long (the map's break brackets are the same at 10, 30 and 120 s).
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
from scipy.integrate._ivp import dop853_coefficients

from creatio.dynamics.solvers import METHODS
from creatio.dynamics.solvers.tableaus import RK4_REAL_STABILITY
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve
from creatio.reports.stability_map import figure, method_colors
from creatio.studies import registry
from creatio.studies.stability_map import StabilityMapConfig, parts, run

G = 9.81
DURATION = 10.0


def real_stability_bound(method: str) -> float:
    """The registry's real stability interval of a method (computed from its tableau)."""
    return METHODS[method].stability_bound


def _negative_real_root(coeffs_ascending: list[float]) -> float:
    """Smallest x > 0 with |R(-x)| = 1 (R = 1 or R = -1), by numpy's companion-matrix roots."""
    found = []
    for side in (1.0, -1.0):
        c = np.array(coeffs_ascending, dtype=float)
        c[0] -= side
        z = np.roots(c[::-1])
        found += list(-z[(np.abs(z.imag) < 1e-9) & (z.real < -1e-9)].real)
    return float(min(found))


RK4_ROOT = _negative_real_root([1.0, 1.0, 1 / 2, 1 / 6, 1 / 24])
# Dormand-Prince 5(4): R(z) = sum_{k<=5} z^k / k! + z^6 / 600 (Hairer, Norsett, Wanner I).
DOPRI5_ROOT = _negative_real_root([1.0, 1.0, 1 / 2, 1 / 6, 1 / 24, 1 / 120, 1 / 600])


def _scipy_dop853_polynomial() -> list[float]:
    """R(z) = 1 + sum_k z^k b^T A^(k-1) 1 from scipy's own DOP853 tableau."""
    n = dop853_coefficients.N_STAGES
    a, b = dop853_coefficients.A[:n, :n], dop853_coefficients.B
    coeffs, v = [1.0], np.ones(n)
    for _ in range(n):
        coeffs.append(float(b @ v))
        v = a @ v
    return coeffs


DOP853_ROOT = _negative_real_root(_scipy_dop853_polynomial())


def _linear_limit(bound: float, mu: float, eps: float) -> float:
    return bound * eps / (3.5 * mu * G)


def _config(*overrides: str) -> StabilityMapConfig:
    """The stability map's config at the tests' duration, with overrides."""
    return resolve("stability_map", [f"study.duration={DURATION!r}", *overrides]).obj


#: A map small enough to run end to end in a few seconds.
TINY = ["study.duration=2.0", "study.axes.mu=[1.0]", "study.axes.eps=[0.04]",
        "study.methods=[rk4]", "study.duration_check.mu=[1.0]",
        "study.duration_check.duration=3.0"]


@pytest.fixture(scope="module")
def mu_map() -> xr.Dataset:
    return run(_config("study.axes.mu=[0.02,0.5,1.0]"), "mu")


@pytest.fixture(scope="module")
def eps_map() -> xr.Dataset:
    return run(_config("study.axes.eps=[0.0025,0.005]", "study.methods=[rk4]",
                       "study.validation=false"), "eps")


def _bracket(ds: xr.Dataset, method: str, value: float) -> tuple[float, float]:
    s = ds.sel({"method": method, "value": value})
    return float(s.largest_stable_dt), float(s.first_broken_dt)


def test_real_stability_bounds_match_numpy_roots() -> None:
    assert RK4_ROOT == pytest.approx(2.785293563405282, abs=1e-12)
    assert real_stability_bound("rk4") == pytest.approx(RK4_ROOT, rel=1e-12)
    assert RK4_REAL_STABILITY == pytest.approx(RK4_ROOT, rel=1e-12)
    assert real_stability_bound("dopri5") == pytest.approx(DOPRI5_ROOT, rel=1e-12)
    assert real_stability_bound("dop853") == pytest.approx(DOP853_ROOT, rel=1e-12)


@pytest.mark.parametrize("mu", [0.5, 1.0])
def test_rk4_break_brackets_linear_limit(mu_map: xr.Dataset, mu: float) -> None:
    good, broken = _bracket(mu_map, "rk4", mu)
    assert good <= _linear_limit(RK4_ROOT, mu, 0.01) <= broken
    s = mu_map.sel({"method": "rk4", "value": mu})
    assert 1.0 <= float(s.ratio) <= 1.35
    assert s.limited_by.item() == "stability"


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853"])
def test_break_scales_like_one_over_mu(mu_map: xr.Dataset, method: str) -> None:
    lo1, hi1 = _bracket(mu_map, method, 0.5)
    lo2, hi2 = _bracket(mu_map, method, 1.0)
    # the true break at mu = 0.5 lies in [lo1, hi1] and in 2 x [lo2, hi2]
    assert max(lo1, 2 * lo2) <= min(hi1, 2 * hi2)


def test_break_scales_like_eps(eps_map: xr.Dataset) -> None:
    lo1, hi1 = _bracket(eps_map, "rk4", 0.0025)
    lo2, hi2 = _bracket(eps_map, "rk4", 0.005)
    assert max(2 * lo1, lo2) <= min(2 * hi1, hi2)
    for eps in (0.0025, 0.005):
        good, broken = _bracket(eps_map, "rk4", eps)
        assert good <= _linear_limit(RK4_ROOT, 0.15, eps) <= broken


def test_dop853_over_rk4_break_is_bound_ratio(mu_map: xr.Dataset) -> None:
    lo_rk, hi_rk = _bracket(mu_map, "rk4", 1.0)
    lo_8, hi_8 = _bracket(mu_map, "dop853", 1.0)
    expected = DOP853_ROOT / RK4_ROOT
    assert lo_8 / hi_rk <= expected <= hi_8 / lo_rk
    # and each break sits on its own scheme's linear limit (6.39 for dop853, not 6.07)
    assert lo_8 <= _linear_limit(DOP853_ROOT, 1.0, 0.01) <= hi_8
    assert _linear_limit(6.0722, 1.0, 0.01) < lo_8
    lo_5, hi_5 = _bracket(mu_map, "dopri5", 1.0)
    assert lo_5 <= _linear_limit(DOPRI5_ROOT, 1.0, 0.01) <= hi_5


def test_small_mu_rk4_is_accuracy_limited(mu_map: xr.Dataset) -> None:
    s = mu_map.sel({"method": "rk4", "value": 0.02})
    assert s.limited_by.item() == "accuracy"
    assert float(s.first_broken_dt) < _linear_limit(RK4_ROOT, 0.02, 0.01)
    assert (mu_map.sel(value=1.0).limited_by == "stability").all()


def test_references_agree(mu_map: xr.Dataset) -> None:
    assert float(mu_map.reference_agreement_m.max()) < 1e-12


def test_map_agrees_with_validation(mu_map: xr.Dataset) -> None:
    assert bool(mu_map.validation_agrees.all())
    assert int(mu_map.accepted_broken.sum()) == 0
    assert bool((mu_map.validation_break_ratio > 1.0).all())
    stable = mu_map.sel({"method": "rk4"}).limited_by == "stability"
    ratio = mu_map.validation_good_ratio.where(stable, drop=True)
    assert ratio.size == 2
    assert bool(((ratio >= 1.0) & (ratio <= 1.35)).all())


@pytest.mark.parametrize("mu", [0.15, 1.0])
def test_validation_refuses_beyond_step_limit(mu: float) -> None:
    limit = resolve("en02", [f"sphere.mu={mu}", "solver.allow_unstable=true"]).obj.step_limit()
    assert limit == pytest.approx(_linear_limit(RK4_ROOT, mu, 0.01) / 1.25, rel=1e-6)

    def overrides(dt: float) -> list[str]:
        return [f"sphere.mu={mu}", f"solver.dt={dt!r}", f"solver.output_interval={dt!r}",
                f"study.duration={100 * dt!r}"]

    resolve("en02", overrides(0.95 * limit))
    with pytest.raises(ConfigError) as info:
        resolve("en02", overrides(1.05 * limit))
    assert info.value.key == "solver.dt"


def test_dataset_is_cf_annotated(mu_map: xr.Dataset, tmp_path) -> None:
    for name, var in mu_map.variables.items():
        assert var.attrs.get("long_name"), name
        assert "units" in var.attrs, name
    assert set(mu_map.limited_by.values.ravel()) <= {"stability", "accuracy", "none"}
    assert not math.isnan(float(mu_map.estimate_dt.min()))
    path = figure([mu_map], tmp_path / "map.png")
    assert path.stat().st_size > 10_000


def test_figure_takes_any_number_of_methods(mu_map: xr.Dataset, tmp_path) -> None:
    extra = [mu_map.isel(method=[i % 3]).assign_coords(method=[f"scheme{i}"])
             for i in range(9)]
    many = xr.concat([mu_map, *extra], dim="method", data_vars="minimal", coords="minimal",
                     compat="override")
    assert many.sizes["method"] == 12
    assert figure([many], tmp_path / "many.png").stat().st_size > 10_000
    for n in (3, 4, 10, 11, 25):
        colors = method_colors([f"m{i}" for i in range(n)])
        assert len({tuple(c) for c in colors.values()}) == n


def test_cli_lists_the_analysis(capsys) -> None:
    from creatio.cli import main

    assert main(["--help"]) == 0
    assert "stability_map" in capsys.readouterr().out


# ------------------------------------------------------------------------------ config
def test_resolve_validates_small_grids() -> None:
    r = resolve("stability_map", ["study.axes.mu=[0.5,1.0]", "study.axes.eps=[0.01]",
                                  "study.methods=[rk4,dop853]", "study.duration=5.0",
                                  "study.duration_check.mu=[]"])
    cfg = r.obj
    assert isinstance(cfg, StabilityMapConfig)
    assert cfg.study.axes == {"mu": [0.5, 1.0], "eps": [0.01]}
    assert cfg.study.methods == ["rk4", "dop853"]
    assert cfg.base.sphere.mu == 0.15 and cfg.base.sphere.eps == 0.01
    assert [p.name for p in parts(cfg)] == ["stability_map_mu", "stability_map_eps"]
    assert r.data["study"]["duration_check"]["duration"] == 120.0  # the base's full cycle
    default = resolve("stability_map").obj
    assert [p.args["axis"] for p in parts(default)] == ["mu", "eps", "duration"]
    entry = registry.get("stability_map")
    assert [p.rsplit("/", 1)[1] for p in entry.reports("data")] == [
        "stability_map.json", "stability_map.md", "stability_map.png"]


def test_module_imports_stay_light() -> None:
    code = ("import sys, creatio.studies.stability_map; "
            "print(sorted(m for m in ('xarray', 'numba', 'hydra', 'creatio.pipeline') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize(("override", "key"), [
    ("study.axes.mu=[0.5,-1.0]", "study.axes.mu[1]"),
    ("study.axes.eps=[0.0]", "study.axes.eps[0]"),
    ("study.methods=[rk4,radau5]", "study.methods[1]"),
    ("study.methods=[euler]", "study.methods[0]"),
    ("study.span=[2.0,0.3]", "study.span"),
    ("study.samples=1", "study.samples"),
    ("study.tolerance=0.0", "study.tolerance"),
    ("study.chatter=0.5", "study.chatter"),
    ("study.duration=10.05", "study.duration"),
    ("study.reference.method=rk4", "study.reference.method"),
    ("study.reference.method=dop853", "study.reference.method"),
    ("study.cross_check.rtol=-1.0", "study.cross_check.rtol"),
    ("study.duration_check.mu=[-0.1]", "study.duration_check.mu[0]"),
    ("+study.axes.b=[0.1]", "study.axes.b"),
    ("bases.en02.sphere.eps=-0.01", "bases.en02.sphere.eps"),
])
def test_invalid_settings_are_refused_by_key(override: str, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        resolve("stability_map", [override])
    assert info.value.key == key


def test_grid_changes_the_config_hash() -> None:
    default = resolve("stability_map")
    assert resolve("stability_map", ["study.axes.mu=[0.5,1.0]"]).sha256 != default.sha256
    assert resolve("stability_map", ["study.samples=5"]).sha256 != default.sha256
    assert resolve("stability_map", ["bases.en02.sphere.eps=0.02"]).sha256 != default.sha256
    assert resolve("stability_map", ["study.samples=9"]).sha256 == default.sha256


def test_run_resolved_end_to_end(tmp_path) -> None:
    from creatio.pipeline.run import run_resolved

    resolved = resolve("stability_map", TINY)
    root = run_resolved(resolved, data_dir=tmp_path)
    entry = resolved.entry
    datasets = entry.datasets(str(root), resolved.obj)
    assert [p.rsplit("/", 1)[1] for p in datasets] == [
        "stability_map_mu.nc", "stability_map_eps.nc", "stability_map_duration.nc"]
    for path in datasets:
        with xr.open_dataset(path) as ds:
            assert ds.attrs["config_sha256"] == resolved.sha256
            assert ds.attrs["study"] == "stability_map"
    reports = entry.reports(str(root))
    for path in reports:
        assert Path(path).is_file(), path
    report = json.loads(Path(reports[0]).read_text())
    assert report["config_sha256"] == resolved.sha256
    point = report["axes"]["mu"]["methods"]["rk4"]["points"][0]
    assert point["value"] == 1.0 and point["limited_by"] == "stability"
    assert point["largest_good_dt_s"] <= _linear_limit(RK4_ROOT, 1.0, 0.01)
    assert report["axes"]["mu"]["validation"]["agrees"] is True
    assert report["duration_check"]["mu"]["1.0"]["rk4"]["same"] is True
    md = Path(reports[1]).read_text()
    assert "## Along mu" in md and "## Along eps" in md and "## Shortened duration" in md
