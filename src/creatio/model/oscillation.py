"""Small oscillations of the sphere in a still cavity of the flat annulus (docs/model.md s.12.3).

At a cavity bottom of the flat annulus (gamma = 0, W = -A, grad W = 0) the principal
directions are R and alpha with curvatures kappa_R = A k^2 and kappa_alpha = A Ka^2 / rho_c^2
(creatio.model.cavity.bottom_curvatures). The centre X = c + b n moves on the offset
surface, whose curvatures there are kappa / (1 - b kappa); gravity is along -n. Along each
principal direction, for a small displacement s of the centre:

    sliding (mu = 0):         omega^2 = g kappa / (1 - b kappa)
    rolling without slip:     omega^2 = g kappa / ((1 - b kappa)(1 + I / (m b^2)))

(1 + I / (m b^2) = 7/5 for the homogeneous sphere). With the regularised friction of
docs/model.md s.4 the no-slip constraint is a stiff viscous coupling of rate
gamma_f = mu g / eps (per unit mass, N = m g at rest at the bottom), and the linearised
motion is the root pair of a cubic (:func:`regularised_rolling`) that tends to the rolling
frequency as gamma_f grows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from creatio.model.cavity import bottom_curvatures

__all__ = ["StillCavity", "regularised_rolling", "still_cavity"]

#: I / (m b^2) of the homogeneous sphere (I = 2 m b^2 / 5, creatio.model.sphere.inertia).
SOLID_SPHERE = 0.4


@dataclass(frozen=True)
class StillCavity:
    """Small-oscillation closed forms of one still cavity bottom (angular rates in rad/s):
    the bottom's principal curvatures (1/m), the sliding and the rolling frequencies along
    R and along alpha."""

    kappa_R: float
    kappa_alpha: float
    slide_R: float
    slide_alpha: float
    roll_R: float
    roll_alpha: float

    def slide(self, direction: str) -> float:
        """The sliding frequency along "R" or "alpha"."""
        return {"R": self.slide_R, "alpha": self.slide_alpha}[direction]

    def roll(self, direction: str) -> float:
        """The rolling frequency along "R" or "alpha"."""
        return {"R": self.roll_R, "alpha": self.roll_alpha}[direction]


def still_cavity(A: float, k: float, Ka: float, rho_c: float, b: float, g: float,
                 inertia_ratio: float = SOLID_SPHERE) -> StillCavity:
    """The closed forms above for the flat annulus's cavity bottom at horizontal radius
    rho_c = R0 + R_c; ValueError when the offset is singular there (b kappa >= 1)."""
    kR, ka = bottom_curvatures(A, k, Ka, rho_c, 0.0)
    if b * max(kR, ka) >= 1.0:
        raise ValueError(f"offset singular at the bottom: b kappa = {b * max(kR, ka):.6g} >= 1")

    def slide(kappa: float) -> float:
        return math.sqrt(g * kappa / (1.0 - b * kappa))

    s_R, s_a = slide(kR), slide(ka)
    f = 1.0 / math.sqrt(1.0 + inertia_ratio)
    return StillCavity(kR, ka, s_R, s_a, f * s_R, f * s_a)


def regularised_rolling(omega_slide: float, rate: float, inertia_ratio: float = SOLID_SPHERE
                        ) -> tuple[float, float]:
    """(angular frequency, decay rate) of the oscillation under a viscous slip coupling.

    The centre's displacement s along a principal direction and the rolled length y = b theta
    obey s'' = -omega_slide^2 s - rate (s' - y') and j y'' = rate (s' - y') with
    j = I / (m b^2) and rate = mu N / (m eps) the friction's linearised coefficient per unit
    mass. Their characteristic polynomial is

        j z^3 + rate (1 + j) z^2 + j omega_slide^2 z + rate omega_slide^2 = 0,

    whose complex pair -decay +- i omega is returned; rate -> inf gives the rolling
    frequency omega_slide / sqrt(1 + j), rate = 0 the sliding one.
    """
    if rate <= 0.0:
        return omega_slide, 0.0
    j = inertia_ratio
    roots = np.roots([j, rate * (1.0 + j), j * omega_slide**2, rate * omega_slide**2])
    pair = roots[np.argmax(np.abs(roots.imag))]
    return float(abs(pair.imag)), float(-pair.real)
