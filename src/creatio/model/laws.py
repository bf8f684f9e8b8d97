"""Phase and inclination laws of time, each with closed-form first and second derivatives.

Every law is one case of the general form (angles in radians, t in seconds)

    phi(t) = phi0 + rate * t + delta * s(clip(t / T, 0, 1)) + amplitude * sin(omega * t)

where s is the step of the law's kind, travelled over one cycle of length T: the quintic
smooth step s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5 (s(0) = 0, s(1) = 1, s' and s'' vanish at
both ends, so clamping keeps the law C2), or for the cosine ramp s(tau) = (1 - cos(pi tau)) / 2
(s' vanishes at both ends, s'' does not: the clamped law is C1), or for the trapezoid the
constant-acceleration step of :func:`trapezoid_step` (the law is C1, its acceleration jumps
at three times). The kinds of docs/model.md s.2 are the special cases:

* constant:     phi0
* linear:       phi0 + rate t
* quintic:      phi0 + delta s(t / T)          (starts and stops at zero speed)
* cosine_ramp:  phi0 + delta (1 - cos(pi t / T)) / 2 on [0, T], held after
* sinusoid:     phi0 + amplitude sin(omega t)  (the inclination law gamma0 + G sin(Omega t))
* trapezoid:    phi0 + delta s(t / T): constant acceleration for the fraction ``ramp`` of the
                cycle, cruise, the mirror deceleration to rest at T (a triangle at ramp = 1/2)

A law's plain-number form is its coefficient vector (:meth:`Law.coefficients`, laid out by
the L_* indices below): the six coefficients of the general form and the kind's code, which
says which step delta travels along. :func:`law_eval` evaluates that vector at one time in
scalar code, which the compiled dynamics core (creatio.dynamics) compiles as it is, and
each step is written once there: the vectorised steps apply that scalar code element by
element (:func:`step_of`; the quintic's NumPy twin, :func:`quintic_step`, says why it is the
exception). A new kind is its step in that scalar code, its code, and the coefficients its
config uses (creatio.studies.schema).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "KIND_CODES",
    "L_AMPLITUDE",
    "L_DELTA",
    "L_KIND",
    "L_OMEGA",
    "L_PHI0",
    "L_RAMP",
    "L_RATE",
    "L_T",
    "NLAW",
    "QUINTIC_CODES",
    "Law",
    "LawKind",
    "LawValue",
    "cosine_step",
    "law_eval",
    "quintic_step",
    "step_of",
    "trapezoid_on_grid",
    "trapezoid_scalar",
    "trapezoid_step",
    "unit_coefficients",
]


class LawKind(StrEnum):
    """Which special case of the general law is meant (validation uses it)."""

    constant = "constant"
    linear = "linear"
    quintic = "quintic"
    sinusoid = "sinusoid"
    cosine_ramp = "cosine_ramp"
    trapezoid = "trapezoid"


#: The coefficient vector of a law: the terms of the general form, the kind's code, and the
#: trapezoid's ramp fraction (0 for every other kind).
(L_PHI0, L_RATE, L_DELTA, L_T, L_AMPLITUDE, L_OMEGA, L_KIND, L_RAMP) = range(8)
NLAW = 8

#: The code of each kind in the coefficient vector (its position in LawKind).
KIND_CODES: dict[LawKind, int] = {kind: code for code, kind in enumerate(LawKind)}
#: The cosine ramp's code: delta travels the cosine step instead of the quintic one.
COSINE_RAMP = KIND_CODES[LawKind.cosine_ramp]
#: The trapezoid's code: delta travels the trapezoid step of ramp fraction L_RAMP.
TRAPEZOID = KIND_CODES[LawKind.trapezoid]
#: The codes whose delta travels the quintic step through its NumPy twin (quintic_step: the
#: quintic itself, and the kinds without a step of their own, whose delta is 0); every other
#: kind, a new one included, gets the step law_eval computes (step_of), with no list to edit.
QUINTIC_CODES = frozenset(KIND_CODES[k] for k in (LawKind.constant, LawKind.linear,
                                                   LawKind.quintic, LawKind.sinusoid))
#: How close (in tau) to a switch of the trapezoid a time is taken to be on it.
SWITCH_TOL = 1e-12


@dataclass(frozen=True)
class LawValue:
    """A law evaluated at times t: value, first and second time derivatives."""

    value: NDArray[np.float64]
    d1: NDArray[np.float64]
    d2: NDArray[np.float64]


def quintic_step(tau: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """Return s, ds/dtau, d2s/dtau2 of the quintic smooth step, clamped outside [0, 1].

    The one step written twice: here in NumPy and in :func:`law_eval`'s scalar code. The two
    round s' differently (30 x^2 (1 - x)^2 here, 30 x x (1 - x) (1 - x) there: 44,695 of the
    120,001 values of EN-01's 1 ms grid differ in their last bit), and the kinematic datasets
    (EN-01's pattern rate) hold this one's bits while the dynamics datasets hold law_eval's,
    so deriving either from the other changes one family of datasets in the last bit. The
    test of law_eval against this function holds them to rounding."""
    tau = np.asarray(tau, dtype=float)
    inside = (tau > 0.0) & (tau < 1.0)
    x = np.clip(tau, 0.0, 1.0)
    s = x * x * x * (10.0 - 15.0 * x + 6.0 * x * x)
    ds = np.where(inside, 30.0 * x * x * (1.0 - x) ** 2, 0.0)
    dds = np.where(inside, 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x), 0.0)
    return s, ds, dds


def cosine_step(tau: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """Return s, ds/dtau, d2s/dtau2 of the cosine step (1 - cos(pi tau)) / 2 on the closed
    interval [0, 1], held outside it. Its second derivative jumps by pi^2 / 2 at both ends;
    there the ramp's own one-sided value is taken (docs/model.md s.2). Derived from the
    scalar formula of :func:`law_eval` (:func:`step_of`)."""
    return step_of(LawKind.cosine_ramp, tau)


def trapezoid_scalar(tau: float, r: float) -> tuple[float, float, float]:
    """s, ds/dtau, d2s/dtau2 of the trapezoid step at one tau (:func:`trapezoid_step`): the
    segment's values, on a switch the mean s''."""
    k = 1.0 / (r * (1.0 - r))
    if tau <= 0.0:
        return 0.0, 0.0, k if tau == 0.0 else 0.0
    if tau >= 1.0:
        return 1.0, 0.0, -0.5 * k if tau - 1.0 <= SWITCH_TOL else 0.0
    if tau < r:
        s = 0.5 * k * tau * tau
        ds = k * tau
    elif tau <= 1.0 - r:
        s = (tau - 0.5 * r) / (1.0 - r)
        ds = 1.0 / (1.0 - r)
    else:
        om = 1.0 - tau
        s = 1.0 - 0.5 * k * om * om
        ds = k * om
    if abs(tau - r) <= SWITCH_TOL:
        dds = 0.5 * k if r < 0.5 else 0.0
    elif abs(tau - (1.0 - r)) <= SWITCH_TOL or 1.0 - tau <= SWITCH_TOL:
        dds = -0.5 * k
    elif tau < r:
        dds = k
    elif tau < 1.0 - r:
        dds = 0.0
    else:
        dds = -k
    return s, ds, dds


def trapezoid_step(tau: ArrayLike, ramp: float) -> tuple[NDArray, NDArray, NDArray]:
    """Return s, ds/dtau, d2s/dtau2 of the trapezoid step of ramp fraction r in (0, 1/2]:
    s'' = 1 / (r (1 - r)) on (0, r), 0 on the cruise (r, 1 - r), -1 / (r (1 - r)) on
    (1 - r, 1), so s(1) = 1 and s' = 1 / (1 - r) at the cruise. Held outside [0, 1].

    The acceleration jumps at tau = r, 1 - r and 1; on a switch (within SWITCH_TOL) it is the
    mean of its two sides, so a fixed-step Runge-Kutta step that ends on it and the next
    that starts on it make errors of opposite sign that cancel to first order; at tau = 0,
    where a run starts, it is the ramp's own value."""
    return step_of(LawKind.trapezoid, tau, ramp)


def unit_coefficients(kind: LawKind, ramp: float = 0.0) -> tuple[float, ...]:
    """The coefficient vector of phi(t) = s(t), the bare step of kind (delta 1, T 1, every
    other term 0; ramp: the trapezoid's fraction), so :func:`law_eval` of it at tau is the
    step's (s, ds/dtau, d2s/dtau2) at tau, bit for bit."""
    c = [0.0] * NLAW
    c[L_DELTA] = 1.0
    c[L_T] = 1.0
    c[L_KIND] = float(KIND_CODES[kind])
    c[L_RAMP] = ramp
    return tuple(c)


def step_of(kind: LawKind, tau: ArrayLike, ramp: float = 0.0
            ) -> tuple[NDArray, NDArray, NDArray]:
    """s, ds/dtau, d2s/dtau2 of kind's step at every tau (any shape): the scalar formula of
    :func:`law_eval`, the one the compiled core runs, applied element by element, so the
    vectorised step is that formula's and never a second copy of it."""
    tau = np.asarray(tau, dtype=float)
    c = unit_coefficients(kind, ramp)
    out = np.array([law_eval(c, x) for x in tau.ravel().tolist()], dtype=float)
    out = out.reshape((*tau.shape, 3))
    return out[..., 0], out[..., 1], out[..., 2]


def trapezoid_on_grid(delta: float, peak_rate: float, acceleration: float, dt: float = 0.0
                      ) -> tuple[float, float, float, float]:
    """(T, ramp, peak rate, acceleration) of the trapezoid travelling delta with the rate
    limit peak_rate and the acceleration a_max (magnitudes > 0): ramp time peak / a_max and
    T = |delta| / peak + peak / a_max, or the triangle T = 2 sqrt(|delta| / a_max) when the
    peak is not reached. With dt > 0 the ramp time and T are rounded to the nearest
    multiples of dt (the switch times land on steps) and the peak rate and acceleration that
    travel delta exactly on those times are returned instead of the ones asked for."""
    if not (peak_rate > 0.0 and acceleration > 0.0 and delta != 0.0):
        raise ValueError(f"trapezoid needs peak rate and acceleration > 0 and a travel, got "
                         f"{peak_rate}, {acceleration}, {delta}")
    D = abs(delta)
    t_a = peak_rate / acceleration
    if acceleration * t_a * t_a >= D:
        t_a = math.sqrt(D / acceleration)
        T = 2.0 * t_a
    else:
        T = D / peak_rate + t_a
    if dt > 0.0:
        n_a = max(1, round(t_a / dt))
        n_T = max(2 * n_a, round(T / dt))
        t_a, T = n_a * dt, n_T * dt
    peak = D / (T - t_a)
    return T, t_a / T, peak, peak / t_a


@dataclass(frozen=True)
class Law:
    """A time law phi(t) in radians; see the module docstring for the general form."""

    phi0: float = 0.0
    rate: float = 0.0
    delta: float = 0.0
    T: float = 1.0
    amplitude: float = 0.0
    omega: float = 0.0
    kind: LawKind = LawKind.constant
    #: the trapezoid's acceleration time as a fraction of T, in (0, 1/2] (0 for other kinds)
    ramp: float = 0.0

    def __post_init__(self) -> None:
        if not self.T > 0.0:
            raise ValueError(f"law cycle length T must be > 0, got {self.T}")
        if self.kind is LawKind.trapezoid and not 0.0 < self.ramp <= 0.5:
            raise ValueError(f"trapezoid ramp fraction must be in (0, 1/2], got {self.ramp}")

    @classmethod
    def constant(cls, phi0: float) -> Law:
        """phi(t) = phi0."""
        return cls(phi0=phi0, kind=LawKind.constant)

    @classmethod
    def linear(cls, phi0: float, rate: float) -> Law:
        """phi(t) = phi0 + rate t."""
        return cls(phi0=phi0, rate=rate, kind=LawKind.linear)

    @classmethod
    def quintic(cls, phi0: float, delta: float, T: float) -> Law:
        """phi(t) = phi0 + delta s(t / T), the smooth step over one cycle of length T."""
        return cls(phi0=phi0, delta=delta, T=T, kind=LawKind.quintic)

    @classmethod
    def cosine_ramp(cls, phi0: float, delta: float, T: float) -> Law:
        """phi(t) = phi0 + delta (1 - cos(pi t / T)) / 2 over one cycle of length T."""
        return cls(phi0=phi0, delta=delta, T=T, kind=LawKind.cosine_ramp)

    @classmethod
    def trapezoid(cls, phi0: float, delta: float, T: float, ramp: float) -> Law:
        """phi(t) = phi0 + delta s(t / T) along the trapezoid step of ramp fraction ramp."""
        return cls(phi0=phi0, delta=delta, T=T, kind=LawKind.trapezoid, ramp=ramp)

    @classmethod
    def sinusoid(cls, phi0: float, amplitude: float, omega: float) -> Law:
        """phi(t) = phi0 + amplitude sin(omega t)."""
        return cls(phi0=phi0, amplitude=amplitude, omega=omega, kind=LawKind.sinusoid)

    def coefficients(self) -> NDArray[np.float64]:
        """The coefficient vector (phi0, rate, delta, T, amplitude, omega, kind code)."""
        c = np.empty(NLAW)
        c[L_PHI0] = self.phi0
        c[L_RATE] = self.rate
        c[L_DELTA] = self.delta
        c[L_T] = self.T
        c[L_AMPLITUDE] = self.amplitude
        c[L_OMEGA] = self.omega
        c[L_KIND] = KIND_CODES[self.kind]
        c[L_RAMP] = self.ramp
        return c

    def scalar(self, t: float) -> tuple[float, float, float]:
        """Value, first and second derivative at one time t, by the compiled formula
        (:func:`law_eval`)."""
        return law_eval(self.coefficients(), t)

    def step(self, tau: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
        """s, ds/dtau, d2s/dtau2 of the step this law's delta travels along: the scalar
        formula of :func:`law_eval` element by element (:func:`step_of`), the quintic's by
        its NumPy twin :func:`quintic_step` (see there why it has one)."""
        if KIND_CODES[self.kind] in QUINTIC_CODES:
            return quintic_step(tau)
        return step_of(self.kind, tau, self.ramp)

    def switch_times(self) -> tuple[float, ...]:
        """The times at which the acceleration jumps (the trapezoid's ramp ends and T)."""
        if self.kind is not LawKind.trapezoid or self.delta == 0.0:
            return ()
        return (self.ramp * self.T, (1.0 - self.ramp) * self.T, self.T)

    def __call__(self, t: ArrayLike) -> LawValue:
        """Evaluate value, first and second derivative at times t (any shape)."""
        t = np.asarray(t, dtype=float)
        s, ds, dds = self.step(t / self.T)
        wt = self.omega * t
        sin_wt, cos_wt = np.sin(wt), np.cos(wt)
        value = self.phi0 + self.rate * t + self.delta * s + self.amplitude * sin_wt
        d1 = self.rate + self.delta * ds / self.T + self.amplitude * self.omega * cos_wt
        d2 = self.delta * dds / self.T**2 - self.amplitude * self.omega**2 * sin_wt
        return LawValue(value, d1 + 0.0 * t, d2 + 0.0 * t)

    def bounds(self) -> tuple[float, float]:
        """Lower and upper bound of phi over t >= 0: exact for each special kind, safe else."""
        lo = hi = self.phi0
        if self.rate > 0.0:
            hi = np.inf
        elif self.rate < 0.0:
            lo = -np.inf
        lo, hi = lo + min(0.0, self.delta), hi + max(0.0, self.delta)
        swing = abs(self.amplitude) if self.omega != 0.0 else 0.0
        return lo - swing, hi + swing


def law_eval(c, t: float) -> tuple[float, float, float]:
    """Value, first and second time derivative at one time t of the law whose coefficient
    vector (:meth:`Law.coefficients`, a tuple or an array) is c.

    Scalar code with no NumPy, so the dynamics layer compiles this very function into its
    loops (creatio.dynamics.jit registers it and :func:`trapezoid_scalar`); terms with a zero
    coefficient are skipped (no trigonometry for a law without a sinusoid). The trapezoid's
    step is a call of its own: inlined here, it made the quintic's RK4 loop about 8 % slower
    (bench_against, median of 11 paired rounds 1.083, against 0.975 with the call). Agrees
    with :class:`Law` to rounding.
    """
    rate = c[L_RATE]
    delta = c[L_DELTA]
    amplitude = c[L_AMPLITUDE]
    value = c[L_PHI0] + rate * t
    d1 = rate
    d2 = 0.0
    if delta != 0.0:
        T = c[L_T]
        tau = t / T
        if c[L_KIND] == TRAPEZOID:
            s, ds, dds = trapezoid_scalar(tau, c[L_RAMP])
        elif c[L_KIND] == COSINE_RAMP:
            # the closed interval [0, 1]: at its ends the ramp's one-sided acceleration
            if tau < 0.0:
                s = 0.0
                ds = 0.0
                dds = 0.0
            elif tau > 1.0:
                s = 1.0
                ds = 0.0
                dds = 0.0
            else:
                x = math.pi * tau
                s = 0.5 - 0.5 * math.cos(x)
                ds = 0.5 * math.pi * math.sin(x)
                dds = 0.5 * math.pi * math.pi * math.cos(x)
        elif tau <= 0.0:
            s = 0.0
            ds = 0.0
            dds = 0.0
        elif tau >= 1.0:
            s = 1.0
            ds = 0.0
            dds = 0.0
        else:
            s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau)
            om = 1.0 - tau
            ds = 30.0 * tau * tau * om * om
            dds = 60.0 * tau * om * (1.0 - 2.0 * tau)
        value += delta * s
        d1 += delta * ds / T
        d2 += delta * dds / (T * T)
    if amplitude != 0.0:
        omega = c[L_OMEGA]
        sw = math.sin(omega * t)
        cw = math.cos(omega * t)
        value += amplitude * sw
        d1 += amplitude * omega * cw
        d2 -= amplitude * omega * omega * sw
    return value, d1, d2

