"""A sphere study with the ``control`` group on (docs/model.md s.12.2): the dataset records the
controlled phase, its rate, u, the lead and the arrival readouts; the recorded lead names a
cavity of the recorded phase; the energy balance closes at RK4's truncation level and its
residual shrinks about 16-fold per halving of dt."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics import simulate
from creatio.pipeline.config import resolve
from creatio.studies import sphere


@pytest.fixture(scope="module")
def cfg():
    # EN-02 with the default controller over 8 s (it arrives within about 4.3 s)
    return resolve("en02", ["control=pd", "phases.T=8"]).obj


@pytest.fixture(scope="module")
def ds(cfg):
    return sphere.run(cfg, cfg.solver.dt)


def test_dataset_records_the_control_block(cfg, ds) -> None:
    for name, units in (("phase_a", "degree"), ("phase_a_rate", "rad s-1"),
                        ("phase_a_acceleration", "rad s-2"), ("lead", "degree"),
                        ("lead_command", "degree"), ("travel", "degree")):
        assert ds[name].attrs["units"] == units and ds[name].sizes["time"] == ds.sizes["time"]
    assert ds.attrs["status"] == "ok" and ds.attrs["carried"] == 1 and ds.attrs["control"] == 1
    Ka = cfg.geometry.Ka
    # the lead is the offset of a cavity of the recorded phase: Ka (alpha + delta) + phi_a
    # = pi (mod 2 pi), and it lies within half a cavity
    v = np.radians(Ka * (ds.contact_alpha + ds.lead) + ds.phase_a) - math.pi
    assert np.max(np.abs(np.angle(np.exp(1j * v.values)))) < 1e-9
    assert np.all(np.abs(ds.lead.values) <= 180.0 / Ka + 1e-9)
    # the pattern angle follows the state's phase: alpha0 - (phi_a - phi_a(0)) / Ka
    expected = 30.0 - (ds.phase_a - ds.phase_a[0]) / Ka
    np.testing.assert_allclose(ds.pattern_angle, expected, rtol=0, atol=1e-12)
    # the commanded lead stays within its limit; the travel reaches the goal
    assert np.max(np.abs(ds.lead_command.values)) <= 10.0 + 1e-12
    assert ds.travel.values[-1] == pytest.approx(-360.0, abs=2.0)
    arrival = ds.attrs["arrival_time"]
    first = ds.time.values[np.argmax(np.abs(ds.travel.values + 360.0) <= 2.0)]
    assert 0.0 < arrival == first < 8.0 and ds.attrs["settling_time"] >= arrival
    # u: the recorded rate's slope (central differences over 0.1 s, O(0.01) in u's scale)
    rate = ds.phase_a_rate.values
    slope = (rate[2:] - rate[:-2]) / 0.2
    scale = np.max(np.abs(ds.phase_a_acceleration.values))
    u = ds.phase_a_acceleration.values[1:-1]
    smooth = np.abs(u) < 0.5 * scale  # off the saturated kinks
    assert np.median(np.abs(slope - u)[smooth]) < 0.02 * scale


def test_energy_residual_converges_at_rk4_order(cfg) -> None:
    """The controlled run's largest energy residual falls about 2^4 = 16-fold per halving of
    dt once the step resolves the saturations' switches (27x from 2 ms, 18.5x from 1 ms)."""
    residual = []
    for dt in (0.002, 0.001, 0.0005):
        res = simulate(cfg.sphere_problem().replace(dt=dt))
        assert res.counts.status == "ok"
        residual.append(res.extrema.max_energy_residual)
    ratios = [a / b for a, b in zip(residual[:-1], residual[1:], strict=True)]
    assert 12.0 < ratios[-1] < 24.0 and ratios[-1] < ratios[0]
    assert residual[0] < 1e-6  # a millionth of a joule against ~1 J of mechanical energy
