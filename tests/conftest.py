"""Shared fixtures: the repository, and the EN-02 sphere problem built two ways.

``en02_problem`` restates EN-02 from docs/studies.md by hand, independently of conf/, so a
test comparing it with the composed config checks the config too; ``en02_config_problem``
is what the pipeline builds from conf/ (trajectory only: energy bookkeeping off).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from creatio.dynamics import Model, Sphere, SphereProblem, Start
from creatio.model.laws import Law
from creatio.model.surface import Motion, Surface

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def repo() -> Path:
    """The repository root (where the Snakefile and conf/ live)."""
    return REPO


@pytest.fixture(scope="session")
def en02_problem() -> SphereProblem:
    """EN-02 by hand (docs/studies.md): notebook geometry R0 = 0.68, dR = 1.72, A = 0.18,
    Kr = 1, Ka = 6, gamma = 0, phi_r = 0, phi_a = 12 pi s(t / 120); m = 1, b = 0.12,
    g = 9.81, mu = 0.15, eps = 0.01; at rest at R = 0.43, alpha = pi/6 (a cavity bottom);
    RK4 at dt = 0.002 s for 120 s."""
    return SphereProblem(
        model=Model(
            surface=Surface(R0=0.68, dR=1.72, A=0.18, Kr=1, Ka=6),
            motion=Motion(phi_r=Law.constant(0.0), phi_a=Law.quintic(0.0, 12.0 * math.pi, 120.0),
                          gamma=Law.constant(0.0)),
            sphere=Sphere(m=1.0, b=0.12, g=9.81, mu=0.15, eps=0.01),
        ),
        start=Start(R=0.43, alpha=math.pi / 6),
    )


@pytest.fixture(scope="session")
def en02r_problem(en02_problem: SphereProblem) -> SphereProblem:
    """EN-02R: phi_a = -12 pi s, phi_r = -pi s; the cavity follows R_c = 0.43 + 0.86 s."""
    return en02_problem.replace(phi_a=Law.quintic(0.0, -12.0 * math.pi, 120.0),
                                phi_r=Law.quintic(0.0, -math.pi, 120.0))


@pytest.fixture(scope="session")
def en02_config_problem() -> SphereProblem:
    """EN-02 as the pipeline composes it from conf/, trajectory only (energy off)."""
    from creatio.pipeline.config import resolve

    return resolve("en02").obj.sphere_problem().replace(energy=False)
