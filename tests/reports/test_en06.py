"""EN-06's report on the tolerance and tilt parts: the contract keys of ``tilt_check`` and
``tolerances`` hold the datasets' values, the answer line names the joint fraction and the
tightest allocation, the sections and the figure are written. The tolerance datasets come
from the parts' own functions on a closed-form toy transport (the study's tests check the
numbers against EN-02); the tilt dataset is EN-02's own."""

from __future__ import annotations

import copy
import json
from collections.abc import Mapping
from typing import Any

import pytest

from creatio.pipeline.config import resolve
from creatio.reports.en06 import write_report
from creatio.store.netcdf import write_dataset
from creatio.studies import en06_tolerances as T
from creatio.studies.budget import Rung, Verification
from creatio.studies.en06_schema import nominal_of


def _toy(cfg: Any) -> T.Model:
    """Final angle and radius linear in R0 (0.5 deg and 1 m per m of R0), carried always:
    R0's allocation is 1 cm on each side, every other input capped."""
    x0 = nominal_of(cfg.base, "geometry.R0")

    def model(changes: Mapping[str, float]) -> T.Transport:
        d = changes.get("geometry.R0", x0) - x0
        return T.Transport(-330.0 + 50.0 * d, 1.11 + d, 5e-6 + 1e-4 * d, True, "ok")
    return model


def _toy_at(cfg: Any) -> T.Models:
    """The toy with a 'solver' error at a rung: the final angle off by 1e3 rtol per m of
    R0's deviation (5 rtol deg at the declared tolerance)."""
    model, x0 = _toy(cfg), nominal_of(cfg.base, "geometry.R0")

    def at(rung: Rung) -> T.Model:
        def run(changes: Mapping[str, float]) -> T.Transport:
            t = model(changes)
            d = changes.get("geometry.R0", x0) - x0
            return T.Transport(t.final_angle_deg + 1e3 * rung.rtol * d, t.final_radius_m,
                               t.surface_work_J, t.carried, t.status)
        return run
    return at


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], dict, dict]:
    """The four parts (tolerances on the toy, the tilt check on EN-02) and their report."""
    cfg = copy.deepcopy(resolve("en06", ["study.tolerances.sobol.base_sizes=[16,32]",
                                         "study.tolerances.sobol.resamples=100",
                                         "study.tolerances.joint.n=50",
                                         "study.tolerances.allocation.iterations=12"]).obj)
    cfg.study.tolerances.budget.candidates = []  # one method: the toy costs alike in each
    models = _toy_at(cfg)
    parts = {"tilt": T.tilt_dataset(cfg), "sobol": T.sobol_dataset(cfg, models=models),
             "allocation": T.allocation_dataset(cfg, models=models),
             "joint": T.joint_dataset(cfg, models=models)}
    tmp = tmp_path_factory.mktemp("en06")
    files = []
    for name, ds in parts.items():
        ds = ds.copy()
        ds.attrs.update({"study": "en06", "title": "EN-06 test", "config_sha256": "0" * 64})
        files.append(write_dataset(ds, tmp / f"en06_{name}.nc"))
    paths = write_report(files, tmp / "reports")
    return json.loads(paths["json"].read_text()), parts, paths


def test_tilt_check_contract(report: tuple[dict[str, Any], dict, dict]) -> None:
    """tilt_check: the three residuals and the finest pair's order, as the dataset holds."""
    s, parts, _ = report
    t, ds = s["tilt_check"], parts["tilt"]
    assert t["energy_residual_J"] == [float(v) for v in ds.energy_residual.values]
    assert t["order"] == float(ds.observed_order.values[-1]) and t["scheme_order"] == 4


def test_tolerances_contract(report: tuple[dict[str, Any], dict, dict]) -> None:
    """sobol.<output>.{S1, S1_conf, ST, ST_conf} at the largest N (0 for an input the toy
    ignores); allocation.<input>.{minus, plus, cap} (R0 at 1 cm to the bisection's
    resolution, the tilt one-sided); joint.{n, fraction_within_spec, interval_95}."""
    s, parts, _ = report
    tol = s["tolerances"]
    sob = parts["sobol"]
    inputs = [str(n) for n in sob.input.values]
    for j, out in enumerate(str(o) for o in sob.output.values):
        assert set(tol["sobol"][out]) == {"S1", "S1_conf", "ST", "ST_conf"}
        for m, n in enumerate(inputs):
            got = tol["sobol"][out]["ST"][n]
            want = float(sob.ST.values[-1, j, m])
            assert got == want or (got is None and want != want)
    for key in ("S1", "ST"):  # the toy ignores dR: both estimators vanish term by term
        assert tol["sobol"]["final_radius_error"][key]["dR"] == 0.0
    r0 = tol["allocation"]["R0"]
    resolution = 0.05 / 8 / 2**12
    for side in ("minus", "plus"):
        assert 0.01 - resolution <= r0[side] <= 0.01 + 1e-15  # rounding of x0 + d - x0
    assert r0["cap"] == [0.05, 0.05]
    beta = tol["allocation"]["beta"]
    assert beta["minus"] is None and beta["capped"] == [None, True]
    assert "psi" not in tol["allocation"]
    joint = tol["joint"]
    assert joint["n"] == 50 and joint["fraction_within_spec"] == 1.0
    lo, hi = joint["interval_95"]
    assert hi == 1.0 and lo == pytest.approx(0.025 ** (1 / 50), rel=1e-9)  # k = n: exact


def test_answer_sections_and_figure(report: tuple[dict[str, Any], dict, dict]) -> None:
    """The opening names the joint fraction and the tightest allocation (R0, 2 x its declared
    5 mm); the tilt and tolerance sections and the figure are there."""
    s, _, paths = report
    text = paths["md"].read_text()
    head = "\n".join(text.splitlines()[:8])
    assert "100 % of 50 transports stay within spec" in head
    assert "tightest allocation is R0 (geometry.R0)" in head
    assert "## Energy identity under a mounting tilt" in text
    assert "### Tolerance allocation" in text and "### Joint Monte Carlo" in text
    assert "Clopper-Pearson" in text
    assert paths["tolerances"].stat().st_size > 10_000
    assert list(s)[:1] == ["study"] and list(s).index("tilt_check") < list(s).index(
        "tolerances")


def test_accuracy_budgets_reach_the_report(report: tuple[dict[str, Any], dict, dict]
                                          ) -> None:
    """tolerances.accuracy.<part> holds each dataset's check, and each section prints its
    line. The toy errs by up to 5 rtol deg in the angle: the Sobol' budget (1e-3 of the
    angle's spread, 50 x 5 mm / sqrt(3) deg, halved by the pilot: 7.2e-5) takes rtol 1e-5;
    the joint's (0.01 deg) and the allocation's (R0's boundary is the radius') the loosest."""
    s, parts, paths = report
    text = paths["md"].read_text()
    for part in ("sobol", "allocation", "joint"):
        v = Verification.from_attrs(parts[part].attrs)
        a = s["tolerances"]["accuracy"][part]
        assert a["line"] == v.line() and a["ok"] and a["tightened"] == 0
        want = 1e-5 if part == "sobol" else 1e-4
        assert (part, a["method"], a["rtol"]) == (part, "radau5", want)
        assert a["line"].startswith("numerical error <= ") and a["line"] in text
        assert all(a["observed"][k] <= a["budget"][k] for k in a["budget"])
    assert s["tolerances"]["accuracy"]["joint"]["budget"] == {
        "final_angle_error": 0.01, "final_radius_error": 1e-4}
    assert s["tolerances"]["accuracy"]["allocation"]["points"] == 2  # R0's two sides


@pytest.mark.long
def test_rib_part_reaches_the_report(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """The rib part through the study's own entry (study.ribs at a small size): en06.json's
    ``ribs`` is the section of its dataset, the answer names the fewest ribs within spec, the
    refused count's reason names the bound, and both figures are written and linked."""
    from creatio.reports.en06_ribs import ribs_section
    from creatio.studies.en06 import run

    cfg = resolve("en06", ["study.ribs.counts=[18,36]", "study.ribs.seeds=3",
                           "study.ribs.errors_N=24"]).obj
    ds = run(cfg, "ribs").copy()
    ds.attrs.update({"study": "en06", "title": "EN-06 test", "config_sha256": "0" * 64})
    paths = write_report([write_dataset(ds, tmp_path / "en06_ribs.nc")], tmp_path / "reports")
    s = json.loads(paths["json"].read_text())
    assert s["ribs"] == json.loads(json.dumps(ribs_section(ds)))
    assert [c["N"] for c in s["ribs"]["cases"]] == [18, 36]
    assert "2 Ka = 12" in s["ribs"]["refused"][0]["reason"]
    md = paths["md"].read_text()
    for name in ("en06_ribs_transport.png", "en06_rib_errors.png"):
        assert (tmp_path / "reports" / name).stat().st_size > 10_000
        assert f"({name})" in md
    fewest = s["ribs"]["smallest_N_within_spec"]
    assert (f"{fewest} ribs are the fewest" if fewest else "no rib count") in md
