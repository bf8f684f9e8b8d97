"""The similarity factors, the pull plus a residual as one gravity vector, and the point-mass
yaw (EN-07, docs/aerospace.md), each against its closed form written out here."""

from __future__ import annotations

import math

import pytest

from creatio.model.similarity import factors, point_mass_yaw, pull_vector
from creatio.model.sphere import tilted_gravity


def test_factors_are_the_powers_of_s_and_a() -> None:
    """At s = 0.5, a = 2 g: times 0.5, velocities 1, rates 2, forces 2, powers 2, energies 1."""
    f = factors(0.5, 2.0)
    assert f.length == 0.5
    assert f.time == pytest.approx(0.5, rel=1e-15)
    assert f.velocity == pytest.approx(1.0, rel=1e-15)
    assert f.rate == pytest.approx(2.0, rel=1e-15)
    assert f.force == 2.0 and f.acceleration == 2.0
    assert f.power == pytest.approx(2.0, rel=1e-15)
    assert f.energy == pytest.approx(1.0, rel=1e-15)
    g = factors(3.0, 0.25)
    # length / time^2 is the acceleration; velocity x time is the length
    assert g.length / g.time ** 2 == pytest.approx(g.acceleration, rel=1e-14)
    assert g.velocity * g.time == pytest.approx(g.length, rel=1e-14)
    assert g.force * g.velocity == pytest.approx(g.power, rel=1e-14)


@pytest.mark.parametrize(("s", "a"), [(0.0, 1.0), (1.0, 0.0), (-1.0, 1.0), (math.inf, 1.0)])
def test_factors_refuse_a_scale_or_pull_that_is_not_positive(s: float, a: float) -> None:
    with pytest.raises(ValueError, match="must be finite and > 0"):
        factors(s, a)


@pytest.mark.parametrize("beta_deg", [0.5, 10.0, 45.0, 80.0])
@pytest.mark.parametrize("psi_deg", [0.0, 30.0, -120.0])
def test_pull_plus_residual_is_the_tilt(beta_deg: float, psi_deg: float) -> None:
    """g cos(beta) along -z plus g sin(beta) along (cos psi, sin psi, 0) is gravity tilted by
    beta toward psi (creatio.model.sphere.tilted_gravity): the same vector to rounding."""
    g = 9.81
    beta, psi = math.radians(beta_deg), math.radians(psi_deg)
    gm, b, p = pull_vector(g * math.cos(beta), g * math.sin(beta),
                           (math.cos(psi), math.sin(psi), 0.0))
    assert gm == pytest.approx(g, rel=4e-16)
    assert b == pytest.approx(beta, rel=4e-16, abs=1e-16)
    ref = tilted_gravity(g, beta, psi)
    got = tilted_gravity(gm, b, p)
    for x, y in zip(got, ref, strict=True):
        assert abs(x - y) <= 4 * math.ulp(g)


def test_pull_vector_without_residual_is_level_and_refuses_a_lift() -> None:
    assert pull_vector(2.0, 0.0, (1.0, 0.0, 0.0)) == (2.0, 0.0, 0.0)
    # a residual straight down adds to the pull
    assert pull_vector(2.0, 0.5, (0.0, 0.0, -3.0)) == (2.5, 0.0, 0.0)
    with pytest.raises(ValueError, match="below the membrane"):
        pull_vector(1.0, 1.0, (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="nonzero"):
        pull_vector(1.0, 0.1, (0.0, 0.0, 0.0))


def test_point_mass_yaw_is_the_closed_form() -> None:
    """m rho^2 / (I_s + m rho^2) of a full turn, opposite to it; 1 / I_s for a large host."""
    m, rho = 1.0, 1.1
    assert point_mass_yaw(m, rho, 10.0) == pytest.approx(
        -1.21 / 11.21 * 2 * math.pi, rel=1e-15)
    big = point_mass_yaw(m, rho, 1e6) / point_mass_yaw(m, rho, 1e7)
    assert big == pytest.approx(10.0, rel=1e-5)
    assert point_mass_yaw(m, rho, math.inf) == 0.0
