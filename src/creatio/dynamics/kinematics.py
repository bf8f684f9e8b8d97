"""Exact kinematics of the sphere centre at one point, compiled (docs/model.md s.1, s.4).

The jets are creatio.model.offset's; this wraps them for callers that want the world-frame
derivatives of X = c + b n at one (R, alpha, t): verification and tests.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from creatio.dynamics.jit import njit
from creatio.model.laws import law_eval
from creatio.model.offset import offset_jets
from creatio.model.surface import Motion, Surface

__all__ = ["centre_kinematics"]


@njit(cache=True)
def _centre_kinematics_rot(R, a, t, R0, k, A, Ka, b, lr, la, lg):
    """Rotating-frame X, its derivatives, n, c and c_t at (R, alpha, t) for the wrapper."""
    pr, pr1, pr2 = law_eval(lr, t)
    pa, pa1, pa2 = law_eval(la, t)
    gm, g1, g2 = law_eval(lg, t)
    rho, z, n1, n2, n3, P, Q, Z = offset_jets(
        R, a, R0, k, A, Ka, b, pr, pr1, pr2, pa, pa1, pa2, gm, g1, g2
    )
    out = np.empty((13, 3))
    out[0] = (P[0], Q[0], Z[0])
    out[1] = (P[1], Q[1], Z[1])  # X_R
    out[2] = (P[2] - Q[0], Q[2] + P[0], Z[2])  # X_a
    out[3] = (P[3], Q[3], Z[3])  # X_t
    out[4] = (P[4], Q[4], Z[4])  # X_RR
    out[5] = (P[5] - Q[1], Q[5] + P[1], Z[5])  # X_Ra
    out[6] = (P[7] - 2.0 * Q[2] - P[0], Q[7] + 2.0 * P[2] - Q[0], Z[7])  # X_aa
    out[7] = (P[6], Q[6], Z[6])  # X_Rt
    out[8] = (P[8] - Q[3], Q[8] + P[3], Z[8])  # X_at
    out[9] = (P[9], Q[9], Z[9])  # X_tt
    out[10] = (n1, n2, n3)
    out[11] = (rho[0], 0.0, z[0])  # c
    out[12] = (rho[3], 0.0, z[3])  # c_t
    return out


def centre_kinematics(surface: Surface, motion: Motion, b: float, R: float, alpha: float,
                      t: float) -> dict[str, NDArray[np.float64]]:
    """World-frame X, X_q (3, 2), X_t, X_qq (3, 2, 2), X_qt (3, 2), X_tt, n, c, c_t at one point.

    The exact derivatives the integrator uses, exposed for verification and for callers
    that need the offset-surface geometry of a sphere of radius b; q = (R, alpha).
    """
    rot = _centre_kinematics_rot(
        float(R),
        float(alpha),
        float(t),
        float(surface.R0),
        surface.k,
        float(surface.A),
        float(surface.Ka),
        float(b),
        motion.phi_r.coefficients(),
        motion.phi_a.coefficients(),
        motion.gamma.coefficients(),
    )
    ca, sa = math.cos(alpha), math.sin(alpha)
    to_world = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    w = rot @ to_world.T
    X_q = np.stack([w[1], w[2]], axis=1)
    X_qq = np.empty((3, 2, 2))
    X_qq[:, 0, 0] = w[4]
    X_qq[:, 0, 1] = X_qq[:, 1, 0] = w[5]
    X_qq[:, 1, 1] = w[6]
    X_qt = np.stack([w[7], w[8]], axis=1)
    return {
        "X": w[0],
        "X_q": X_q,
        "X_t": w[3],
        "X_qq": X_qq,
        "X_qt": X_qt,
        "X_tt": w[9],
        "n": w[10],
        "c": w[11],
        "c_t": w[12],
    }
