"""Fatigue of the membrane over one transport cycle: rainflow counting and Miner's rule (EN-06).

At each point of a grid over the membrane, the history of the largest principal face strain
over one cycle (creatio.model.strain) is periodic: it is rotated to start at its largest
peak and closed with that peak, then its cycles are counted by rainflow (ASTM E1049, the
`rainflow` package) and summed by Miner's rule with the material's strain-life law
(docs/materials.md, restated):

    N_f = (eps_aeq / eps_f)^(1 / c),   eps_aeq = eps_a / (1 - eps_mean / eps_u)

with eps_a half the cycle's range and eps_mean its mean; a cycle with eps_mean >= eps_u fails
at once (N_f = 0, infinite damage). The damage per transport cycle is sum(count / N_f), the
life in transport cycles 1 / (largest damage over the membrane).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import rainflow
from numpy.typing import ArrayLike, NDArray

from creatio.model.strain import Field

__all__ = [
    "Cycles",
    "FatigueMap",
    "StrainLife",
    "closed_periodic",
    "count_cycles",
    "cycles_to_failure",
    "fatigue_map",
    "history",
    "miner",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class StrainLife:
    """A material's strain-life law: coefficient eps_f, exponent c < 0, ultimate strain eps_u."""

    eps_f: float
    c: float
    eps_u: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.eps_f) and self.eps_f > 0.0):
            raise ValueError(f"eps_f must be a finite number > 0, got {self.eps_f}")
        if not (math.isfinite(self.c) and self.c < 0.0):
            raise ValueError(f"c must be a finite number < 0, got {self.c}")
        if not (math.isfinite(self.eps_u) and self.eps_u > 0.0):
            raise ValueError(f"eps_u must be a finite number > 0, got {self.eps_u}")


@dataclass(frozen=True)
class Cycles:
    """Rainflow cycles of one history: range, mean and count (1 or 1/2) of each."""

    range: Array
    mean: Array
    count: Array

    @property
    def total(self) -> float:
        """Number of cycles (half cycles count 1/2)."""
        return float(np.sum(self.count))


def history(field: Field, alpha: ArrayLike, R: ArrayLike, times: ArrayLike) -> Array:
    """A field (e.g. the largest principal face strain) at every (alpha, R) of a grid and
    every time: shape (n_alpha, n_R, n_t)."""
    a = np.asarray(alpha, float)
    r = np.asarray(R, float)
    t = np.asarray(times, float)
    return np.array(np.broadcast_to(field(a[:, None, None], r[None, :, None], t[None, None, :]),
                                    (a.size, r.size, t.size)))


def closed_periodic(series: ArrayLike) -> Array:
    """One period of a periodic history (its last sample not repeating the first), rotated to
    start at its largest value and closed by repeating it, so rainflow sees whole loops."""
    x = np.asarray(series, float)
    i = int(np.argmax(x))
    return np.concatenate([x[i:], x[:i], x[i:i + 1]])


def count_cycles(series: ArrayLike, periodic: bool = True) -> Cycles:
    """Rainflow cycles (ASTM E1049) of a history; a periodic one is closed first."""
    x = closed_periodic(series) if periodic else np.asarray(series, float)
    rows = [(rng, mean, count) for rng, mean, count, _, _ in rainflow.extract_cycles(x.tolist())]
    if not rows:
        return Cycles(np.zeros(0), np.zeros(0), np.zeros(0))
    rng, mean, count = (np.array(col, float) for col in zip(*rows, strict=True))
    return Cycles(rng, mean, count)


def cycles_to_failure(amplitude: ArrayLike, mean: ArrayLike, law: StrainLife) -> Array:
    """Cycles to failure N_f = (eps_aeq / eps_f)^(1 / c) with the mean-strain correction
    eps_aeq = eps_a / (1 - eps_mean / eps_u); 0 where eps_mean >= eps_u, inf where eps_a = 0."""
    eps_a, eps_m = np.broadcast_arrays(np.asarray(amplitude, float), np.asarray(mean, float))
    n_f = np.zeros(eps_a.shape)
    ok = eps_m < law.eps_u
    eps_aeq = eps_a[ok] / (1.0 - eps_m[ok] / law.eps_u)
    with np.errstate(divide="ignore"):
        n_f[ok] = (eps_aeq / law.eps_f) ** (1.0 / law.c)
    return n_f


def miner(cycles: Cycles, law: StrainLife) -> float:
    """Miner's damage sum(count / N_f) of a set of cycles (inf if one fails at once)."""
    if cycles.count.size == 0:
        return 0.0
    n_f = cycles_to_failure(0.5 * cycles.range, cycles.mean, law)
    with np.errstate(divide="ignore"):
        return float(np.sum(np.where(n_f == 0.0, np.inf, cycles.count / n_f)))


@dataclass(frozen=True)
class FatigueMap:
    """Damage per transport cycle on an (alpha, R) grid, its largest value, where, the life in
    transport cycles (1 / largest damage) and the rainflow cycle count at each point."""

    alpha: Array
    R: Array
    damage: Array
    cycles: Array
    max_damage: float
    alpha_max: float
    R_max: float
    life: float


def fatigue_map(field: Field, law: StrainLife, alpha: ArrayLike, R: ArrayLike,
                times: ArrayLike) -> FatigueMap:
    """Damage per transport cycle at every (alpha, R) from the field's periodic history at the
    times (one cycle, the last time not repeating the first)."""
    a, r = np.asarray(alpha, float), np.asarray(R, float)
    hist = history(field, a, r, times)
    damage = np.empty(hist.shape[:2])
    counts = np.empty(hist.shape[:2])
    for i in range(hist.shape[0]):
        for j in range(hist.shape[1]):
            cyc = count_cycles(hist[i, j])
            damage[i, j] = miner(cyc, law)
            counts[i, j] = cyc.total
    i, j = np.unravel_index(int(np.argmax(damage)), damage.shape)
    worst = float(damage[i, j])
    life = math.inf if worst == 0.0 else 1.0 / worst
    return FatigueMap(alpha=a, R=r, damage=damage, cycles=counts, max_damage=worst,
                      alpha_max=float(a[i]), R_max=float(r[j]), life=life)
