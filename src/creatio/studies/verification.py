"""Verification kernels of the kinematic studies (plain NumPy, no xarray).

Central differences [c(q + h) - c(q - h)] / (2 h) with h in model units (u, rad, s),
evaluated just outside [0, dR] at the radial ends (the formula extends smoothly).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from creatio.model.surface import Frame, Motion, Surface

DERIVATIVES = ("c_R", "c_alpha", "c_t")


def sample_grid(
    surface: Surface, n_radii: int, n_angles: int, times: Sequence[float]
) -> tuple[NDArray, NDArray, NDArray]:
    """Broadcast (alpha, R, t) grid: radii over [0, dR] with both ends, angles 2 pi j / n."""
    R = np.linspace(0.0, surface.dR, n_radii)
    alpha = 2.0 * np.pi * np.arange(n_angles) / n_angles
    t = np.asarray(times, float)
    return np.meshgrid(alpha, R, t, indexing="ij")


def fd_errors(
    surface: Surface, motion: Motion, alpha: NDArray, R: NDArray, t: NDArray,
    hs: Sequence[float],
) -> NDArray:
    """Max Euclidean error of analytic c_R, c_alpha, c_t against central differences.

    Returns shape (3, len(hs)) in the order of DERIVATIVES.
    """
    fr = Frame(surface, motion, alpha, R, t)
    exact = (fr.c_R, fr.c_alpha, fr.c_t)
    out = np.empty((3, len(hs)))

    def pos(a: NDArray, r: NDArray, tt: NDArray) -> NDArray:
        return Frame(surface, motion, a, r, tt).position

    for j, h in enumerate(hs):
        approx = (
            (pos(alpha, R + h, t) - pos(alpha, R - h, t)) / (2 * h),
            (pos(alpha + h, R, t) - pos(alpha - h, R, t)) / (2 * h),
            (pos(alpha, R, t + h) - pos(alpha, R, t - h)) / (2 * h),
        )
        for i in range(3):
            out[i, j] = np.max(np.linalg.norm(approx[i] - exact[i], axis=-1))
    return out


def regularity(
    surface: Surface, motion: Motion, alpha: NDArray, R: NDArray, t: NDArray
) -> dict[str, float]:
    """Normal length, normal-tangent orthogonality, J identity, min J and seam closure."""
    fr = Frame(surface, motion, alpha, R, t)
    n, cR, ca = fr.normal, fr.c_R, fr.c_alpha
    cross = np.cross(cR, ca)
    dots = np.maximum(
        np.abs(np.sum(n * cR, -1)) / np.linalg.norm(cR, axis=-1),
        np.abs(np.sum(n * ca, -1)) / np.linalg.norm(ca, axis=-1),
    )
    seam = Frame(surface, motion, alpha + 2.0 * np.pi, R, t).position - fr.position
    return {
        "normal_length_error": float(np.max(np.abs(np.linalg.norm(n, axis=-1) - 1.0))),
        "normal_tangent_dot": float(np.max(dots)),
        "j_identity_error": float(np.max(np.abs(fr.J - np.linalg.norm(cross, axis=-1)))),
        "j_min_sampled": float(np.min(fr.J)),
        "seam_closure": float(np.max(np.linalg.norm(seam, axis=-1))),
    }
