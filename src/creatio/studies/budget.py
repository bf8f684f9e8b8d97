"""Accuracy budgets: each ensemble, fit and search runs at the cheapest method and tolerance
its answer needs, chosen by a short pilot and verified on a seeded subsample, never assumed.

A computation declares its budget in its answer's own terms (docs/accuracy.md):

* Sobol' outputs: numerical error <= 1e-3 of each output's standard deviation over the
  sample (:func:`sobol_budget`);
* a fit: model error <= 1e-2 of the measurement noise (:func:`noise_budget`);
* a boundary search: <= 1e-2 of the bisection's resolution (:func:`resolution_budget`).

It hands a function ``run(rung, idx)`` that runs the points ``idx`` (indices into its sample)
at a :class:`Rung` (method, rtol, atol) and returns one array per output, aligned with idx
along the first axis. :func:`choose` runs a pilot subsample at every rung of a
:func:`ladder` from the loosest and at a reference 100x tighter than the tightest, and picks
the loosest rung whose error is within SAFETY of the budget; :func:`verify` reruns a seeded
subsample of the finished run at 100x tighter tolerances and records the largest observed
error beside the budget (:class:`Verification`); :func:`budgeted` does both, and when the
budget is broken tightens 10x, reruns every point and says so (``tightened``).

The numerical error of a point is measured against the same method at 100x tighter
tolerances: for a method whose global error is proportional to its tolerance that
reference's own error is 1 % of the run's, so the difference is the run's error to 1 %.
Pure numpy: the studies' modules and their tests import it without xarray or Hydra.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

__all__ = ["SAFETY", "TIGHTER", "Rung", "Runner", "Verification", "budgeted", "cheapest",
           "choose",
           "errors", "fixed", "ladder", "noise_budget", "resolution_budget", "sobol_budget",
           "subsample", "verify"]

#: The pilot's safety factor: a rung is chosen when its pilot error is <= SAFETY x budget,
#: since the pilot's few points need not hold the sample's worst one.
SAFETY = 0.5
#: How much tighter than the run the verification's reference is.
TIGHTER = 100.0

#: run(rung, idx): the points idx run at rung, one array per output aligned with idx.
Runner = Callable[["Rung", np.ndarray], Mapping[str, np.ndarray]]


def _round(x: float) -> float:
    """x to 12 significant digits: 1e-8 / 10 is 1e-9, not 1.0000000000000001e-09."""
    return float(f"{x:.12g}")


@dataclass(frozen=True)
class Rung:
    """One integration setting of a budget's ladder: the solver's method and tolerances."""

    method: str
    rtol: float
    atol: float

    def overrides(self) -> list[str]:
        """The Hydra overrides that select this setting (solver group, rtol, atol)."""
        return [f"solver={self.method}", f"solver.rtol={self.rtol!r}",
                f"solver.atol={self.atol!r}"]

    def changes(self) -> dict[str, Any]:
        """The dotted keys that select this setting in a validated config (schema.vary)."""
        return {"solver.method": self.method, "solver.rtol": self.rtol,
                "solver.atol": self.atol}

    def tighter(self, factor: float = TIGHTER) -> Rung:
        """The same method with both tolerances divided by factor."""
        return Rung(self.method, _round(self.rtol / factor), _round(self.atol / factor))

    def label(self) -> str:
        """A short human label: ``radau5 rtol=1e-06 atol=1e-08``."""
        return f"{self.method} rtol={self.rtol:.3g} atol={self.atol:.3g}"


def ladder(reference: Rung, loosest_rtol: float, step: float = 10.0) -> list[Rung]:
    """The rungs from loosest_rtol down to the reference by factors of step (atol scaled with
    rtol), loosest first, the reference last: the pilot's candidates."""
    if not (loosest_rtol > 0.0 and step > 1.0):
        raise ValueError(f"ladder: loosest_rtol={loosest_rtol} must be > 0 and step={step} > 1")
    k = max(0, math.floor(math.log(loosest_rtol / reference.rtol) / math.log(step) + 1e-9))
    return [Rung(reference.method, _round(reference.rtol * step**i),
                 _round(reference.atol * step**i)) for i in range(k, -1, -1)]


def _finite(a: np.ndarray) -> np.ndarray:
    """The finite values of a, flattened."""
    a = np.asarray(a, dtype=float).ravel()
    return a[np.isfinite(a)]


def sobol_budget(Y: Mapping[str, np.ndarray], fraction: float = 1e-3) -> dict[str, float]:
    """fraction x each output's standard deviation over the sample (finite values); an output
    constant over the sample gets 0, which marks it unchecked (it has no indices)."""
    out = {}
    for name, y in Y.items():
        v = _finite(y)
        s = float(np.std(v)) if v.size > 1 else 0.0
        out[name] = fraction * s if s > 0.0 else 0.0
    return out


def noise_budget(noise: float, fraction: float = 1e-2) -> float:
    """A fit's budget: fraction x the measurement noise (its standard deviation)."""
    return fraction * float(noise)


def resolution_budget(resolution: float, fraction: float = 1e-2) -> float:
    """A boundary search's budget: fraction x the resolution the bisection reports."""
    return fraction * float(resolution)


def fixed(value: float) -> Callable[[Mapping[str, np.ndarray]], dict[str, float]]:
    """A budget_of giving every output the same budget (a noise's or a resolution's)."""
    return lambda Y: {name: float(value) for name in Y}


def subsample(n: int, size: int = 16, seed: int = 0) -> np.ndarray:
    """size distinct indices of range(n), sorted, drawn by seed; all of them if n <= size."""
    if n <= size:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, size=size, replace=False))


def errors(rows: Mapping[str, np.ndarray], reference: Mapping[str, np.ndarray],
           names: Sequence[str] | None = None) -> dict[str, float]:
    """The largest absolute difference per output between rows and reference (over points
    and any further axes); inf where one is finite and the other is not."""
    out = {}
    for name in names if names is not None else list(reference):
        a = np.asarray(rows[name], dtype=float)
        b = np.asarray(reference[name], dtype=float)
        fa, fb = np.isfinite(a), np.isfinite(b)
        same = (a == b) | (np.isnan(a) & np.isnan(b))
        if np.any((fa != fb) | (~fa & ~same)):
            out[name] = math.inf
            continue
        d = np.abs(a[fa] - b[fa])
        out[name] = float(d.max()) if d.size else 0.0
    return out


def _within(err: Mapping[str, float], budget: Mapping[str, float], factor: float) -> bool:
    """Every output with a positive budget has err <= factor x budget."""
    return all(err[k] <= factor * b for k, b in budget.items() if b > 0.0)


def _fmt(x: float) -> str:
    """A number for a line of text: two significant digits."""
    return f"{x:.2g}"


@dataclass(frozen=True)
class Verification:
    """The checked accuracy of a finished computation: per output the budget and the largest
    error observed on points reruns at reference (100x tighter than rung); tightened counts
    the 10x tightenings a broken budget needed."""

    budget: dict[str, float]
    observed: dict[str, float]
    points: int
    seed: int
    rung: Rung
    reference: Rung
    tightened: int = 0

    @property
    def checked(self) -> list[str]:
        """The outputs with a positive budget (a constant output has none)."""
        return [k for k, b in self.budget.items() if b > 0.0]

    @property
    def ok(self) -> bool:
        """Every checked output's observed error is within its budget."""
        return _within(self.observed, self.budget, 1.0)

    def worst(self) -> str | None:
        """The checked output with the largest observed error relative to its budget."""
        checked = self.checked
        if not checked:
            return None
        return max(checked, key=lambda k: self.observed[k] / self.budget[k])

    def _text(self, name: str) -> str:
        """The required sentence for one output."""
        return (f"numerical error <= {_fmt(self.observed[name])} "
                f"(budget {_fmt(self.budget[name])}, checked on {self.points} points)")

    def line(self) -> str:
        """"numerical error <= X (budget Y, checked on N points)" for the worst output."""
        name = self.worst()
        if name is None:
            return f"no output varies over the sample (checked on {self.points} points)"
        return self._text(name)

    def lines(self) -> list[str]:
        """One line per output, named: ``final_angle_error: numerical error <= ...``."""
        return [f"{k}: " + (self._text(k) if self.budget[k] > 0.0 else
                            "constant over the sample, not checked") for k in self.budget]

    def describe(self) -> str:
        """The line with the worst output, the setting and any tightening, for a report."""
        name = self.worst()
        text = self.line() + (f" in {name}" if name else "") + f", at {self.rung.label()}"
        if self.tightened:
            text += f"; budget broken at first, tightened {self.tightened} time(s) by 10x"
        if not self.ok:
            text += "; BUDGET BROKEN"
        return text

    def attrs(self, prefix: str = "accuracy_") -> dict[str, str | float | int]:
        """Flat netCDF attributes (strings and scalars) from which :meth:`from_attrs` reads
        this back."""
        out: dict[str, str | float | int] = {
            f"{prefix}method": self.rung.method, f"{prefix}rtol": self.rung.rtol,
            f"{prefix}atol": self.rung.atol, f"{prefix}reference_method": self.reference.method,
            f"{prefix}reference_rtol": self.reference.rtol,
            f"{prefix}reference_atol": self.reference.atol, f"{prefix}points": self.points,
            f"{prefix}seed": self.seed, f"{prefix}tightened": self.tightened,
            f"{prefix}ok": int(self.ok), f"{prefix}outputs": ",".join(self.budget),
            f"{prefix}line": self.line()}
        for k in self.budget:
            out[f"{prefix}budget_{k}"] = float(self.budget[k])
            out[f"{prefix}observed_{k}"] = float(self.observed[k])
        return out

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, Any], prefix: str = "accuracy_") -> Verification:
        """The Verification written by :meth:`attrs` (KeyError naming the missing key)."""
        def get(key: str) -> Any:
            if prefix + key not in attrs:
                raise KeyError(f"{prefix}{key}: no accuracy budget recorded under this prefix")
            return attrs[prefix + key]
        names = [k for k in str(get("outputs")).split(",") if k]
        return cls(budget={k: float(get(f"budget_{k}")) for k in names},
                   observed={k: float(get(f"observed_{k}")) for k in names},
                   points=int(get("points")), seed=int(get("seed")),
                   rung=Rung(str(get("method")), float(get("rtol")), float(get("atol"))),
                   reference=Rung(str(get("reference_method")), float(get("reference_rtol")),
                                  float(get("reference_atol"))),
                   tightened=int(get("tightened")))


def choose(run: Runner, rungs: Sequence[Rung], points: np.ndarray,
           budget_of: Callable[[Mapping[str, np.ndarray]], Mapping[str, float]]) -> Rung:
    """The first rung, in order, whose error on the pilot points is <= SAFETY x the budget,
    against the last rung 100x tighter (budget_of takes the reference's outputs); the last
    rung when none is. One ladder (loosest first): its loosest within budget; several
    methods' ladders one after another: the methods in order of preference."""
    if not rungs:
        raise ValueError("choose: no rungs to choose from")
    reference = run(rungs[-1].tighter(TIGHTER), points)
    budget = dict(budget_of(reference))
    for rung in rungs[:-1]:
        if _within(errors(run(rung, points), reference, list(budget)), budget, SAFETY):
            return rung
    return rungs[-1]


def cheapest(run: Runner, rungs: Sequence[Rung], points: np.ndarray,
             budget_of: Callable[[Mapping[str, np.ndarray]], Mapping[str, float]]) -> Rung:
    """Among several methods' ladders (rungs grouped by method, each loosest first), the rung
    within SAFETY x the budget whose pilot took the least CPU time: per method its loosest
    within budget, against the last rung 100x tighter (budget_of takes its outputs); each
    method is warmed on one point first (loading its compiled loop is not its cost); the
    last rung when none is."""
    if not rungs:
        raise ValueError("cheapest: no rungs to choose from")
    reference = run(rungs[-1].tighter(TIGHTER), points)
    budget = dict(budget_of(reference))
    best: tuple[float, Rung] | None = None
    for method in dict.fromkeys(r.method for r in rungs):
        ladder_ = [r for r in rungs if r.method == method]
        run(ladder_[0], points[:1])
        for rung in ladder_:
            t0 = time.process_time()
            out = run(rung, points)
            cost = time.process_time() - t0
            if _within(errors(out, reference, list(budget)), budget, SAFETY):
                if best is None or cost < best[0]:
                    best = (cost, rung)
                break
    return rungs[-1] if best is None else best[1]


def verify(run: Runner, rows: Mapping[str, np.ndarray], rung: Rung,
           budget: Mapping[str, float], seed: int, size: int = 16) -> Verification:
    """Rerun a seeded subsample of rows (computed at rung) 100x tighter and record the largest
    error per budgeted output beside its budget."""
    n = len(next(iter(rows.values())))
    idx = subsample(n, size, seed)
    reference = rung.tighter(TIGHTER)
    tight = run(reference, idx)
    names = list(budget)
    observed = errors({k: np.asarray(rows[k])[idx] for k in names}, tight, names)
    return Verification(budget={k: float(budget[k]) for k in names}, observed=observed,
                        points=int(idx.size), seed=seed, rung=rung, reference=reference)


def budgeted(run: Runner, n: int, rungs: Sequence[Rung],
             budget_of: Callable[[Mapping[str, np.ndarray]], Mapping[str, float]],
             seed: int, size: int = 16, max_tighten: int = 3, by_cost: bool = False,
             ) -> tuple[dict[str, np.ndarray], Verification]:
    """All n points at the rung a pilot (subsample seed) chooses (:func:`choose`, or
    :func:`cheapest` by_cost among several methods), verified on another subsample
    (seed + 1) against the budget of the full rows; a broken budget tightens the rung 10x
    and reruns every point, at most max_tighten times (then ``ok`` is False)."""
    pick = cheapest if by_cost else choose
    rung = pick(run, rungs, subsample(n, size, seed), budget_of)
    everything = np.arange(n)
    tightened = 0
    while True:
        rows = {k: np.asarray(v) for k, v in run(rung, everything).items()}
        check = verify(run, rows, rung, budget_of(rows), seed + 1, size)
        if check.ok or tightened >= max_tighten:
            return rows, replace(check, tightened=tightened)
        rung = rung.tighter(10.0)
        tightened += 1
