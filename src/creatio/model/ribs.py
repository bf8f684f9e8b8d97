"""The surface a finite set of ribs makes: a periodic quintic spline skin between N ribs.

N ribs at alpha_j = 2 pi j / N impose the exact radial profile along their lines; between
them the skin is the periodic quintic spline in alpha through the ribs' displacements (C4,
so the offset surface's third derivatives of W stay continuous). The spline is linear in its
data, so for W = A sin(u) cos(Ka alpha + phi_a) (docs/model.md s.1, s.14.4):

    W_N = A sin(u) [cos(phi_a) S_c(alpha) - sin(phi_a) S_s(alpha)]

with S_c, S_s the splines through cos(Ka alpha_j), sin(Ka alpha_j) (with rib errors, through
(1 + e_j) cos(Ka alpha_j + d_j) and (1 + e_j) sin(Ka alpha_j + d_j)): two fixed functions of
alpha. Exact ribs alias the wave into sum_m h_m cos((Ka + m N) alpha + phi_a), with the
closed form h_m = (Ka / (Ka + m N))^6 / sum_l (Ka / (Ka + l N))^6 of the cardinal spline.

Pure NumPy. A skin is handed to the compiled core as its table (:func:`skin_table`): one row
per interval [alpha_j, alpha_j+1), the power-basis coefficients of S_c then S_s in the local
coordinate x = (alpha - alpha_j) / h, h = 2 pi / N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from math import comb

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DEGREE",
    "NCOEF",
    "Ribs",
    "alias_amplitudes",
    "alias_spectrum",
    "check_rib_count",
    "periodic_quintic",
    "quintic_pieces",
    "rib_errors",
    "shape_error",
    "skin",
    "skin_jets",
    "skin_table",
    "spline_eval",
]

Array = NDArray[np.float64]

#: The spline degree (quintic: C4 at the ribs) and its coefficients per interval.
DEGREE = 5
NCOEF = DEGREE + 1


def check_rib_count(N: int, Ka: int) -> None:
    """ValueError unless N > 2 Ka: at N <= 2 Ka the ribs cannot carry a travelling wave (at
    N = 2 Ka every sample of sin(Ka alpha) vanishes)."""
    if int(N) != N or N < 1:
        raise ValueError(f"N must be a positive integer, got {N}")
    if not N > 2 * Ka:
        raise ValueError(f"N = {N} ribs cannot carry the travelling wave: N must be > 2 Ka = "
                         f"{2 * Ka}")


@dataclass(frozen=True)
class Ribs:
    """N ribs and their errors: each rib's relative amplitude error e_j and phase offset d_j
    (rad), empty for exact ribs."""

    N: int
    amplitude_errors: tuple[float, ...] = ()
    phase_errors: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if int(self.N) != self.N or self.N < 1:
            raise ValueError(f"N must be a positive integer, got {self.N}")
        for name in ("amplitude_errors", "phase_errors"):
            values = tuple(float(v) for v in getattr(self, name))
            if values and len(values) != self.N:
                raise ValueError(f"{name} needs one value per rib ({self.N}), got {len(values)}")
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"{name} must be finite, got {values}")
            object.__setattr__(self, name, values)

    def samples(self, Ka: int) -> tuple[Array, Array]:
        """The ribs' data (c_j, s_j): (1 + e_j) cos(Ka alpha_j + d_j), (1 + e_j) sin(...)."""
        alpha = 2.0 * np.pi * np.arange(self.N) / self.N
        arg = Ka * alpha
        if self.phase_errors:
            arg = arg + np.asarray(self.phase_errors)
        gain = 1.0 + np.asarray(self.amplitude_errors) if self.amplitude_errors else 1.0
        return gain * np.cos(arg), gain * np.sin(arg)

    def table(self, Ka: int) -> Array:
        """The skin's coefficient table for the compiled core (:func:`skin_table`)."""
        check_rib_count(self.N, Ka)
        return skin_table(*self.samples(Ka))


def quintic_pieces() -> Array:
    """(6, 6) matrix M: on [alpha_j, alpha_j+1) the spline sum_i c_i B((alpha - alpha_i) / h)
    is sum_p (sum_l M[l, p] c_{j+l-2}) x^p, from the centred cardinal quintic B-spline
    B(t) = (1/120) sum_k (-1)^k C(6, k) (t + 3 - k)_+^5 (exact rationals)."""
    M = np.zeros((NCOEF, NCOEF))
    for row, lo in enumerate(range(-2, 4)):
        for k in range(0, 4 - lo):
            shift = 3 - lo - k  # (x + shift)^5 over the whole interval
            for p in range(NCOEF):
                M[row, p] += (-1) ** k * comb(6, k) * comb(5, p) * shift ** (5 - p)
    return M / 120.0


def periodic_quintic(y: ArrayLike) -> Array:
    """(N, 6) power-basis coefficients (x^0 .. x^5, x = (alpha - alpha_j) / h) of the periodic
    quintic spline through y_j at alpha_j = 2 pi j / N: the B-spline coefficients solve the
    circulant system (c_{j-2} + 26 c_{j-1} + 66 c_j + 26 c_{j+1} + c_{j+2}) / 120 = y_j,
    whose symbol is >= 16 / 120, by FFT."""
    y = np.asarray(y, float)
    N = y.size
    kernel = np.zeros(N)
    for offset, w in ((0, 66.0), (1, 26.0), (-1, 26.0), (2, 1.0), (-2, 1.0)):
        kernel[offset % N] += w / 120.0
    c = np.fft.ifft(np.fft.fft(y) / np.fft.fft(kernel)).real
    window = np.stack([np.roll(c, 2 - row) for row in range(NCOEF)], axis=1)  # c_{j+row-2}
    return window @ quintic_pieces()


def skin_table(c: ArrayLike, s: ArrayLike) -> Array:
    """The table of the skin through the ribs' data c_j, s_j: (N, 12), row j the coefficients
    of S_c on interval j then those of S_s (C-contiguous, as the compiled core reads it)."""
    return np.ascontiguousarray(np.hstack([periodic_quintic(c), periodic_quintic(s)]))


def _locate(coef: Array, alpha: ArrayLike) -> tuple[NDArray[np.int64], Array, float]:
    """(interval index, local x in [0, 1), 1 / h) of angles alpha on a table of N rows."""
    N = coef.shape[0]
    q = np.asarray(alpha, float) * (N / (2.0 * np.pi))
    j = np.floor(q)
    return np.mod(j.astype(np.int64), N), q - j, N / (2.0 * np.pi)


def spline_eval(coef: ArrayLike, alpha: ArrayLike, order: int = 0) -> Array:
    """The order-th alpha derivative (0 to 5) of the spline with (N, 6) coefficients at
    alpha (any real: the spline is 2 pi periodic)."""
    coef = np.asarray(coef, float)
    j, x, inv_h = _locate(coef, alpha)
    c = coef[j]
    out = np.zeros_like(x)
    for p in range(DEGREE, order - 1, -1):  # Horner on the order-th derivative
        out = out * x + c[..., p] * (math.factorial(p) / math.factorial(p - order))
    return out * inv_h ** order


def skin(table: ArrayLike, phi_a: ArrayLike, alpha: ArrayLike, order: int = 0) -> Array:
    """H_N = cos(phi_a) S_c - sin(phi_a) S_s (the factor of A sin u in W_N), or its order-th
    alpha derivative; cos(Ka alpha + phi_a) on the ideal surface."""
    table = np.asarray(table, float)
    Sc = spline_eval(table[:, :NCOEF], alpha, order)
    Ss = spline_eval(table[:, NCOEF:], alpha, order)
    return np.cos(phi_a) * Sc - np.sin(phi_a) * Ss


def skin_jets(table: ArrayLike, alpha: ArrayLike, pa: ArrayLike, pa1: ArrayLike,
              pa2: ArrayLike) -> tuple[Array, ...]:
    """(H, H_a, H_t, H_aa, H_at, H_tt, H_aaa, H_aat, H_att): H_N and its partial derivatives
    in (alpha, t) up to those the offset surface reads, for phi_a with rates pa1, pa2.
    With G = sin(phi_a) S_c + cos(phi_a) S_s: H_t = -phi_a' G, H_tt = -phi_a'' G - phi_a'^2 H."""
    table = np.asarray(table, float)
    S = [(spline_eval(table[:, :NCOEF], alpha, n), spline_eval(table[:, NCOEF:], alpha, n))
         for n in range(4)]
    cp, sp = np.cos(pa), np.sin(pa)
    H = [cp * c - sp * s for c, s in S]
    G = [sp * c + cp * s for c, s in S]
    return (H[0], H[1], -pa1 * G[0], H[2], -pa1 * G[1], -pa2 * G[0] - pa1 * pa1 * H[0],
            H[3], -pa1 * G[2], -pa2 * G[1] - pa1 * pa1 * H[1])


def alias_amplitudes(N: int, Ka: int, m: ArrayLike) -> Array:
    """h_m of exact ribs: S_c + i S_s = sum_m h_m exp(i (Ka + m N) alpha), with
    h_m = (Ka / (Ka + m N))^6 / sum_l (Ka / (Ka + l N))^6 (the quintic cardinal spline's
    Fourier symbol, l summed over |l| <= 10^4: the tail is below 1e-20 relative)."""
    check_rib_count(N, Ka)
    lm = np.arange(-10_000, 10_001)
    total = np.sum(np.sort((Ka / (Ka + lm * N)) ** 6))  # small terms first
    m = np.asarray(m)
    return (Ka / (Ka + m * N)) ** 6 / total


def alias_spectrum(table: ArrayLike, Ka: int, M: int = 8, samples: int = 64) -> Array:
    """Complex amplitudes a_m, |m| <= M, of S_c + i S_s = sum a_m exp(i (Ka + m N) alpha)
    (+ the rest of the spectrum), from the FFT of the spline sampled at `samples` points per
    interval: h_m for exact ribs, and for ribs with errors the same series plus what the
    errors add at other wavenumbers."""
    table = np.asarray(table, float)
    N = table.shape[0]
    n = N * samples
    alpha = 2.0 * np.pi * np.arange(n) / n
    z = spline_eval(table[:, :NCOEF], alpha) + 1j * spline_eval(table[:, NCOEF:], alpha)
    spectrum = np.fft.fft(z) / n
    return spectrum[(Ka + np.arange(-M, M + 1) * N) % n]


def shape_error(N: int, Ka: int) -> float:
    """Relative RMS error over a turn of exact ribs' skin against the wave,
    ||H_N - cos(Ka alpha + phi_a)|| / ||cos(...)|| = sqrt((1 - h_0)^2 + sum_{m != 0} h_m^2),
    the same at every phi_a (the wavenumbers |Ka + m N| are distinct for N > 2 Ka)."""
    m = np.arange(-2000, 2001)
    h = alias_amplitudes(N, Ka, m)
    d = np.where(m == 0, 1.0 - h, h)
    return float(math.sqrt(np.sum(np.sort(d * d))))


def rib_errors(N: int, sigma_e: float, sigma_d: float, seed: int) -> tuple[Array, Array]:
    """Each rib's amplitude error e_j ~ Normal(0, sigma_e) and phase offset d_j ~ Normal(0,
    sigma_d) (rad), drawn in that order from numpy's default generator seeded by seed."""
    rng = np.random.default_rng(seed)
    return rng.normal(0.0, sigma_e, N), rng.normal(0.0, sigma_d, N)
