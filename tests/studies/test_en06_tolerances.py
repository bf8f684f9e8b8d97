"""EN-06's tolerances and tilt check (docs/materials.md s.8) at small sizes: the Sobol' path
against closed-form indices of a toy model run through it, the rows against direct EN-02
runs, the allocation's boundary against direct runs on each side of it (and the final
radius' exact shift with R0), the binomial interval against its closed forms and a Bernoulli
sample with a known fraction, the energy order under tilt, and the config's refusals."""

from __future__ import annotations

import copy
import math
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from scipy import stats

from creatio.errors import ConfigError
from creatio.pipeline.config import resolve, validate
from creatio.studies import budget as bd
from creatio.studies import en06
from creatio.studies import en06_tolerances as T
from creatio.studies import sphere as en02
from creatio.studies.en06_schema import En06Config, nominal_of
from creatio.studies.schema import vary

#: Small sizes for the real model (the defaults take about 10 minutes of one core).
SMALL = ["study.tolerances.sobol.base_sizes=[4]", "study.tolerances.joint.n=6",
         "study.tolerances.allocation.scan=2", "study.tolerances.allocation.iterations=6",
         "study.tolerances.allocation.azimuths=4"]

#: The toy's angle coefficient per input (deg per unit of the centred input u in [-1, 1]).
COEF = {"A": 0.1, "R0": 0.05, "b": 0.02, "beta": 0.15, "dR": 0.08, "psi": 0.0}


@pytest.fixture(scope="module")
def cfg() -> Any:
    """EN-06 at the small sizes."""
    return resolve("en06", SMALL).obj


def toy(cfg: Any) -> T.Model:
    """A closed-form stand-in for EN-02: with u the input centred and scaled to [-1, 1] on
    its declared interval, final angle = -330 + sum COEF u (additive: S1 = ST = COEF^2 /
    sum COEF^2), final radius = 1.11 + 0.01 u_A u_R0 (a pure interaction: S1 = 0, ST = 1
    for A and R0), carried iff u_b <= 0.5 (a function of b alone: S1 = ST = 1 for b, a
    fraction 3/4 carried), W_surface constant (no indices)."""
    dists = {d.key: (d.low, d.high) for d in T.distributions(cfg.study.tolerances, cfg.base)}
    names = {cfg.study.tolerances.inputs[n].key: n for n in cfg.study.tolerances.names}

    def model(changes: Mapping[str, float]) -> T.Transport:
        u = {}
        for key, (lo, hi) in dists.items():
            x = changes.get(key, nominal_of(cfg.base, key))
            u[names[key]] = (2.0 * x - lo - hi) / (hi - lo)
        angle = -330.0 + sum(COEF[n] * u[n] for n in u)
        return T.Transport(angle, 1.11 + 0.01 * u["A"] * u["R0"], 5e-6, u["b"] <= 0.5, "ok")
    return model


def toy_at(cfg: Any, c: float) -> T.Models:
    """The toy with a 'solver' error: at a rung its final angle is off by rtol x c x (1 +
    u_A) deg (u_A centred and scaled, as in toy), so an error from the nominal is
    rtol x c x u_A; rtol 0 is the toy itself."""
    exact = toy(cfg)
    dists = {d.key: (d.low, d.high) for d in T.distributions(cfg.study.tolerances, cfg.base)}

    def u(changes: Mapping[str, float], key: str) -> float:
        lo, hi = dists[key]
        return (2.0 * changes.get(key, nominal_of(cfg.base, key)) - lo - hi) / (hi - lo)

    def at(rung: bd.Rung) -> T.Model:
        def model(changes: Mapping[str, float]) -> T.Transport:
            t = exact(changes)
            e = rung.rtol * c
            return T.Transport(t.final_angle_deg + e * (1.0 + u(changes, "geometry.A")),
                               t.final_radius_m, t.surface_work_J, t.carried, t.status)
        return model
    return at


def test_budgeted_sobol_on_a_toy_solver_chooses_checks_and_agrees(cfg: Any) -> None:
    """The toy solver errs by 100 rtol |u_A| deg over a spread of about 0.12 deg: the pilot
    takes the loosest rung whose error against rtol 1e-10 on its 16 points is within half
    the budget there (1e-7), every row's error from the exact toy is within the recorded
    budget, and the indices equal the exact toy's within their bootstrap half-widths."""
    c = copy.deepcopy(cfg)
    c.study.tolerances.sobol.base_sizes = [256]
    c.study.tolerances.sobol.resamples = 200
    c.study.tolerances.budget.candidates = []  # one method: the toy costs alike in each
    ds = T.sobol_dataset(c, models=toy_at(c, 100.0))
    exact = T.sobol_dataset(c, toy(c))
    v = bd.Verification.from_attrs(ds.attrs)
    pilot = bd.subsample(ds.sizes["point"], 16, c.study.tolerances.budget.seed)
    a = list(ds.input.values).index("A")
    lo, hi = ds.input_low.values[a], ds.input_high.values[a]
    u_a = (2.0 * ds.input_value.values[pilot, a] - lo - hi) / (hi - lo)
    limit = bd.SAFETY * 1e-3 * np.std(exact.final_angle_error.values[pilot] + 1e-8 * u_a)
    want = max(r.rtol for r in c.study.tolerances.budget.rungs()
               if 100.0 * (r.rtol - 1e-10) * np.abs(u_a).max() <= limit)
    assert v.rung.rtol == want == 1e-7 and v.ok and v.tightened == 0
    assert v.budget["final_angle_error"] == pytest.approx(1e-3 * np.std(
        ds.final_angle_error.values), rel=1e-12)
    err = np.abs(ds.final_angle_error.values - exact.final_angle_error.values)
    assert err.max() <= v.budget["final_angle_error"]
    assert v.observed["final_angle_error"] <= err.max() + 1e-15
    assert ds.attrs["accuracy_line"].startswith("numerical error <= ")
    for key in ("S1", "ST"):
        j = list(ds.output.values).index("final_angle_error")
        diff = np.abs(ds[key].values[-1, j] - exact[key].values[-1, j])
        assert (diff <= exact[f"{key}_conf"].values[-1, j]).all(), (key, diff)


def test_a_loose_ladder_is_caught_tightened_and_reported(cfg: Any) -> None:
    """A ladder of one loose rung (rtol 1e-4, an error of 1e-2 deg against a budget of about
    1.2e-4): the pilot has no choice, the check breaks the budget, the part tightens 10x and
    reruns until it holds (1e-7: 1e-5 deg), records the count and the report says so."""
    from creatio.reports import en06_tolerances as R

    c = copy.deepcopy(cfg)
    c.study.tolerances.sobol.base_sizes = [64]
    c.study.tolerances.sobol.resamples = 200
    bgt = c.study.tolerances.budget
    bgt.loosest_rtol, bgt.rtol, bgt.atol, bgt.candidates = 1e-4, 1e-4, 1e-6, []
    ds = T.sobol_dataset(c, models=toy_at(c, 100.0))
    v = bd.Verification.from_attrs(ds.attrs)
    exact = T.sobol_dataset(c, toy(c))
    err = np.abs(ds.final_angle_error.values - exact.final_angle_error.values)
    assert v.ok and v.tightened >= 1 and v.rung.rtol == 1e-4 / 10**v.tightened
    assert err.max() <= v.budget["final_angle_error"]
    # one tightening fewer broke it: the error there (10x this one) exceeds the budget
    assert err.max() * 10 > v.budget["final_angle_error"]
    out: dict[str, Any] = {}
    R.SUMMARIES["sobol"](ds, out)
    text = "\n".join(R.section({"sobol": ds}, out, None))
    assert f"tightened {v.tightened} time(s) by 10x" in text and v.line() in text


def test_budgeted_joint_and_allocation_on_the_toy_match_the_exact_toy(cfg: Any) -> None:
    """Joint (400 draws) and allocation on the toy solver: the same count within spec as the
    exact toy, and every boundary within one bisection resolution of the exact toy's, with
    the check within its budget."""
    c = copy.deepcopy(cfg)
    c.study.tolerances.joint.n = 400
    c.study.tolerances.allocation.iterations = 12
    c.study.tolerances.budget.candidates = []
    models = toy_at(c, 100.0)
    ds, exact = T.joint_dataset(c, models=models), T.joint_dataset(c, toy(c))
    v = bd.Verification.from_attrs(ds.attrs)
    assert v.ok and v.budget == {"final_angle_error": 1e-2, "final_radius_error": 1e-4}
    assert int(ds.within_count) == int(exact.within_count)
    al, al0 = T.allocation_dataset(c, models=models), T.allocation_dataset(c, toy(c))
    v = bd.Verification.from_attrs(al.attrs)
    assert v.ok and v.points >= 2 and v.budget == {"boundary": 1e-2}
    res = al0.cap.values / c.study.tolerances.allocation.scan / 2.0**12
    on = al0.allocated.values == 1
    assert (np.abs(al.allocation.values - al0.allocation.values)[on] <= res[on]).all()


def test_sobol_path_gives_the_toy_closed_form_indices(cfg: Any) -> None:
    """The part's own path (EN-05's design, inverse CDFs and estimators) on the toy at
    N = 1024: each index within 3 bootstrap half-widths and 0.03 of the closed form, the
    constant output without indices, the smaller size a prefix of the design."""
    c = copy.deepcopy(cfg)
    c.study.tolerances.sobol.base_sizes = [256, 1024]
    c.study.tolerances.sobol.resamples = 200
    ds = T.sobol_dataset(c, toy(c))
    names = [str(n) for n in ds.input.values]
    total = sum(v * v for v in COEF.values())
    exact = {
        "final_angle_error": {n: (COEF[n] ** 2 / total,) * 2 for n in names},
        "final_radius_error": {n: (0.0, 1.0 if n in ("A", "R0") else 0.0) for n in names},
        "carried": {n: (1.0, 1.0) if n == "b" else (0.0, 0.0) for n in names},
    }
    for out, by in exact.items():
        j = list(ds.output.values).index(out)
        for m, n in enumerate(names):
            for key, want in zip(("S1", "ST"), by[n], strict=True):
                got = float(ds[key].values[-1, j, m])
                half = float(ds[f"{key}_conf"].values[-1, j, m])
                assert abs(got - want) <= max(3.0 * half, 1e-12), (out, n, key, got, half)
                assert abs(got - want) <= 0.03, (out, n, key, got)
    j = list(ds.output.values).index("surface_work")
    assert np.isnan(ds.S1.values[:, j]).all() and (ds.runs_missing.values[:, j] == 0).all()
    assert list(ds.runs.values) == [256 * 8, 1024 * 8]
    lo, hi = ds.input_low.values, ds.input_high.values
    assert ((ds.input_value.values >= lo) & (ds.input_value.values <= hi)).all()


@pytest.mark.long
def test_sobol_rows_are_direct_en02_runs(cfg: Any) -> None:
    """At N = 4 on EN-02 (32 runs) under the budget: two rows of the design rerun directly
    through sphere.run at the recorded method and tolerances give the same final angle,
    radius, W_surface and carried, from the nominal; every row agrees with the design run
    100x tighter within the recorded budget, and the indices with its within their
    bootstrap half-widths."""
    ds = T.sobol_dataset(cfg)
    assert ds.sizes["point"] == 4 * 8 and (ds.status.values == "ok").all()
    v = bd.Verification.from_attrs(ds.attrs)
    assert v.ok and v.points == 16 and ds.attrs["method"] == v.rung.method
    base = vary(cfg.base, v.rung.changes())
    tight = vary(cfg.base, v.rung.tighter().changes())
    ref = T.sobol_dataset(cfg, lambda ch: T.evaluate(tight, ch))
    for name in T.BUDGETED:
        assert np.abs(ds[name].values - ref[name].values).max() <= v.budget[name], name
    j = list(ds.output.values).index("final_angle_error")
    for key in ("S1", "ST"):
        diff = np.abs(ds[key].values[-1, j] - ref[key].values[-1, j])
        assert (diff <= ref[f"{key}_conf"].values[-1, j]).all(), key
    nom = en02.run(base, base.solver.dt)
    assert float(ds.nominal_final_angle) == float(nom.centre_azimuth.values[-1])
    for i in (0, 17):
        changes = {str(k): float(x) for k, x in zip(ds.input_key.values,
                                                     ds.input_value.values[i], strict=True)}
        run = en02.run(vary(base, changes), base.solver.dt)
        assert ds.final_angle_error.values[i] == (float(run.centre_azimuth.values[-1])
                                                  - float(nom.centre_azimuth.values[-1]))
        assert ds.final_radius_error.values[i] == (float(run.centre_radius.values[-1])
                                                   - float(nom.centre_radius.values[-1]))
        assert ds.surface_work.values[i] == float(run.surface_work.values[-1])
        assert ds.carried.values[i] == float(run.attrs["carried"])


def test_boundary_finds_a_known_threshold_to_its_resolution() -> None:
    """A step function at 0.3 on [0, 1]: inside <= 0.3 < outside, 2^-30 of a scan step
    apart; a cap within spec is returned capped; a second window within spec beyond the
    first failure is not reached (the scan stops at the first)."""
    b = T.boundary(lambda d: (d <= 0.3, 1), 1.0, 4, 30)
    assert b.inside <= 0.3 < b.outside and b.outside - b.inside == pytest.approx(0.25 / 2**30)
    assert not b.capped and b.runs == 2 + 30
    b = T.boundary(lambda d: (True, 2), 0.7, 5, 10)
    assert b.capped and b.inside == 0.7 and math.isnan(b.outside) and b.runs == 10
    b = T.boundary(lambda d: (d < 0.2 or d > 0.6, 1), 1.0, 4, 20)
    assert 0.2 - 0.25 / 2**20 <= b.inside < 0.2 <= b.outside


@pytest.mark.long
def test_allocation_boundary_is_confirmed_by_direct_runs(cfg: Any) -> None:
    """R0 and the tilt alone on EN-02 under the budget: each boundary within one bisection
    resolution of the search run 100x tighter; the allocated deviation is within spec and
    the first deviation out of spec is not, each rerun directly at the recorded method and
    tolerances (every azimuth when tilted); R0
    shifts the final radius by itself, so its allocation is the 1 cm spec to the search's
    resolution (cap / scan / 2^iterations)."""
    c = copy.deepcopy(cfg)
    tol = c.study.tolerances
    tol.inputs = {k: tol.inputs[k] for k in ("R0", "beta")}
    ds = T.allocation_dataset(c)
    v = bd.Verification.from_attrs(ds.attrs)
    assert v.ok and v.points == 3
    tight = vary(c.base, v.rung.tighter().changes())
    ref = T.allocation_dataset(c, lambda ch: T.evaluate(tight, ch))
    res = ds.cap.values / tol.allocation.scan / 2.0**tol.allocation.iterations
    on = ds.allocated.values == 1
    assert (np.abs(ds.allocation.values - ref.allocation.values)[on] <= res[on]).all()
    base, spec, al = vary(c.base, v.rung.changes()), tol.spec, tol.allocation
    nom = T.evaluate(base, {})

    def direct(name: str, sign: float, dev: float) -> bool:
        inp = tol.inputs[name]
        value = inp.value(nominal_of(base, inp.key), sign * dev)
        tilted = inp.key == "sphere.beta_deg" and value > 0
        psis = [360.0 * k / al.azimuths for k in range(al.azimuths)] if tilted else [None]
        return all(T.within_spec(T.errors(T.evaluate(
            base, {inp.key: value, **({"sphere.psi_deg": p} if p is not None else {})}), nom),
            spec) for p in psis)

    names = [str(n) for n in ds.input.values]
    checked = 0
    for i, name in enumerate(names):
        for j, sign in enumerate((-1.0, 1.0)):
            if not ds.allocated.values[i, j]:
                continue
            inside, outside = float(ds.allocation.values[i, j]), float(
                ds.first_outside.values[i, j])
            assert not ds.capped.values[i, j] and 0.0 < inside < outside
            assert direct(name, sign, inside) and not direct(name, sign, outside)
            checked += 1
    assert checked == 3  # R0 both sides, the tilt's plus side
    r0 = names.index("R0")
    step = 0.05 / al.scan / 2**al.iterations
    for j in range(2):
        assert 0.01 - step - 1e-8 <= ds.allocation.values[r0, j] <= 0.01 + 1e-8


@pytest.mark.parametrize(("k", "n"), [(0, 20), (7, 20), (20, 20), (731, 1000)])
def test_binomial_interval_matches_its_closed_forms(k: int, n: int) -> None:
    """Clopper-Pearson from the beta quantiles, Wilson from its score formula."""
    lo, hi = T.binomial_interval(k, n, 0.95, "exact")
    want_lo = 0.0 if k == 0 else stats.beta.ppf(0.025, k, n - k + 1)
    want_hi = 1.0 if k == n else stats.beta.ppf(0.975, k + 1, n - k)
    assert lo == pytest.approx(want_lo, rel=1e-9, abs=1e-15)
    assert hi == pytest.approx(want_hi, rel=1e-9, abs=1e-15)
    z, p = stats.norm.ppf(0.975), k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo, hi = T.binomial_interval(k, n, 0.95, "wilson")
    assert lo == pytest.approx(max(centre - half, 0.0), rel=1e-9, abs=1e-15)
    assert hi == pytest.approx(min(centre + half, 1.0), rel=1e-9, abs=1e-15)


@pytest.mark.parametrize("p", [0.05, 0.3, 0.75])
def test_exact_interval_covers_the_true_fraction_at_its_level(p: float) -> None:
    """The probability that the exact interval of a Bernoulli(p) sample of 120 holds p, summed
    exactly over every count k (binomial weights), is at least 95 % (Clopper-Pearson is
    conservative); Wilson's stays within 3 points of it."""
    n = 120
    weights = stats.binom.pmf(np.arange(n + 1), n, p)
    for method, floor in (("exact", 0.95), ("wilson", 0.92)):
        held = np.array([lo <= p <= hi for lo, hi in (T.binomial_interval(k, n, 0.95, method)
                                                     for k in range(n + 1))])
        assert float(np.sum(weights[held])) >= floor, method


def test_joint_part_holds_the_true_fraction_of_the_toy(cfg: Any) -> None:
    """The joint part on the toy (within spec exactly when u_b <= 0.5, fraction 3/4): the
    count equals the draws with b in the lower three quarters of its interval, and the
    exact 95 % interval of 2000 draws holds 3/4."""
    c = copy.deepcopy(cfg)
    c.study.tolerances.joint.n = 2000
    ds = T.joint_dataset(c, toy(c))
    b = list(ds.input.values).index("b")
    x = ds.input_value.values[:, b]
    lo, hi = float(ds.input_low.values[b]), float(ds.input_high.values[b])
    expected = int(np.sum((2.0 * x - lo - hi) / (hi - lo) <= 0.5))
    assert int(ds.within_count) == expected
    assert float(ds.interval_low) <= 0.75 <= float(ds.interval_high)
    assert ds.attrs["interval_method"] == "Clopper-Pearson (exact)"


def test_tilt_check_residuals_fall_at_fourth_order(cfg: Any) -> None:
    """The part's residuals are those of EN-02 run directly at dt, dt/2, dt/4 under the
    tilt; each halving's observed order near RK4's 4."""
    ds = T.tilt_dataset(cfg)
    tc, base = cfg.study.tilt_check, cfg.base
    for i, dt in enumerate((0.002, 0.001, 0.0005)):
        run = en02.run(vary(base, tc.changes(dt)), dt)
        assert ds.energy_residual.values[i] == run.attrs["max_energy_residual"]
    assert ds.attrs["scheme_order"] == 4
    assert all(3.5 < p < 5.0 for p in ds.observed_order.values)
    assert abs(float(ds.observed_order.values[-1]) - 4.0) < 0.5


def test_parts_include_the_tolerances(cfg: Any) -> None:
    """One part per dataset, in report order."""
    assert [p.name for p in en06.parts(cfg)] == [
        "en06_strain", "en06_fatigue", "en06_tilt", "en06_sobol", "en06_allocation",
        "en06_joint", "en06_ribs"]


@pytest.mark.parametrize(("override", "key", "rule"), [
    ("study.tolerances.inputs.R0.minus=-0.001", "study.tolerances.inputs.R0.minus",
     "must be >= 0"),
    ("study.tolerances.inputs.R0.cap=[0.001,0.05]", "study.tolerances.inputs.R0.cap[0]",
     "must be 0 (not allocated) or >= the declared tolerance"),
    ("study.tolerances.inputs.A.cap=[1.5,0.5]", "study.tolerances.inputs.A.cap[0]",
     "refused by en02"),
    ("study.tolerances.inputs.beta.cap=[0,95]", "study.tolerances.inputs.beta.cap[1]",
     "must lie in [0, 90)"),
    ("study.tolerances.inputs.psi.cap=[0,10]", "study.tolerances.inputs.psi.cap",
     "must be [0, 0]"),
    ("study.tolerances.inputs.R0.key=geometry.R9", "study.tolerances.inputs.R0.key",
     "must name a number"),
    ("study.tolerances.inputs.b.plus=inf", "study.tolerances.inputs.b.plus",
     "must be a finite number"),
    ("study.tolerances.sobol.base_sizes=[100]", "study.tolerances.sobol.base_sizes[0]",
     "power of 2"),
    ("study.tolerances.sobol.base_sizes=[65536]", "study.tolerances.sobol.base_sizes",
     "more than 200,000"),
    ("study.tolerances.sobol.resamples=10000000", "study.tolerances.sobol.resamples",
     "more than 2,000,000"),
    ("study.tolerances.joint.n=0", "study.tolerances.joint.n", "must be >= 1"),
    ("study.tolerances.joint.n=1000000", "study.tolerances.joint.n", "more than 200,000"),
    ("study.tolerances.joint.confidence=1.5", "study.tolerances.joint.confidence",
     "must lie in (0, 1)"),
    ("study.tolerances.allocation.iterations=61", "study.tolerances.allocation.iterations",
     "must lie in [1, 60]"),
    ("study.tolerances.allocation.azimuths=10000000", "study.tolerances.allocation.azimuths",
     "more than 200,000"),
    ("study.tolerances.spec.radius_m=0", "study.tolerances.spec.radius_m", "must be > 0"),
    ("study.tilt_check.beta_deg=0", "study.tilt_check.beta_deg", "must lie in (0, 90)"),
    ("study.tolerances.budget.points=8", "study.tolerances.budget.points", "must be >= 16"),
    ("study.tolerances.budget.method=rk4", "study.tolerances.budget.method",
     "must be an adaptive method"),
    ("study.tolerances.budget.candidates=[dop853,rk4]",
     "study.tolerances.budget.candidates[1]", "must be an adaptive method"),
    ("study.tolerances.budget.loosest_rtol=1e-10", "study.tolerances.budget.loosest_rtol",
     "must be >= rtol"),
    ("study.tolerances.budget.sobol_fraction=2", "study.tolerances.budget.sobol_fraction",
     "must lie in (0, 1]"),
    ("study.tilt_check.cycle_s=1e9", "study.tilt_check.cycle_s", "more than 2,000,000"),
    ("study.tilt_check.cycle_s=nan", "study.tilt_check.cycle_s", "must be a finite number"),
])
def test_bad_values_are_refused_in_one_line(override: str, key: str, rule: str) -> None:
    """Each is refused as the pipeline validates the config (the default's data with the
    value set): one line naming the key, the value and the rule, before anything runs."""
    dotted, _, text = override.partition("=")
    data = copy.deepcopy(resolve("en06").data)
    *path, name = dotted.split(".")
    node = data
    for part in path:
        node = node[part]
    node[name] = float(text) if text in ("nan", "inf") else yaml.safe_load(text)
    with pytest.raises(ConfigError) as err:
        validate(data, schema=En06Config)
    message = str(err.value)
    assert "\n" not in message and err.value.key == key, message
    assert rule in message


@pytest.mark.parametrize("override", ["study.tolerances.joint.n=abc",
                                      "study.tolerances.joint.interval=normal"])
def test_a_wrong_type_is_refused_in_one_line(override: str) -> None:
    """A value of the wrong type or kind names its key."""
    with pytest.raises(ConfigError) as err:
        resolve("en06", [override])
    assert "\n" not in str(err.value) and override.split("=")[0] in str(err.value)


@pytest.mark.long
def test_the_cli_refuses_a_bad_tolerance_in_one_line_and_writes_nothing(tmp_path: Path
                                                                         ) -> None:
    """creatio run with a bad tolerance: exit 2, one line naming the key, nothing written."""
    proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en06",
                           "study.tolerances.inputs.dR.minus=-1"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "study.tolerances.inputs.dR.minus" in lines[0] and "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []
