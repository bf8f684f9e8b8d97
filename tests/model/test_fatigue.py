"""Fatigue over the transport cycle (EN-06, docs/materials.md): rainflow on the ASTM E1049
example, Miner's rule at constant amplitude, the periodic treatment, EN-02's closed form (12
cycles at every point, their range and mean), and the material configs' validation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from creatio.errors import ConfigError
from creatio.model import fatigue as FT
from creatio.model.laws import Law
from creatio.model.strain import largest_face_strain
from creatio.model.surface import Motion, Surface
from creatio.studies.material_schema import MaterialConfig, MaterialLaw

REPO = Path(__file__).resolve().parents[2]
R0, DR, A, KA = 0.68, 1.72, 0.18, 6
K = 2.0 * math.pi / DR
T = 120.0
SURF = Surface(R0=R0, dR=DR, A=A, Kr=1, Ka=KA)
EN02 = Motion(Law.constant(0.0), Law.quintic(0.0, 12.0 * math.pi, T), Law.constant(0.0))
ELASTOMER = FT.StrainLife(eps_f=4.0, c=-0.2, eps_u=3.0)


def test_rainflow_counts_the_astm_e1049_example() -> None:
    """ASTM E1049-85 s.5.4.4 example -2, 1, -3, 5, -1, 3, -4, 4, -2: ranges 3 (1/2),
    4 (3/2), 6 (1/2), 8 (1), 9 (1/2), by hand from the three-point rule."""
    cyc = FT.count_cycles([-2, 1, -3, 5, -1, 3, -4, 4, -2], periodic=False)
    table: dict[float, float] = {}
    for rng, count in zip(cyc.range, cyc.count, strict=True):
        table[float(rng)] = table.get(float(rng), 0.0) + float(count)
    assert table == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}
    assert cyc.total == 4.0
    # the one closed loop is (-1, 3), mean 1; range 8 is two halves, (-3, 5) and (-4, 4)
    full = {(float(r), float(m)) for r, m, c in zip(cyc.range, cyc.mean, cyc.count,
                                                     strict=True) if c == 1.0}
    assert full == {(4.0, 1.0)}
    eights = sorted(float(m) for r, m in zip(cyc.range, cyc.mean, strict=True) if r == 8.0)
    assert eights == [0.0, 1.0]


def test_miner_at_constant_amplitude_gives_the_strain_life() -> None:
    """n equal cycles of amplitude 0.5 and mean 0.25 (elastomer law): eps_aeq = 6/11, so
    N_f = (22/3)^5 = 21208.37...; damage n / N_f and one cycle's life N_f."""
    n = 7
    phase = 2 * np.pi * np.arange(n * 16) / 16
    series = 0.25 + 0.5 * np.cos(phase)
    cyc = FT.count_cycles(series)
    assert cyc.total == n
    np.testing.assert_allclose(cyc.range, 1.0, rtol=1e-12)
    np.testing.assert_allclose(cyc.mean, 0.25, atol=1e-12)
    n_f = (22.0 / 3.0) ** 5
    assert FT.cycles_to_failure(0.5, 0.25, ELASTOMER) == pytest.approx(n_f, rel=1e-12)
    assert FT.miner(cyc, ELASTOMER) == pytest.approx(n / n_f, rel=1e-12)
    one = FT.count_cycles(series[:16])
    assert 1.0 / FT.miner(one, ELASTOMER) == pytest.approx(n_f, rel=1e-12)


def test_mean_beyond_the_ultimate_strain_fails_at_once_and_a_still_point_never() -> None:
    """A cycle whose mean reaches eps_u has N_f = 0 (infinite damage); no strain swing, no
    damage."""
    assert FT.cycles_to_failure(0.1, 3.0, ELASTOMER) == 0.0
    hot = FT.count_cycles([3.1, 2.9, 3.1, 2.9])
    assert FT.miner(hot, ELASTOMER) == math.inf
    assert FT.miner(FT.count_cycles(np.full(10, 0.3)), ELASTOMER) == 0.0
    assert FT.cycles_to_failure(0.0, 0.2, ELASTOMER) == math.inf


def test_periodic_counting_does_not_depend_on_where_the_period_starts() -> None:
    """Rotating a periodic history (any start) gives the same cycles and damage: the
    treatment starts it at its largest peak and closes it there."""
    rng = np.random.default_rng(7)
    x = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    series = 0.3 + sum(rng.uniform(0.01, 0.1) * np.cos(m * x + rng.uniform(0, 6))
                       for m in range(1, 8))
    ref = FT.count_cycles(series)

    def table(c: FT.Cycles) -> dict[tuple[float, float], float]:
        out: dict[tuple[float, float], float] = {}
        for r, m, n in zip(c.range.round(12), c.mean.round(12), c.count, strict=True):
            out[(float(r), float(m))] = out.get((float(r), float(m)), 0.0) + float(n)
        return out

    key = table(ref)
    assert all(n == round(n) for n in key.values())  # closed loops: half cycles pair up
    for shift in (1, 37, 150):
        got = FT.count_cycles(np.roll(series, shift))
        assert table(got) == key
        assert FT.miner(got, ELASTOMER) == pytest.approx(FT.miner(ref, ELASTOMER), rel=1e-12)
    # counted as a plain (open) sequence, a shifted start changes the count: the treatment matters
    open_counts = {FT.count_cycles(np.roll(series, s), periodic=False).total for s in (1, 37)}
    assert open_counts != {ref.total}


def quintic_inverse(s: np.ndarray) -> np.ndarray:
    """tau with 10 tau^3 - 15 tau^4 + 6 tau^5 = s, by bisection (the step is increasing)."""
    lo, hi = np.zeros_like(s), np.ones_like(s)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        below = 10 * mid**3 - 15 * mid**4 + 6 * mid**5 < s
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def test_en02_closed_form_twelve_cycles_of_known_range_and_mean_everywhere() -> None:
    """EN-02 at h = 0: eps1 = a cos^2 v + b sin^2 v with a = A^2 k^2 cos^2 u / 2,
    b = A^2 (Ka / rho)^2 sin^2 u / 2 (u = kR fixed, v = Ka alpha + phi_a rising by 12 pi):
    exactly 12 cycles at every point, range |a - b|, mean (a + b) / 2. Times are where
    phi_a = n pi / 8 and alpha = j pi / 24, so every extreme of v is sampled exactly."""
    times = T * quintic_inverse(np.arange(96) / 96.0)
    np.testing.assert_allclose(EN02.phi_a(times).value, np.arange(96) * np.pi / 8, atol=1e-12)
    alpha = np.arange(48) * np.pi / 24
    R = np.array([0.0, 0.1, 0.3595, 0.6, 0.86, 1.2, 1.5])
    hist = FT.history(largest_face_strain(SURF, EN02, h=0.0), alpha, R, times)
    u = K * R
    a = 0.5 * A**2 * K**2 * np.cos(u) ** 2
    b = 0.5 * A**2 * (KA / (R0 + R)) ** 2 * np.sin(u) ** 2
    assert np.any(a > b) and np.any(a < b)
    for j, (aj, bj) in enumerate(zip(a, b, strict=True)):
        for i in range(alpha.size):
            cyc = FT.count_cycles(hist[i, j])
            assert cyc.total == 12.0
            np.testing.assert_allclose(cyc.range, abs(aj - bj), rtol=1e-9, atol=1e-14)
            np.testing.assert_allclose(cyc.mean, 0.5 * (aj + bj), rtol=1e-9)
    fmap = FT.fatigue_map(largest_face_strain(SURF, EN02, h=0.0), ELASTOMER, alpha, R, times)
    eps_aeq = 0.5 * np.abs(a - b) / (1 - 0.5 * (a + b) / 3.0)
    damage = 12.0 / (eps_aeq / 4.0) ** (1 / -0.2)
    np.testing.assert_allclose(fmap.damage, np.broadcast_to(damage, fmap.damage.shape),
                               rtol=1e-8)
    np.testing.assert_array_equal(fmap.cycles, 12.0)
    assert fmap.max_damage == pytest.approx(damage.max(), rel=1e-8)
    assert fmap.R_max == R[int(np.argmax(damage))]
    assert fmap.life == pytest.approx(1.0 / damage.max(), rel=1e-8)


# ---------------------------------------------------------------------- material configs
def load(name: str) -> dict[str, object]:
    """A shipped material group as a plain mapping."""
    return yaml.safe_load((REPO / "conf" / "material" / f"{name}.yaml").read_text())


def test_shipped_materials_are_valid_and_labelled_illustrative() -> None:
    """elastomer: neo-Hookean 0.4 MPa, 1 mm, eps_u 3, eps_f 4, c -0.2; fabric: SVK 1 GPa,
    nu 0.3, 0.3 mm, eps_u 0.03, eps_f 0.05, c -0.1; both files say illustrative."""
    el = MaterialConfig.from_mapping(load("elastomer"), "elastomer")
    fa = MaterialConfig.from_mapping(load("fabric"), "fabric")
    assert (el.law, el.shear_modulus, el.thickness, el.eps_u, el.eps_f, el.c) == (
        MaterialLaw.neo_hookean, 4e5, 1e-3, 3.0, 4.0, -0.2)
    assert (fa.law, fa.youngs_modulus, fa.poisson, fa.thickness, fa.eps_u, fa.eps_f, fa.c) == (
        MaterialLaw.svk, 1e9, 0.3, 3e-4, 0.03, 0.05, -0.1)
    assert el.strain_life() == ELASTOMER
    for name in ("elastomer", "fabric"):
        assert "illustrative" in (REPO / "conf" / "material" / f"{name}.yaml").read_text()


BAD = [
    ("elastomer", "shear_modulus", 0.0, "must be > 0"),
    ("elastomer", "shear_modulus", -4e5, "must be > 0"),
    ("elastomer", "shear_modulus", math.nan, "finite"),
    ("elastomer", "shear_modulus", math.inf, "finite"),
    ("elastomer", "shear_modulus", "soft", "must be a number"),
    ("elastomer", "shear_modulus", True, "must be a number"),
    ("elastomer", "youngs_modulus", 1e9, "not used by law=neo_hookean"),
    ("elastomer", "thickness", 0.0, "must be > 0"),
    ("elastomer", "thickness", -1e-3, "must be > 0"),
    ("elastomer", "thickness", None, "must be a number"),
    ("elastomer", "eps_u", 0.0, "must be > 0"),
    ("elastomer", "eps_f", -4.0, "must be > 0"),
    ("elastomer", "c", 0.0, "must be < 0"),
    ("elastomer", "c", 0.2, "must be < 0"),
    ("elastomer", "c", -math.inf, "finite"),
    ("elastomer", "law", "rubber", "must be one of neo_hookean | svk"),
    ("elastomer", "hardness", 60.0, "is not a material key"),
    ("fabric", "youngs_modulus", 0.0, "must be > 0"),
    ("fabric", "poisson", 0.5, "0 <= poisson < 0.5"),
    ("fabric", "poisson", -0.1, "0 <= poisson < 0.5"),
    ("fabric", "shear_modulus", 1e6, "not used by law=svk"),
    ("fabric", "eps_u", 1e20, "in magnitude"),
]


@pytest.mark.parametrize(("material", "key", "value", "rule"), BAD)
def test_bad_material_values_are_refused_in_one_line(material: str, key: str, value: object,
                                                     rule: str) -> None:
    """Each bad value raises ConfigError: one line naming the key, the value and the rule."""
    values = load(material)
    values[key] = value
    with pytest.raises(ConfigError) as err:
        MaterialConfig.from_mapping(values, f"material.{material}")
    message = str(err.value)
    assert "\n" not in message
    assert err.value.key == f"material.{material}.{key}"
    assert repr(value) in message and rule in message
