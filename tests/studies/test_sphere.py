"""EN-02 / EN-02R through the study layer and reports: published figures, refusals, statuses."""

from __future__ import annotations

import math

import pytest

from creatio.dynamics import UnstableStepError, check_stable
from creatio.errors import ConfigError
from creatio.pipeline.config import resolve
from creatio.pipeline.run import run_study
from creatio.reports.sphere import dynamic_summary
from creatio.studies import published


@pytest.fixture(scope="module")
def en02():
    """EN-02 at the configured dt and dt / 2, summarised as the report does."""
    resolved = resolve("en02")
    runs = [run_study(resolved, dt=dt) for dt in resolved.obj.solver.timesteps()]
    return runs, dynamic_summary(runs)


@pytest.fixture(scope="module")
def en02r():
    """EN-02R at the configured dt and dt / 2."""
    resolved = resolve("en02r")
    runs = [run_study(resolved, dt=dt) for dt in resolved.obj.solver.timesteps()]
    return runs, dynamic_summary(runs)


def test_en02_published_figures(en02):
    """-360 deg, 1.110 m, 9.810 N at the published precision; the two bounds are met."""
    _, s = en02
    assert s["status"] == "ok" and s["dt_s"] == [0.002, 0.001]
    assert s["angular_displacement_deg"] == pytest.approx(
        published.EN02["angular_displacement_deg"], abs=1e-5)
    assert round(s["final_radius_m"], 3) == published.EN02["final_radius_m"]
    assert round(s["min_normal_reaction_N"], 3) == published.EN02["min_normal_reaction_N"]
    assert s["timestep_difference_m"] < published.EN02["timestep_difference_m"]
    assert s["energy_residual_J"] < published.EN02["energy_residual_J"]


def test_en02_history_is_sampled_and_consistent(en02):
    """0.1 s sampling over 120 s; the minimum N over all steps is below every sample."""
    runs, s = en02
    ds = runs[0]
    assert ds.sizes["time"] == 1201
    assert ds.time.values[1] == pytest.approx(0.1)
    assert s["min_normal_reaction_N"] <= float(ds.normal_reaction.min()) + 1e-15
    assert s["max_slip_speed_m_s"] >= float(ds.slip_speed.max()) - 1e-18
    # The sphere starts at a cavity bottom at rest: N = m g, no slip, no spin.
    assert float(ds.normal_reaction[0]) == pytest.approx(9.81, rel=1e-12)
    assert float(ds.spin_rate[0]) == 0.0


def test_en02r_transport_follows_the_cavity(en02r):
    """The cavity goes from R = 0.43 to 1.29 (R_p = 0.43 + 0.86 s); the sphere follows it."""
    runs, s = en02r
    ds = runs[0]
    assert s["status"] == "ok"
    assert float(ds.cavity_R[0]) == pytest.approx(0.43, abs=1e-12)
    assert float(ds.cavity_R[-1]) == pytest.approx(1.29, abs=1e-12)
    assert s["cavity_tracking_error_m"] < 0.01
    assert round(s["angular_displacement_deg"]) == 360
    # Flat surface: centre radius = R0 + R at a cavity bottom (W_R = 0), so 0.68 + 1.29.
    assert s["final_radius_m"] == pytest.approx(1.97, abs=1e-3)
    assert s["min_edge_clearance_m"] > 0.0
    assert s["timestep_difference_m"] < 1e-11


def test_unstable_dt_is_refused_at_validation_and_allowed_with_a_warning():
    """mu = 0.6 puts the friction limit near 1.08 ms: dt = 2 ms is refused, unless allowed,
    in one line with the rule's one message (creatio.dynamics.problem.check_stable)."""
    with pytest.raises(ConfigError) as info:
        resolve("en02", ["sphere.mu=0.6"])
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("invalid config: solver.dt=0.002: ")
    assert "mu = 0.6" in msg and "eps = 0.01" in msg and "largest stable dt is 0.00108161 s" in msg
    assert "solver.allow_unstable=true" in msg
    with pytest.raises(UnstableStepError) as core:
        check_stable(resolve("en02", ["sphere.mu=0.6", "solver.allow_unstable=true"]).obj
                     .sphere_problem().replace(allow_unstable=False))
    assert str(core.value) in msg
    allowed = resolve("en02", ["sphere.mu=0.6", "solver.allow_unstable=true",
                               "phases.T=2.0"])
    ds = run_study(allowed)
    assert "allow_unstable" in ds.attrs["warnings"]


def test_a_stop_is_recorded_not_hidden():
    """A 1 s cycle throws the sphere off: status contact_lost with its time, no NaN."""
    resolved = resolve("en02", ["phases.T=1.0"])
    ds = run_study(resolved)
    assert ds.attrs["status"] == "contact_lost"
    assert 0.0 < ds.attrs["stop_time"] < 1.0
    assert math.isclose(float(ds.time.values[-1]), ds.attrs["stop_time"], abs_tol=1e-12)
    assert not ds.centre.isnull().any()


def test_trajectory_only_skips_what_it_does_not_need():
    """mu = 0 and only the trajectory asked: no rotation, no energy; the same path."""
    short = ["phases.T=10.0", "sphere.mu=0"]
    full = run_study(resolve("en02", short))
    lean = run_study(resolve("en02", [*short, "study.outputs=[trajectory]"]))
    assert full.attrs["rotation_integrated"] == 1 and full.attrs["energy_integrated"] == 1
    assert lean.attrs["rotation_integrated"] == 0 and lean.attrs["energy_integrated"] == 0
    assert float(abs(lean.centre - full.centre).max()) < 1e-15
    assert lean.energy_residual.isnull().all()
    with_friction = run_study(resolve("en02", ["phases.T=10.0", "study.outputs=[trajectory]"]))
    assert with_friction.attrs["rotation_integrated"] == 1  # friction couples spin and path


def test_outputs_must_include_the_trajectory():
    """An outputs list without the trajectory is refused, naming the key."""
    with pytest.raises(ConfigError, match="study.outputs"):
        resolve("en02", ["study.outputs=[energy]"])


def test_en02v_settles_on_a_still_surface_that_does_no_work():
    """EN-02V (docs/studies.md): on the viewer's still surface the membrane's power
    (N n + f) . c_t vanishes (c_t = 0), so E - E0 = -D_friction; the sphere rolls from 30 deg
    toward the cavity bottom at (180 - 29) / 6 = 25.17 deg and stays near it; the energy
    residual falls at RK4's order between dt and dt / 2."""
    resolved = resolve("en02v")
    runs = [run_study(resolved, dt=dt) for dt in resolved.obj.solver.timesteps()]
    s = dynamic_summary(runs)
    assert s["status"] == "ok" and s["stop_time_s"] == 20.0
    for ds in runs:
        assert float(abs(ds.surface_work).max()) == 0.0
        assert float(ds.friction_dissipation[-1]) > 0.0
    alpha = runs[0].contact_alpha.values  # the contact point's angle (degree)
    bottom = (180.0 - 29.0) / 6.0
    assert alpha[0] == pytest.approx(30.0, abs=1e-9)
    assert alpha.min() < bottom < 30.0 and abs(alpha[-1] - bottom) < 30.0 - bottom
    coarse, fine = (s["energy_residual_by_dt_J"][repr(dt)] for dt in s["dt_s"])
    assert coarse / fine > 2.0**4 * 0.9
