"""The sphere model's similarity and the pull a platform adds to it (docs/aerospace.md).

Under a pull of strength a along the structure's -z (gravity, or the ``base`` confinement
P / m, which acts exactly as gravity), a run at length scale s under a is the run at scale 1
under g with every length times s and every time times sqrt(s g / a), provided the
friction's regularisation speed eps scales as a velocity and m, mu and every angle stay.
:func:`factors` gives the factor of each kind of quantity. :func:`pull_vector` composes the
pull with a platform's residual acceleration into the one gravity vector the core takes
(magnitude, tilt, azimuth: a residual adds to the pull exactly as a mounting tilt does).
:func:`point_mass_yaw` is the closed form of a host's yaw that the interfaces are read
beside. Pure functions of numbers: no config, no solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from creatio.model.structure import point_mass_rotation

__all__ = ["Factors", "factors", "point_mass_yaw", "pull_vector"]


@dataclass(frozen=True)
class Factors:
    """What one unit of each kind of quantity becomes at scale s under a pull a (a_ratio =
    a / g): the multiplier of a length, time, velocity, acceleration, rate (1 / time),
    force, power and energy of the sphere (mass unchanged)."""

    length: float
    time: float
    velocity: float
    acceleration: float
    rate: float
    force: float
    power: float
    energy: float


def factors(s: float, a_ratio: float) -> Factors:
    """The similarity factors of scale s (> 0) under a pull a_ratio times the reference's
    (> 0): lengths s, times sqrt(s / a_ratio), velocities sqrt(s a_ratio), forces a_ratio,
    powers a_ratio sqrt(s a_ratio), energies s a_ratio."""
    if not (s > 0.0 and math.isfinite(s)):
        raise ValueError(f"s must be finite and > 0, got {s}")
    if not (a_ratio > 0.0 and math.isfinite(a_ratio)):
        raise ValueError(f"a_ratio must be finite and > 0, got {a_ratio}")
    time = math.sqrt(s / a_ratio)
    velocity = math.sqrt(s * a_ratio)
    return Factors(length=s, time=time, velocity=velocity, acceleration=a_ratio,
                   rate=1.0 / time, force=a_ratio, power=a_ratio * velocity,
                   energy=s * a_ratio)


def pull_vector(pull: float, residual: float, direction: tuple[float, float, float]
                ) -> tuple[float, float, float]:
    """(g, beta, psi) of the gravity vector pull (0, 0, -1) + residual d / |d| in the
    structure's frame: its magnitude (m/s^2), its tilt off -z (rad, in [0, pi/2)) and the
    azimuth it leans toward (rad; 0 when it has no horizontal part), the arguments of
    creatio.dynamics.problem.Sphere. ValueError when the sum does not point below the
    membrane's plane (the membrane must carry it) or the direction is the zero vector."""
    dx, dy, dz = (float(c) for c in direction)
    norm = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not (norm > 0.0 and math.isfinite(norm)):
        raise ValueError(f"direction must be a nonzero finite vector, got {direction}")
    gx, gy = residual * dx / norm, residual * dy / norm
    gz = -pull + residual * dz / norm
    horizontal = math.hypot(gx, gy)
    if not gz < 0.0:
        raise ValueError(f"the pull {pull} m/s^2 along -z plus the residual {residual} m/s^2 "
                         f"along {direction} does not point below the membrane's plane "
                         f"(z component {gz:.6g} m/s^2)")
    g = math.hypot(horizontal, gz)
    beta = math.atan2(horizontal, -gz)
    psi = math.atan2(gy, gx) if horizontal > 0.0 else 0.0
    return g, beta, psi


def point_mass_yaw(m: float, rho: float, I_s: float, turn: float = 2.0 * math.pi) -> float:
    """Host yaw (rad) when a point mass m is carried through a relative turn (default one
    full turn) at the constant radius rho: -m rho^2 / (I_s + m rho^2) x turn (H_z = 0)."""
    return point_mass_rotation(m, rho, I_s, turn)
