"""Radau IIA coefficients for s = 3, 5, 7 stages (orders 5, 9, 13), computed, not typed.

Everything follows from the collocation nodes (Hairer & Wanner, Solving ODEs II, IV.5 and
IV.8): the nodes c are the roots of d^(s-1)/dx^(s-1) [x^(s-1) (x - 1)^s] (c_s = 1); A is
the integral of the Lagrange basis over them, A[i, j] = int_0^c_i l_j, and b its last row.
The simplified Newton iteration of the implicit stepper block-diagonalises A^-1 = T L T^-1
into one real eigenvalue and (s - 1) / 2 complex pairs; the error estimate is Hairer's
embedded formula of order s (a weight gamma_0 = 1 / mu_real on f(t, y)); the dense output is
the collocation polynomial through (0, 0) and (c_i, Z_i).

Why extended precision: in float64 the nodes from the companion matrix of the node
polynomial are off by 1.3e-12 at s = 7 (3e-16 at s = 3) and A then by 1e-11 (measured), and
the eigenvector matrix T has condition 1136 (entries of T^-1 up to 300). So the work is
done in the standard library's decimal arithmetic (60 digits; the polynomial's rational
coefficients exact through fractions; float64 values only as starting guesses for Newton
polishing) and each number is rounded once to float64: the constants are the correctly
rounded values of the exact ones. All three methods cost about 40 ms, once per process.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from decimal import Decimal, localcontext
from fractions import Fraction

import numpy as np
from numpy.typing import NDArray

__all__ = ["STAGES", "RadauIIA", "coefficients", "pade_denominator", "pade_numerator",
           "stability_function"]

#: The stage counts of the variable-order stepper (orders 2 s - 1 = 5, 9, 13).
STAGES = (3, 5, 7)

_DIGITS = 60


@dataclass(frozen=True)
class RadauIIA:
    """One Radau IIA method, as float64 arrays rounded once from 60-digit values.

    mu_real is the real eigenvalue of A^-1 (Hairer's u1); mu_complex[k] is the shift of the
    k-th complex linear system, (mu / h - J) X = r, and T's columns 2k+1, 2k+2 are the real
    and imaginary parts of the eigenvector of A^-1 for conj(mu_complex[k]), so that
    T^-1 A^-1 T has the blocks [[Re mu, -Im mu], [Im mu, Re mu]]. Pairs are ordered by
    increasing real part (Hairer's order). ``normalisation`` is the convention: "last" (every
    eigenvector has last component 1, Im mu < 0: scipy's radau.py and creatio's 3-stage
    constants) or "hairer" (the real eigenvector of unit 2-norm, the complex ones with last
    component 1, Im mu > 0: radau.f's COERTV and COERCV). e weighs Z / h in the error estimate
    (mu_real / h - J)^-1 (f(t, y) + sum_i e_i Z_i / h) (Hairer's DD), and p gives the
    collocation polynomial u(t + x h) = y + sum_i Z_i sum_k p[i, k] x^(k + 1).
    """

    s: int
    c: NDArray[np.float64]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    a_inv: NDArray[np.float64]
    mu_real: float
    mu_complex: NDArray[np.complex128]
    t: NDArray[np.float64]
    ti: NDArray[np.float64]
    e: NDArray[np.float64]
    p: NDArray[np.float64]
    normalisation: str

    @property
    def order(self) -> int:
        """Classical order of the step: 2 s - 1 (B(2s-1), C(s), D(s-1))."""
        return 2 * self.s - 1

    @property
    def stage_order(self) -> int:
        """Order of the stages and of the collocation polynomial's local error, minus one."""
        return self.s

    @property
    def error_order(self) -> int:
        """Order of the embedded formula behind the error estimate (its local error is
        O(h^(s + 1)), which sets the controller's exponent 1 / (s + 1))."""
        return self.s


# ---------------------------------------------------------------------------- exact pieces


def _node_polynomial(s: int) -> list[Fraction]:
    """Coefficients (lowest degree first) of d^(s-1)/dx^(s-1) [x^(s-1) (x - 1)^s], exact."""
    # x^(s-1) (x-1)^s = sum_k binom(s, k) (-1)^(s-k) x^(s-1+k)
    poly = [Fraction(0)] * (2 * s)
    for k in range(s + 1):
        poly[s - 1 + k] = Fraction(math.comb(s, k) * (-1) ** (s - k))
    for _ in range(s - 1):
        poly = [poly[d] * d for d in range(1, len(poly))]
    return poly


def pade_numerator(s: int) -> list[Fraction]:
    """P(z) of the (s-1, s) Pade approximant of exp, lowest degree first, exact: with
    pade_denominator, the stability function of s-stage Radau IIA (Hairer & Wanner II,
    IV.3 and IV.5), a check independent of the tableau."""
    k, j = s - 1, s
    return [Fraction(math.factorial(k + j - m) * math.factorial(k),
                     math.factorial(k + j) * math.factorial(m) * math.factorial(k - m))
            for m in range(k + 1)]


def pade_denominator(s: int) -> list[Fraction]:
    """Q(z) of the (s-1, s) Pade approximant of exp, lowest degree first (exact)."""
    k, j = s - 1, s
    return [Fraction(math.factorial(k + j - m) * math.factorial(j) * (-1) ** m,
                     math.factorial(k + j) * math.factorial(m) * math.factorial(j - m))
            for m in range(j + 1)]


# -------------------------------------------------------------- decimal helpers (real/complex)


def _D(x: float | int | Fraction) -> Decimal:
    if isinstance(x, Fraction):
        return Decimal(x.numerator) / Decimal(x.denominator)
    return Decimal(x)


def _horner(poly: list[Decimal], x: Decimal) -> Decimal:
    acc = Decimal(0)
    for coef in reversed(poly):
        acc = acc * x + coef
    return acc


def _roots_01(poly: list[Fraction], s: int) -> list[Decimal]:
    """The s real roots of poly in (0, 1], float64 guesses polished by Newton in decimal."""
    guesses = np.sort(np.polynomial.polynomial.polyroots([float(q) for q in poly]).real)
    pd = [_D(q) for q in poly]
    dpd = [pd[d] * d for d in range(1, len(pd))]
    tol = Decimal(10) ** (-(_DIGITS - 8))
    roots = []
    for g in guesses:
        x = Decimal(float(g))
        for _ in range(100):
            dx = _horner(pd, x) / _horner(dpd, x)
            x -= dx
            if abs(dx) <= tol * max(abs(x), Decimal(1)):
                break
        else:  # pragma: no cover - a well-separated simple root always converges
            raise ArithmeticError(f"Radau node polishing did not converge (s={s})")
        roots.append(x)
    roots.sort()
    roots[-1] = Decimal(1)  # exactly a root: (x - 1) divides the polynomial
    return roots


def _poly_mul_linear(poly: list[Decimal], root: Decimal) -> list[Decimal]:
    """poly(x) (x - root), lowest degree first."""
    out = [Decimal(0)] * (len(poly) + 1)
    for d, q in enumerate(poly):
        out[d + 1] += q
        out[d] -= q * root
    return out


def _lagrange(nodes: list[Decimal], j: int) -> list[Decimal]:
    """Coefficients of the Lagrange basis polynomial of nodes[j] over nodes."""
    poly = [Decimal(1)]
    denom = Decimal(1)
    for m, cm in enumerate(nodes):
        if m != j:
            poly = _poly_mul_linear(poly, cm)
            denom *= nodes[j] - cm
    return [q / denom for q in poly]


def _solve(mat: list[list], rhs: list[list]) -> list[list]:
    """Gauss-Jordan with partial pivoting over any field type (Decimal or _C): mat X = rhs."""
    n = len(mat)
    a = [row[:] + r[:] for row, r in zip(mat, rhs, strict=True)]
    m = len(a[0])
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(a[i][k]))
        a[k], a[p] = a[p], a[k]
        piv = a[k][k]
        a[k] = [v / piv for v in a[k]]
        for i in range(n):
            if i != k:
                f = a[i][k]
                a[i] = [a[i][q] - f * a[k][q] for q in range(m)]
    return [row[n:] for row in a]


class _C:
    """A complex number over Decimal (the decimal module has none)."""

    __slots__ = ("re", "im")

    def __init__(self, re: Decimal, im: Decimal = Decimal(0)) -> None:
        self.re = re
        self.im = im

    def __add__(self, o: _C) -> _C:
        return _C(self.re + o.re, self.im + o.im)

    def __sub__(self, o: _C) -> _C:
        return _C(self.re - o.re, self.im - o.im)

    def __mul__(self, o: _C) -> _C:
        return _C(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)

    def __truediv__(self, o: _C) -> _C:
        d = o.re * o.re + o.im * o.im
        return _C((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)

    def __abs__(self) -> Decimal:
        return (self.re * self.re + self.im * self.im).sqrt()


def _eigenpair(m: list[list[Decimal]], lam0: complex) -> tuple[_C, list[_C]]:
    """Eigenvalue near lam0 of m and its eigenvector with last component 1, by Newton on
    (m - lam I) v = 0 over (v_1 .. v_{s-1}, lam), started from float64 values."""
    s = len(m)
    mf = np.array([[float(x) for x in row] for row in m])
    w, v = np.linalg.eig(mf)
    k = int(np.argmin(np.abs(w - lam0)))
    vec = v[:, k] / v[-1, k]
    lam = _C(Decimal(float(w[k].real)), Decimal(float(w[k].imag)))
    x = [_C(Decimal(float(q.real)), Decimal(float(q.imag))) for q in vec[:-1]]
    tol = Decimal(10) ** (-(_DIGITS - 8))
    one = _C(Decimal(1))
    for _ in range(100):
        vv = [*x, one]
        res = []
        for i in range(s):
            acc = _C(Decimal(0))
            for j in range(s):
                acc = acc + _C(m[i][j]) * vv[j]
            res.append(acc - lam * vv[i])
        jac = []
        for i in range(s):
            row = []
            for j in range(s - 1):
                row.append(_C(m[i][j]) - (lam if i == j else _C(Decimal(0))))
            row.append(_C(Decimal(0)) - vv[i])
            jac.append(row)
        delta = _solve(jac, [[_C(Decimal(0)) - r] for r in res])
        step = max(abs(d[0]) for d in delta)
        x = [xi + d[0] for xi, d in zip(x, delta[:-1], strict=True)]
        lam = lam + delta[-1][0]
        if step <= tol:
            break
    else:  # pragma: no cover - a simple eigenvalue always converges from float64
        raise ArithmeticError("Radau eigenvector polishing did not converge")
    return lam, [*x, one]


def _f(x: Decimal) -> float:
    """Round once to float64 (Decimal -> float is correctly rounded)."""
    return float(x)


# --------------------------------------------------------------------------- the methods


@functools.cache
def coefficients(s: int, normalisation: str = "last") -> RadauIIA:
    """The s-stage Radau IIA method (s odd, 1 <= s <= 9), see :class:`RadauIIA`."""
    if s % 2 != 1 or not 1 <= s <= 9:
        raise ValueError(f"Radau IIA stages: s={s}: must be odd, 1..9")
    if normalisation not in ("last", "hairer"):
        raise ValueError(f"normalisation={normalisation!r}: must be 'last' or 'hairer'")
    with localcontext() as ctx:
        ctx.prec = _DIGITS
        c = _roots_01(_node_polynomial(s), s)
        # A[i, j] = int_0^{c_i} l_j(x) dx
        a = [[Decimal(0)] * s for _ in range(s)]
        for j in range(s):
            lj = _lagrange(c, j)
            integral = [Decimal(0)] + [q / (d + 1) for d, q in enumerate(lj)]
            for i in range(s):
                a[i][j] = _horner(integral, c[i])
        b = a[-1][:]
        eye = [[Decimal(int(i == j)) for j in range(s)] for i in range(s)]
        ainv = _solve(a, eye)
        # eigenvalues of A^-1: one real, (s-1)/2 pairs; float64 guesses, then polished
        w = np.linalg.eigvals(np.array([[float(x) for x in row] for row in ainv]))
        real = [x for x in w if abs(x.imag) < 1e-8 * abs(x)]
        pairs = sorted((x for x in w if x.imag > 1e-8 * abs(x)), key=lambda z: z.real)
        if len(real) != 1 or len(pairs) != (s - 1) // 2:  # pragma: no cover
            raise ArithmeticError(f"Radau IIA s={s}: unexpected spectrum {w}")
        lam_r, v_r = _eigenpair(ainv, complex(real[0].real, 0.0))
        mu_real = lam_r.re
        cols = [[vi.re for vi in v_r]]
        if normalisation == "hairer":
            norm = sum(q * q for q in cols[0]).sqrt()
            cols[0] = [q / norm for q in cols[0]]
        mus = []
        for z in pairs:
            # T's columns from the eigenvector of one eigenvalue of the pair, the solve
            # shifted by the other (see RadauIIA): scipy's (and creatio's) convention takes
            # alpha + i beta for T, radau.f's alpha - i beta
            target = complex(z) if normalisation == "last" else complex(z).conjugate()
            lam, vec = _eigenpair(ainv, target)
            cols.append([vi.re for vi in vec])
            cols.append([vi.im for vi in vec])
            mus.append(complex(_f(lam.re), -_f(lam.im)))
        t = [[cols[k][i] for k in range(s)] for i in range(s)]
        ti = _solve(t, eye)
        # Hairer's embedded formula of order s: weight gamma_0 = 1 / mu_real on f(t, y),
        # bhat on the stages; e = mu_real (bhat - b)^T A^-1 weighs Z / h
        gamma0 = 1 / mu_real
        vander = [[c[i] ** k for i in range(s)] for k in range(s)]
        rhs = [[Decimal(1) / (k + 1) - (gamma0 if k == 0 else 0)] for k in range(s)]
        bhat = [r[0] for r in _solve(vander, rhs)]
        e = [mu_real * sum((bhat[i] - b[i]) * ainv[i][j] for i in range(s)) for j in range(s)]
        # collocation polynomial: Lagrange basis over (0, c_1 .. c_s), without the node 0
        nodes0 = [Decimal(0), *c]
        p = []
        for i in range(s):
            li = _lagrange(nodes0, i + 1)
            p.append(li[1:])
    arr = functools.partial(np.array, dtype=np.float64)
    return RadauIIA(
        s=s,
        c=arr([_f(x) for x in c]),
        a=arr([[_f(x) for x in row] for row in a]),
        b=arr([_f(x) for x in b]),
        a_inv=arr([[_f(x) for x in row] for row in ainv]),
        mu_real=_f(mu_real),
        mu_complex=np.array(mus, dtype=np.complex128),
        t=arr([[_f(x) for x in row] for row in t]),
        ti=arr([[_f(x) for x in row] for row in ti]),
        e=arr([_f(x) for x in e]),
        p=arr([[_f(x) for x in row] for row in p]),
        normalisation=normalisation,
    )


def stability_function(method: RadauIIA, z: NDArray | complex) -> NDArray[np.complex128]:
    """R(z) = 1 + z b^T (I - z A)^-1 1 of the method's float64 tableau, at each z."""
    zz = np.atleast_1d(np.asarray(z, dtype=np.complex128))
    s = method.s
    out = np.empty(zz.shape, dtype=np.complex128)
    one = np.ones(s)
    for k, zk in np.ndenumerate(zz):
        if np.isinf(zk):
            # R(inf) = 1 - b^T A^-1 1
            out[k] = 1.0 - method.b @ np.linalg.solve(method.a, one)
        else:
            out[k] = 1.0 + zk * (method.b @ np.linalg.solve(np.eye(s) - zk * method.a, one))
    return out
