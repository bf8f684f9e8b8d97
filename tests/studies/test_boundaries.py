"""Physics boundaries of EN-02: located boundaries against independent predictions, and the
analysis as a configured study (validation, config hash, one end-to-end run)."""

from __future__ import annotations

import json
import logging
import math
import sys

import numpy as np
import pytest
import xarray as xr

from creatio.dynamics import simulate
from creatio.dynamics.sphere import evaluate as core_evaluate
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve
from creatio.studies import boundaries as bd
from creatio.studies.registry import Part
from creatio.studies.schema import vary


@pytest.fixture(scope="module")
def cfg() -> bd.BoundariesConfig:
    """The default boundaries config (its base is the default EN-02 config)."""
    return resolve("boundaries").obj


@pytest.fixture(scope="module")
def en02():
    """The default EN-02 config object."""
    return resolve("en02").obj


def _explore(cfg: bd.BoundariesConfig, axis: str, values: list[float],
             rtol: float | None = None) -> xr.Dataset:
    """One axis on its own grid (and bisection tolerance), as a validated variation."""
    changes: dict = {f"study.axes.{axis}.grid": values}
    if rtol is not None:
        changes["study.rtol"] = rtol
    return bd.explore(vary(cfg, changes), axis)


@pytest.fixture(scope="module")
def b_axis(cfg) -> xr.Dataset:
    return _explore(cfg, "b", [0.12, 0.18, 0.2, 0.45])


@pytest.fixture(scope="module")
def a_axis(cfg) -> xr.Dataset:
    return _explore(cfg, "A", [0.18, 0.28, 0.3, 0.68], rtol=1e-2)


@pytest.fixture(scope="module")
def t_axis(cfg) -> xr.Dataset:
    return _explore(cfg, "T", [120.0, 7.5, 6.5, 6.0, 4.0], rtol=1e-2)


@pytest.fixture(scope="module")
def mu_axis(cfg) -> xr.Dataset:
    return _explore(cfg, "mu", [0.15, 0.3, 0.35, 1.0], rtol=1e-2)


@pytest.fixture(scope="module")
def gamma_axis(cfg) -> xr.Dataset:
    return _explore(cfg, "gamma", [0.0, 20.0, 25.0, 85.0])


@pytest.fixture(scope="module")
def every_axis(b_axis, a_axis, t_axis, mu_axis, gamma_axis) -> list[xr.Dataset]:
    return [b_axis, a_axis, t_axis, mu_axis, gamma_axis]


def _bottom_curvature(cfg) -> float:
    """Larger principal curvature of the flat (gamma = 0) cavity bottom, W = -A there:
    along R it is A k^2, along alpha A Ka^2 / rho^2 with rho = R0 + R_init."""
    g = cfg.geometry
    k = 2.0 * math.pi * g.Kr / g.dR
    rho = g.R0 + cfg.study.initial.R
    return g.A * max(k * k, g.Ka**2 / rho**2)


def _bracket(ds: xr.Dataset) -> tuple[float, float]:
    lo, hi = sorted((float(ds["boundary_ok"]), float(ds["boundary_fail"])))
    return lo, hi


# ------------------------------------------------------------------------------ config
def test_default_config_is_en02_and_the_module_constants(cfg, en02):
    assert cfg.base == en02
    s = cfg.study
    assert s.explore == ["T", "A", "b", "gamma", "mu"]
    assert (s.rtol, s.stable_fraction) == (1e-3, 0.8)
    assert s.nice_mantissas == [5.0, 4.0, 2.5, 2.0, 1.0]
    assert s.axes.T.grid[0] == 120.0 and s.axes.T.quantize_to_dt and s.axes.T.log
    assert s.axes.mu.stable_rerun and not s.axes.b.stable_rerun
    assert bd.parts(cfg) == [Part(f"boundaries_{a}", {"axis": a}) for a in bd.AXES]


@pytest.mark.parametrize(("overrides", "key"), [
    (["study.axes.b.grid=[0.12,0.2,0.15]"], "study.axes.b.grid[2]"),
    (["study.axes.mu.grid=[0.15]"], "study.axes.mu.grid"),
    (["study.axes.A.grid=[0.7,0.8]"], "study.axes.A.grid[0]"),
    (["study.axes.gamma.grid=[0.0,nan]"], "study.axes.gamma.grid[1]"),
    (["study.explore=[b,c]"], "study.explore[1]"),
    (["study.rtol=0"], "study.rtol"),
    (["study.stable_fraction=1.5"], "study.stable_fraction"),
    (["study.nice_mantissas=[5.0,10.0]"], "study.nice_mantissas[1]"),
    (["bases.en02.geometry.A=0.9"], "bases.en02.geometry.A"),
])
def test_resolve_refuses_a_bad_setting_naming_its_key(overrides, key):
    with pytest.raises(ConfigError) as info:
        resolve("boundaries", overrides)
    assert info.value.key == key


def test_vary_refuses_like_resolve(cfg):
    with pytest.raises(ConfigError) as info:
        vary(cfg, {"study.axes.b.grid": [0.12, 0.2, 0.15]})
    assert info.value.key == "study.axes.b.grid[2]"


def test_changing_a_grid_changes_the_config_hash():
    default = resolve("boundaries")
    grid = resolve("boundaries", ["study.axes.b.grid=[0.12,0.2]"])
    rtol = resolve("boundaries", ["study.rtol=0.01"])
    base = resolve("boundaries", ["bases.en02.sphere.mu=0.2"])
    assert grid.obj.study.axes.b.grid == [0.12, 0.2]
    assert len({default.sha256, grid.sha256, rtol.sha256, base.sha256}) == 4


# ------------------------------------------------------------------------------ physics
def test_default_run_b_kappa_is_the_cavity_bottom_curvature(en02):
    # The sphere starts at rest at the cavity bottom, the curvature maximum of the surface.
    res = simulate(en02.sphere_problem().replace(energy=False))
    expected = en02.sphere.b * _bottom_curvature(en02)
    assert res.extrema.max_b_kappa == pytest.approx(expected, rel=1e-12)
    assert bd.bottom_b_kappa(en02) == pytest.approx(expected, rel=1e-12)


def test_inclined_bottom_curvature_matches_the_integrator():
    # On a cone the alpha curvature gains rho sin(gamma): compare with the core's own
    # principal curvature at the start state.
    cfg = resolve("en02", ["phases.gamma.phi0=10", "phases.gamma.unit=deg"]).obj
    p = cfg.sphere_problem()
    _, _, _, bk = core_evaluate(p.parameter_vector(), p.law_matrix(),
                                p.initial_state(True, True), 0.0)
    assert bk == pytest.approx(bd.bottom_b_kappa(cfg), rel=1e-12)
    assert bd.bottom_b_kappa(cfg) != pytest.approx(bd.bottom_b_kappa(resolve("en02").obj))


def test_b_boundary_is_where_b_kappa_reaches_one(b_axis, en02, cfg):
    b_star = 1.0 / _bottom_curvature(en02)  # b kappa = 1
    lo, hi = _bracket(b_axis)
    assert b_axis["boundary_status"].item() == "offset_singular"
    assert lo <= b_star <= hi
    assert hi - lo <= cfg.study.rtol * hi
    assert float(b_axis["analytic_boundary"]) == pytest.approx(b_star, rel=1e-12)
    # beyond b = R_init the envelope already crosses the inner edge at t = 0
    assert b_axis["status"].sel(value=0.45).item() == "edge_crossed"


def test_a_boundary_and_refusal_at_r0(a_axis, en02):
    a_star = 1.0 / (en02.sphere.b * _bottom_curvature(en02) / en02.geometry.A)
    lo, hi = _bracket(a_axis)
    assert a_axis["boundary_status"].item() == "offset_singular"
    assert lo <= a_star <= hi
    refused = a_axis.sel(value=0.68)
    assert refused["status"].item() == "refused"
    assert refused["run_status"].item() == "not_run"
    assert "geometry.A" in refused["message"].item() and "R0" in refused["message"].item()
    assert np.isnan(refused["min_N"].item())


def test_t_axis_failures(t_axis, en02):
    ds = t_axis
    status = ds["status"].values.astype(str)
    failing = status != "ok"
    assert failing.any() and (ds["stop_time"].values[failing] < ds["duration"].values[failing]
                              ).all()
    assert (ds["min_N"].values[~failing] > 0.0).all()
    lost = status == "contact_lost"
    assert lost.any() and (ds["min_N"].values[lost] <= 0.0).all()
    assert (ds["min_N"].values[~lost] > 0.0).all()
    assert ds["left_cavity"].sel(value=120.0).item() == 0
    # duration follows T (the axis varies both)
    np.testing.assert_allclose(ds["duration"].values, ds["value"].values)
    # without a quasi-static hold at peak speed the sphere cannot stay in the cavity, so the
    # located boundary cannot lie below that estimate
    assert float(ds["boundary_fail"]) >= float(ds["analytic_boundary"])


def test_contact_lost_stops_where_n_crosses_zero(cfg):
    point = bd.evaluate(cfg, "T", 6.0)
    res = point.result
    assert point.status == res.counts.status == "contact_lost"
    assert res.histories.N[-1] <= 0.0 < res.histories.N[-2]
    assert res.histories.t[-1] == pytest.approx(res.counts.stop_time)


def test_mu_refusal_threshold_is_the_step_limit(mu_axis, cfg):
    ds = mu_axis
    nominal = 0.002
    for mu in ds["value"].values.tolist():
        en02 = resolve("en02", [f"sphere.mu={mu!r}", "solver.allow_unstable=true"]).obj
        limit = en02.step_limit()
        row = ds.sel(value=mu)
        assert float(row["step_limit"]) == limit
        assert (row["status"].item() == "refused_unstable") == (limit < nominal)
        assert row["run_status"].item() == "ok"
        # accepted values record the nominal run, refused ones a rerun at 0.8 limit or less
        cap = limit if row["status"].item() == "ok" else cfg.study.stable_fraction * limit
        assert float(row["dt"]) <= min(nominal, cap)
        assert round(0.1 / float(row["dt"])) * float(row["dt"]) == pytest.approx(0.1)
    # the limit scales as 1 / mu, so dt = 0.002 is refused from mu0 limit(mu0) / 0.002 on
    mu_star = 0.15 * float(ds["step_limit"].sel(value=0.15)) / nominal
    lo, hi = _bracket(ds)
    assert lo <= mu_star <= hi
    assert float(ds["analytic_boundary"]) == pytest.approx(mu_star, rel=1e-9)
    assert ds["physics_boundary_status"].item() == "none"


def test_gamma_boundary_above_the_energy_barrier(gamma_axis):
    # Released at rest, the rolling sphere escapes once it can clear the inner edge with its
    # start energy; friction only dissipates (the pattern moves < 1e-5 rad in that second),
    # so the run needs at least that inclination, and little more.
    ds = gamma_axis
    analytic = float(ds["analytic_boundary"])
    lo, hi = _bracket(ds)
    assert ds["boundary_status"].item() == "edge_crossed"
    assert analytic <= hi
    assert hi - analytic <= 0.01 * analytic
    assert ds["status"].sel(value=85.0).item() == "offset_singular"
    assert float(ds["stop_time"].sel(value=85.0)) == 0.0


def test_every_run_is_finite_and_clean(every_axis):
    for ds in every_axis:
        ran = ds["run_status"].values.astype(str) != "not_run"
        assert (ds["histories_finite"].values[ran] == 1).all()
        assert (ds["histories_finite"].values[~ran] == -1).all()
        assert set(ds["status"].values.astype(str)) <= set(bd.STATUSES)
        assert set(ds["run_status"].values.astype(str)) <= set(bd.RUN_STATUSES)
        assert ds.attrs["anomalies"] == ""
        for name, var in ds.variables.items():
            assert {"long_name", "units"} <= set(var.attrs), name


def test_stable_dt_choice(cfg):
    s = cfg.study
    rule = (s.stable_fraction, s.nice_mantissas)
    assert bd.stable_dt(6.489689e-05, 0.002, 0.1, 120.0, *rule) == 5e-05
    assert bd.stable_dt(0.0043, 0.002, 0.1, 120.0, *rule) == 0.002
    assert bd.stable_dt(0.00125, 0.002, 0.1, 120.0, *rule) == 0.001
    assert bd.stable_dt(0.0043, 0.002, 0.1, 6.853, *rule) == 1e-3


# ------------------------------------------------------------------------------ end to end
def test_run_resolved_writes_the_datasets_and_the_report(tmp_path, caplog):
    from creatio.pipeline.run import run_resolved

    resolved = resolve("boundaries", ["study.explore=[b]", "study.axes.b.grid=[0.12,0.2]"])
    with caplog.at_level(logging.INFO, logger="creatio"):
        root = run_resolved(resolved, data_dir=tmp_path)
    assert "axis b: boundary" in caplog.text
    assert root == tmp_path / "runs" / resolved.key
    ds = xr.load_dataset(root / "benchmarks" / "boundaries" / "boundaries_b.nc")
    assert ds.attrs["config_sha256"] == resolved.sha256
    assert ds["boundary_status"].item() == "offset_singular"
    reports = {s: root / "benchmarks" / f"boundaries{s}" for s in (".json", ".md", ".png")}
    assert sorted(p.name for p in (root / "benchmarks").iterdir() if p.is_file()) == sorted(
        p.name for p in reports.values())
    assert reports[".png"].stat().st_size > 0
    summary = json.loads(reports[".json"].read_text())
    assert summary["config_sha256"] == resolved.sha256
    axis = summary["axes"]["b"]
    assert axis["status"] == "offset_singular"
    assert axis["bracket"][0] <= axis["boundary"] <= axis["bracket"][1]
    assert axis["analytic"]["value"] == pytest.approx(float(ds["analytic_boundary"]))
    assert axis["analytic"]["basis"].startswith("offset_singular where")
    table = reports[".md"].read_text()
    assert "| b | `sphere.b` | 0.190" in table and "offset_singular" in table


def test_cli_help_lists_the_analysis_config(monkeypatch):
    from creatio import cli

    monkeypatch.setattr(sys, "argv", list(sys.argv))
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["run", "analysis=boundaries", "--help"])
    assert exit_info.value.code == 0
