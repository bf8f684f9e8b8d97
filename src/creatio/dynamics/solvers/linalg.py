"""Small dense linear algebra for the implicit stepper, compiled (no LAPACK call overhead)."""

from __future__ import annotations

from creatio.dynamics.jit import njit

__all__ = ["lu_factor", "lu_solve"]


@njit(cache=True)
def lu_factor(a, piv):
    """In-place LU factorisation with partial pivoting (real or complex square matrix);
    False when a pivot is exactly zero (singular: the factors must not be used)."""
    n = a.shape[0]
    ok = True
    for k in range(n):
        p = k
        best = abs(a[k, k])
        for i in range(k + 1, n):
            v = abs(a[i, k])
            if v > best:
                best = v
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[p, j]
                a[p, j] = tmp
        d = a[k, k]
        if d == 0.0:
            ok = False
            continue
        for i in range(k + 1, n):
            a[i, k] /= d
            lik = a[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= lik * a[k, j]
    return ok


@njit(cache=True)
def lu_solve(a, piv, b):
    """Solve in place a x = b with the factors of lu_factor (b overwritten by x)."""
    n = a.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]
