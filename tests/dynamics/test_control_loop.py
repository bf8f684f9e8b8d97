"""The compiled cascade along histories (creatio.dynamics.control_loop) against the model's
own scalar formula, called per state in Python."""

from __future__ import annotations

import math

import numpy as np
import pytest

from creatio.dynamics.control_loop import servo_histories
from creatio.model.control import Controller, servo

KA = 6.0


def _controller(u_max: float) -> Controller:
    return Controller(goal=-2.0 * math.pi, alpha0=0.3, k_theta=1.7, k_omega=0.9,
                      omega_max=2.0, delta_max=math.radians(10.0), omega_n=20.0, zeta=1.0,
                      u_max=u_max)


@pytest.mark.parametrize("u_max", [math.inf, 40.0], ids=["free", "limited"])
def test_servo_histories_are_the_scalar_servo_bit_for_bit(u_max: float) -> None:
    """2000 random states spanning several cavities and every saturation: u, delta and
    delta_cmd equal Controller.acceleration's (the scalar servo per state) exactly."""
    rng = np.random.default_rng(7)
    n = 2000
    alpha = rng.uniform(-8.0, 2.0, n)
    alphadot = rng.uniform(-4.0, 4.0, n)
    phi_a = rng.uniform(-40.0, 40.0, n)
    phidot_a = rng.uniform(-30.0, 30.0, n)
    ctl = _controller(u_max)
    got = servo_histories(ctl, KA, alpha, alphadot, phi_a, phidot_a)
    want = ctl.acceleration(KA, alpha, alphadot, phi_a, phidot_a)
    for g, w in zip(got, want, strict=True):
        assert g.shape == (n,) and np.array_equal(g, w)
    # the states reach the limits, so the comparison covers the clipped branches
    assert np.any(np.abs(got[2]) == ctl.delta_max)
    if math.isfinite(u_max):
        assert np.any(np.abs(got[0]) == u_max) and np.any(np.abs(got[0]) < u_max)
    # and the lead stays in (-pi/Ka, pi/Ka]
    assert np.all(np.abs(got[1]) <= math.pi / KA + 1e-15)
    one = servo(alpha[0], alphadot[0], phi_a[0], phidot_a[0], KA, *ctl.coefficients())
    assert (got[0][0], got[1][0], got[2][0]) == one[:3]


def test_servo_histories_of_no_states_and_of_mismatched_histories() -> None:
    """Empty histories give empty rows; histories of different lengths are refused."""
    ctl = _controller(math.inf)
    empty = servo_histories(ctl, KA, [], [], [], [])
    assert [e.shape for e in empty] == [(0,), (0,), (0,)]
    with pytest.raises(ValueError, match="one length"):
        servo_histories(ctl, KA, [0.0, 1.0], [0.0], [0.0, 1.0], [0.0, 1.0])
