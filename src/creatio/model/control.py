"""Phase-tracking control of the pattern (docs/model.md s.12.2): the lead, the cascade, gains.

The angular phase phi_a becomes a state with phiddot_a = u. The carrying cavity's angle is
alpha_p = (pi - phi_a + 2 pi j) / Ka with j picking the cavity nearest the contact angle
alpha, and the lead is delta = alpha_p - alpha in (-pi/Ka, pi/Ka]. With theta = alpha -
alpha(0) the sphere's travel and theta_goal the commanded one:

    v_cmd     = sat((K_theta / K_omega) (theta_goal - theta), Omega_max)
    delta_cmd = sat(K_omega (v_cmd - alphadot), delta_max)
    u         = sat(omega_n^2 Ka (delta - delta_cmd) + 2 zeta omega_n (-Ka alphadot - phidot_a),
                    u_max)

with sat(x, L) = max(-L, min(L, x)). u reads positions and velocities only, so a step's
stages never need an acceleration. :func:`servo` is scalar code that the dynamics layer
compiles into its right-hand side as it is (creatio.dynamics.jit registers it), and that
analyses call on recorded histories, so both see one formula.

The outer loop's gains follow from linearising the sphere in a still cavity, alphaddot =
-k_alpha (alpha - alpha_p) = k_alpha delta, and placing its poles at s^2 + 2 zeta_c omega_c s +
omega_c^2 (:func:`outer_gains`): K_theta = omega_c^2 / k_alpha, K_omega = 2 zeta_c omega_c /
k_alpha, where k_alpha is the square of the rolling sphere's small-oscillation frequency
along alpha (creatio.model.oscillation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["SCALAR_KERNELS", "Controller", "lead", "outer_gains", "sat", "servo"]


def sat(x: float, limit: float) -> float:
    """x clipped to [-limit, limit] (limit = inf: x)."""
    return max(-limit, min(limit, x))


def lead(alpha: float, phi_a: float, Ka: float) -> float:
    """The lead delta = alpha_p - alpha of the cavity nearest alpha, in (-pi/Ka, pi/Ka]."""
    period = 2.0 * math.pi / Ka
    x = (math.pi - phi_a) / Ka - alpha
    return x - period * math.ceil(x / period - 0.5)


def servo(alpha: float, alphadot: float, phi_a: float, phidot_a: float, Ka: float,
          goal: float, alpha0: float, k_theta: float, k_omega: float, omega_max: float,
          delta_max: float, omega_n: float, zeta: float, u_max: float
          ) -> tuple[float, float, float, float]:
    """(u, delta, delta_cmd, v_cmd) of the cascade in the module docstring at one state."""
    theta = alpha - alpha0
    v_cmd = sat(k_theta / k_omega * (goal - theta), omega_max)
    delta_cmd = sat(k_omega * (v_cmd - alphadot), delta_max)
    delta = lead(alpha, phi_a, Ka)
    u = sat(omega_n * omega_n * Ka * (delta - delta_cmd)
            + 2.0 * zeta * omega_n * (-Ka * alphadot - phidot_a), u_max)
    return u, delta, delta_cmd, v_cmd


def outer_gains(omega_c: float, zeta_c: float, k_alpha: float) -> tuple[float, float]:
    """(K_theta, K_omega) placing the linearised outer loop's poles at omega_c, zeta_c."""
    return omega_c * omega_c / k_alpha, 2.0 * zeta_c * omega_c / k_alpha


@dataclass(frozen=True)
class Controller:
    """The controller of one run (angles in rad, rates in rad/s): the commanded travel
    theta_goal from alpha0, the outer gains, the speed limit Omega_max (of the sphere's
    alpha), the lead limit delta_max, the servo's omega_n and zeta and its acceleration
    limit u_max (rad/s^2 of phi_a; inf for none)."""

    goal: float
    alpha0: float
    k_theta: float
    k_omega: float
    omega_max: float
    delta_max: float
    omega_n: float
    zeta: float
    u_max: float = math.inf

    def __post_init__(self) -> None:
        for name in ("k_theta", "k_omega", "omega_max", "omega_n", "u_max"):
            v = getattr(self, name)
            if not v > 0.0:
                raise ValueError(f"controller {name} must be > 0, got {v}")
        for name in ("delta_max", "zeta"):
            v = getattr(self, name)
            if not v >= 0.0:
                raise ValueError(f"controller {name} must be >= 0, got {v}")
        for name in ("goal", "alpha0"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"controller {name} must be finite")

    def coefficients(self) -> NDArray[np.float64]:
        """The controller's row as the compiled core reads it (creatio.dynamics.layout C_*,
        in the order of this record's fields)."""
        return np.array([self.goal, self.alpha0, self.k_theta, self.k_omega, self.omega_max,
                         self.delta_max, self.omega_n, self.zeta, self.u_max], dtype=float)

    def acceleration(self, Ka: float, alpha: NDArray, alphadot: NDArray, phi_a: NDArray,
                     phidot_a: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """(u, delta, delta_cmd) along recorded histories, by :func:`servo`."""
        out = np.array([servo(a, ad, p, pd, Ka, self.goal, self.alpha0, self.k_theta,
                              self.k_omega, self.omega_max, self.delta_max, self.omega_n,
                              self.zeta, self.u_max)[:3]
                        for a, ad, p, pd in zip(alpha, alphadot, phi_a, phidot_a, strict=True)])
        if out.size == 0:
            return np.empty(0), np.empty(0), np.empty(0)
        return out[:, 0], out[:, 1], out[:, 2]


#: The scalar formulas the compiled core calls (creatio.dynamics.jit registers them).
SCALAR_KERNELS = (sat, lead, servo)
