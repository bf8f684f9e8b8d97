"""The controller's cascade along recorded histories, compiled (docs/model.md s.12.2).

:meth:`creatio.model.control.Controller.acceleration` calls the scalar
:func:`~creatio.model.control.servo` once per recorded step in Python: about 1.7 million calls
in EN-04's closed loop. :func:`servo_histories` runs the same scalar formula in one compiled
loop (creatio.dynamics.jit registers it for compiled callers, as the right-hand side calls
it), so the numbers are those of the model's own formula, bit for bit: one formula, two
callers.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from creatio.dynamics.jit import njit
from creatio.model.control import Controller, servo

__all__ = ["servo_histories"]


@njit(cache=True)
def _servo_loop(Ka, alpha, alphadot, phi_a, phidot_a, c):  # type: ignore[no-untyped-def]
    """(u, delta, delta_cmd) rows of servo at each state, c the controller's coefficients."""
    n = alpha.size
    out = np.empty((n, 3))
    for i in range(n):
        u, d, dc, _ = servo(alpha[i], alphadot[i], phi_a[i], phidot_a[i], Ka, c[0], c[1],
                            c[2], c[3], c[4], c[5], c[6], c[7], c[8])
        out[i, 0] = u
        out[i, 1] = d
        out[i, 2] = dc
    return out


def servo_histories(ctl: Controller, Ka: float, alpha: ArrayLike, alphadot: ArrayLike,
                    phi_a: ArrayLike, phidot_a: ArrayLike
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """(u, delta, delta_cmd) along recorded histories: Controller.acceleration's numbers, by
    the same scalar servo in one compiled loop instead of a Python call per step."""
    arrays = [np.ascontiguousarray(x, dtype=np.float64) for x in (alpha, alphadot, phi_a,
                                                                   phidot_a)]
    size = arrays[0].size
    if any(a.ndim != 1 or a.size != size for a in arrays):
        raise ValueError("servo_histories needs four 1-D histories of one length, got shapes "
                         f"{[a.shape for a in arrays]}")
    out = _servo_loop(float(Ka), *arrays, ctl.coefficients())
    return out[:, 0], out[:, 1], out[:, 2]
