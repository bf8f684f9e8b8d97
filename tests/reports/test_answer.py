"""Every report opens with its answer (issue 34): under the title, three to five plain-word
lines (what was computed, the answer, what it rests on) holding the figures of the report's
own JSON, before any table of keys. The kinematic reports put a unit on every number; EN-04
says why its robustness rows for the sphere's mass are equal, and shows no arrival for a
sphere that was lost."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.reports.answer import answer_lines, num
from creatio.reports.registry import writer

REPO = Path(__file__).resolve().parents[2]


def _answer(md: str) -> list[str]:
    """The lines between the title and the first blank line after it; checks their shape
    and that no table comes before them."""
    lines = md.splitlines()
    assert lines[0].startswith("# ") and lines[1] == ""
    end = lines.index("", 2)
    block = lines[2:end]
    assert 3 <= len(block) <= 5, block
    assert block[0].startswith("- **Computed:** ") and block[-1].startswith("- **Rests on:** ")
    assert all(b.startswith("- **Answer:** ") for b in block[1:-1])
    assert not any(line.startswith("|") for line in lines[:end])
    return block


def test_answer_lines_lay_out_what_they_are_given_and_refuse_a_sixth_line():
    assert answer_lines("a", "b", "c") == ["- **Computed:** a", "- **Answer:** b",
                                           "- **Rests on:** c", ""]
    assert len(answer_lines("a", ["b", "c", "d"], "e")) == 6
    with pytest.raises(ValueError, match="one to three lines, not 4"):
        answer_lines("a", ["b"] * 4, "c")
    assert num(0.000436457, "m") == "0.0004365 m" and num(None, "s") == "not computed"
    assert num(float("nan")) == "not computed" and num(12, "deg") == "12 deg"


# ------------------------------------------------------------------------------ kinematic
@pytest.fixture(scope="module", params=["ct02", "en01"])
def kinematic(request, tmp_path_factory):
    """CT-02's or EN-01's dataset computed here and its report written."""
    from creatio.pipeline.config import resolve
    from creatio.pipeline.run import run_study
    from creatio.reports.kinematic import write_report
    from creatio.store.netcdf import write_dataset

    study = request.param
    d = tmp_path_factory.mktemp(study)
    cfg = resolve(study)
    path = write_dataset(run_study(cfg, study), d / f"{study}.nc")
    out = write_report([path], d / "reports")
    return study, json.loads(out["json"].read_text()), out["md"].read_text()


def test_kinematic_reports_open_with_their_answer(kinematic):
    study, s, md = kinematic
    block = _answer(md)
    text = "\n".join(block)
    orders = [o for n in s["observed_order"].values() for h, o in n.items() if float(h) >= 1e-4]
    assert f"observed order {min(orders):.3f} to {max(orders):.3f}" in text
    assert 1.99 < min(orders) and max(orders) < 2.01 and "the derivatives are right" in text
    L = "u" if study == "ct02" else "m"
    assert f"J stays at least {s['j_min_sampled']:.4g} {L}" in text
    assert f"bound R0 - A = {s['j_min']:.4g} {L}" in text
    assert f"unit vector to {s['normal_length_error']:.4g} dimensionless" in text
    c_alpha = s["fd_error"]["c_alpha"]["0.0001"]
    assert f"c_alpha {c_alpha:.4g} {L}/rad" in text
    if study == "en01":
        assert f"fastest {s['pattern_max_rate_rad_s']:.4g} rad/s" in text
    else:  # the model length unit is named, with the geometry it was computed in
        assert "model length unit u (R0 = 0.68 u, dR = 1.72 u, A = 0.18 u)" in text


def _tables(md: str) -> list[list[list[str]]]:
    """Every markdown table as rows of cells (header first, separator dropped)."""
    out, current = [], []
    for line in md.splitlines() + [""]:
        if line.startswith("|"):
            if not set(line) <= set("|-: "):
                current.append([c.strip() for c in re.split(r"(?<!\\)\|", line.strip("|"))])
        elif current:
            out.append(current)
            current = []
    return out


UNIT = re.compile(r"\(([^()]+)\)$")


def test_kinematic_tables_give_a_unit_on_every_number(kinematic):
    study, _, md = kinematic
    tables = _tables(md)
    assert len(tables) >= 3
    for rows in tables:
        header = rows[0]
        if header[0] == "figure":  # one figure a row: the unit ends its label
            for row in rows[1:]:
                assert UNIT.search(row[0].replace("\\|", "|")), (study, row)
        else:  # the derivative table: one unit per column
            assert header[0].startswith("h (") and all(UNIT.search(h) for h in header), header
    L = "u" if study == "ct02" else "m"
    assert f"c_alpha computed ({L}/rad)" in tables[0][0]
    assert f"c_t computed ({L}/s)" in tables[0][0]


# ------------------------------------------------------------------------------ EN-04
def _en04_datasets() -> list[Path]:
    paths = sorted((REPO / "data" / "studies" / "en04").glob("en04_*.nc"))
    names = {p.stem for p in paths}
    if not {"en04_actuation", "en04_oscillation", "en04_control"} <= names:
        pytest.skip("EN-04's datasets are not built (snakemake -c 1 data/reports/en04.json)")
    return paths


@pytest.fixture(scope="module")
def en04(tmp_path_factory):
    from creatio.reports.en04 import write_report

    out = write_report(_en04_datasets(), tmp_path_factory.mktemp("en04"))
    return json.loads(out["json"].read_text()), out["md"].read_text()


@pytest.mark.long
def test_en04_opens_with_the_demand_the_frequencies_and_the_fastest_controller(en04):
    s, md = en04
    text = "\n".join(_answer(md))
    a = s["actuation"]["en02"]
    assert f"EN-02 peaks at {a['P_actuator_peak_W']:.4g} W" in text
    assert f"takes {a['E_actuator_J']:.4g} J" in text
    worst = max(abs(c[f"{m}_rel_difference"]) for c in s["oscillation_checks"].values()
                for m in ("slide", "roll"))
    assert f"closed forms to {worst:.2g} relative (within" in text
    k = s["control_checks"]
    assert f"{k['cases_carried']} of {k['cases']} closed-loop controllers" in text
    assert f"the fastest arrives in {s['control']['fastest_arrival_s']:.4g} s" in text
    assert md.index(text.splitlines()[0]) < md.index("K_m_max_J")


@pytest.mark.long
def test_en04_robustness_says_why_mass_rows_agree_and_hides_a_lost_arrival(en04):
    s, md = en04
    rows = s["control"]["robustness"]
    section = md[md.index("### Robustness"):md.index("### Every controller")]
    table_rows = [r for r in _tables(section)[0][1:]]
    assert len(table_rows) == len(rows)
    for r, cells in zip(rows, table_rows, strict=True):
        assert (cells[3] == "lost") == (not r["closed_loop_carried"])
        assert (cells[5] == "lost") == (not r["open_loop_carried"])
    factors = {r["mass_factor"] for r in rows}
    if len(factors) > 1:  # equal across m in the data, and the report says by which law
        for mu in {r["mu"] for r in rows}:
            same = [(r["closed_loop_arrival_s"], r["open_loop_carried"]) for r in rows
                    if r["mu"] == mu]
            assert len(set(same)) == 1
        assert "equal by a law of the model, not by chance" in section
        assert "scales with m" in section


def test_en04_mass_law_sentence_follows_the_rows():
    from creatio.reports.en04 import _mass_law

    keys = ["closed_loop_arrival_s"]
    equal = [{"mu": 0.1, "mass_factor": f, "closed_loop_arrival_s": 4.0} for f in (0.5, 1.0)]
    assert "equal by a law of the model" in _mass_law(equal, keys)
    differ = [{"mu": 0.1, "mass_factor": f, "closed_loop_arrival_s": 4.0 + f} for f in (0.5, 1)]
    assert "differ" in _mass_law(differ, keys)
    assert _mass_law([{"mu": 0.1, "mass_factor": 1.0, "closed_loop_arrival_s": 4.0}],
                     keys) is None


# --------------------------------------------------------------- beyond EN-02 (small runs)
@pytest.mark.long
@pytest.mark.parametrize(("study", "overrides"), [
    ("en02g", ["study.inclinations_deg=[0,20,40]", "study.oscillation.gamma0_deg=[10]",
               "phases.T=30.0"]),
    ("en03", ["study.inertia_sweep=[1.0,100.0]", "phases.T=30.0"]),
    ("en03m", ["phases.T=20.0", "study.bisection.decades=[-2,-1]",
               "study.max_force_factor=1.0", "study.bisection.rtol=0.05"]),
])
def test_the_sphere_studies_beyond_en02_open_with_their_answer(study, overrides, tmp_path):
    from creatio.pipeline.config import resolve
    from creatio.pipeline.run import run_study
    from creatio.store.netcdf import write_dataset

    cfg = resolve(study, overrides)
    paths = [write_dataset(run_study(cfg, q.name), tmp_path / f"{q.name}.nc")
             for q in cfg.entry.parts(cfg.obj)]
    files = writer(cfg.entry.id)(paths, tmp_path)
    s = json.loads(files["json"].read_text())
    text = "\n".join(_answer(files["md"].read_text()))
    assert f"{s['timestep_difference_m']:.3g} m" in text
    if study == "en02g":
        assert s["max_carried_inclination_deg"] == 20.0 and s["equilibrium_limit_deg"] < 40
        assert "from 0 deg up to 20 deg (2 of 3 inclinations)" in text
        assert f"an equilibrium exists up to {s['equilibrium_limit_deg']:.4g} deg" in text
    elif study == "en03":
        assert f"the structure turns {s['structure_rotation_deg']:.4g} deg" in text
        assert f"(point-mass estimate {s['structure_rotation_point_mass_deg']:.4g} deg)" in text
        for key, v in s["inertia_sweep"].items():
            assert f"{v['structure_rotation_deg']:.4g} deg at I_s = {key} kg m^2" in text
    else:
        assert s["normal"]["min_confining_force_N"] is None
        assert f"normal confinement: I_s = 10 kg m^2: none up to {s['max_force_N']:.4g} N" in text
        base = s["base"]["min_confining_force_N"]
        assert f"base confinement: I_s = 10 kg m^2: {base:.4g} N" in text


@pytest.mark.long
def test_en02f_opens_with_its_boundary_and_drop_test(tmp_path):
    from creatio.pipeline.config import resolve
    from creatio.reports.en02f import write_en02f
    from creatio.store.netcdf import write_dataset
    from creatio.studies import en02f
    from creatio.studies.schema import vary

    cfg = vary(resolve("en02f").obj, {"study.cycles_s": [8.0, 6.0], "study.restitutions": [0.0],
                                     "phases.T": 6.0, "study.duration": 6.0})
    paths = [write_dataset(en02f.run(cfg, dt), tmp_path / f"en02f_dt{dt!r}.nc")
             for dt in cfg.solver.timesteps()]
    paths.append(write_dataset(en02f.run(cfg, drop=True), tmp_path / "en02f_drop.nc"))
    out = write_en02f(paths, tmp_path / "reports")
    s = json.loads(out["json"].read_text())
    text = "\n".join(_answer(out["md"].read_text()))
    lo, hi = s["boundary"]["with_flight"]["0"]
    assert f"e = 0: fails at T = {lo:.4g} s, carried again from {hi:.4g} s" in text
    kept = sum(c["ends_in_cavity"] for c in s["cases"].values())
    assert f"{kept} of 2 cases end the cycle in their starting cavity" in text
    assert f"within {s['drop_test']['first_impact_time_error_s']:.3g} s of free fall" in text


# ------------------------------------------------------------------------------ EN-05
def test_en05_answer_names_the_driver_the_fit_and_the_pinning_cycles():
    from creatio.reports.en05 import _answer as en05_answer

    summary = {
        "sobol": {"256": {}, "512": {
            "final_radius_m": {"computed": True, "runs": 4096,
                               "ST": {"mu": 0.12, "eps": 0.81, "m": None}},
            "surface_work_J": {"computed": False, "runs": 4096}}},
        "calibration": {"truth": {"sphere.mu": 0.05}, "estimate": {"sphere.mu": 0.05001},
                        "stderr": {"sphere.mu": 7e-5}, "coverage_95": {"sphere.mu": 0.935},
                        "seeds": 200, "cycle_s": 10.0},
        "design": {"pins_mu_to_0_01": {"0.05": [7.0, 12.0], "0.3": []}, "target": 0.01,
                   "camera_noise_m": 0.001, "camera_hz": 30.0, "max_step_disagreement": 0.002},
        "ishigami": {"S1": {"x1": 0.30}, "S1_closed_form": {"x1": 0.31},
                     "ST": {"x1": 0.56}, "ST_closed_form": {"x1": 0.5576}},
        "carried_fraction": 0.98,
    }
    text = "\n".join(en05_answer(summary))
    assert "final_radius_m: eps (ST 0.81)" in text and "surface_work_J" not in text
    assert "sphere.mu = 0.05001 +- 7e-05 (truth 0.05)" in text and "sphere.mu 93.5 %" in text
    assert "mu = 0.05: T = 7, 12 s; mu = 0.3: no cycle" in text
    assert "within 0.010 of its closed forms" in text and "98.0 % of the sample runs" in text


# ------------------------------------------------------------------------------ sweeps
def test_a_sweep_report_opens_with_the_range_of_its_figures(tmp_path):
    from creatio.reports.sweep import write_sweep_report

    mu = np.array([0.0, 0.15, 0.35])
    ds = xr.Dataset({
        "max_slip_speed_m_s": ("sphere__mu", [0.109, 2.9e-5, np.nan]),
        "cumulative_spin_deg": ("sphere__mu", [0.0, 3331.0, np.nan]),
        "status": ("sphere__mu", ["ok", "ok", "invalid"]),
        "message": ("sphere__mu", ["", "", "too large"]),
    }, coords={"sphere__mu": ("sphere__mu", mu, {"long_name": "sphere.mu"})},
        attrs={"title": "sweep", "points": 3, "points_run": 2, "base_overrides": "[]"})
    text = "\n".join(_answer(write_sweep_report(ds, tmp_path)["md"].read_text()))
    assert "3 points of the base config over sphere.mu = 0 to 0.35 (3 values)" in text
    assert "cumulative spin (deg) from 0 (sphere.mu = 0) to 3331 (sphere.mu = 0.15)" in text
    assert "from 2.9e-05 (sphere.mu = 0.15) to 0.109 (sphere.mu = 0)" in text
    assert "points by status: ok 2, invalid 1" in text


# ------------------------------------------------------------------------ work-precision
def test_the_benchmark_opens_with_its_tightest_resolved_comparison():
    from creatio.reports.work_precision import _markdown, summary

    def entry(method, group, setting, error, times):
        return {"study": "en02", "method": method, "group": group, "setting": setting,
                "error_m": error, "time_s": min(times), "time_max_s": max(times),
                "time_median_s": float(np.median(times)), "time_spread": max(times) / min(times),
                "state_size": 12, "final_error_m": error, "repeats": len(times),
                "rhs_evals": 100, "steps": 25, "rejected_steps": 0, "jacobians": 0,
                "lu_factorisations": -1, "newton_iterations": -1, "status": "ok",
                "first_call_s": 0.0}

    runs = [entry("dop853", "native", "rtol=1e-10", 5e-11, [2e-2, 2.1e-2]),
            entry("sundials-CVODE-BDF", "peer", "rtol=1e-11", 6e-11, [1e-1, 1.1e-1]),
            entry("scipy-LSODA", "peer", "rtol=1e-08", 5e-9, [1e-3, 1.5e-3])]
    s = summary(runs, {"check_adaptive_max_diff_m": 1e-14}, [1e-8, 1e-10], 10.0)
    text = "\n".join(_answer(_markdown({"en02": s}, runs, {}, {}, [1e-8, 1e-10], 10.0)))
    assert ("en02 at 1e-10 m: dop853 rtol=1e-10 in 20 ms against sundials-CVODE-BDF "
            "rtol=1e-11 in 100 ms (5x, faster)") in text
    assert "each integrator (dop853) takes" in text


# ------------------------------------------------------------------------ stability map
@pytest.mark.long
def test_the_stability_map_opens_with_each_schemes_step_against_its_estimate():
    from creatio.pipeline.config import resolve
    from creatio.reports.stability_map import markdown
    from creatio.reports.stability_map import summary as map_summary
    from creatio.studies.stability_map import run

    cfg = resolve("stability_map", [
        "study.duration=2.0", "study.axes.mu=[0.5,1.0]", "study.axes.eps=[0.04]",
        "study.methods=[rk4]", "study.duration_check.mu=[1.0]",
        "study.duration_check.duration=3.0"]).obj
    sets = [run(cfg, "mu")]
    s = map_summary(sets)
    text = "\n".join(_answer(markdown(sets)))
    ratios = [p["ratio"] for p in s["axes"]["mu"]["methods"]["rk4"]["points"]]
    assert all(r > 1 for r in ratios)  # the estimate keeps a margin below the break
    lo, hi = f"{min(ratios):.3g}", f"{max(ratios):.3g}"
    assert f"rk4: {lo if lo == hi else f'{lo} to {hi}'} times the estimate" in text
    assert "within 1e-09 m over 2 s" in text and "along mu = 0.5, 1." in text
    assert ("refuses exactly the steps above its limit" in text) == s["validation_agrees"]


# ------------------------------------------------------------------------- boundaries
def test_the_boundaries_open_with_each_axis_boundary_beside_its_analytic_value():
    from creatio.reports.boundaries import _answer as boundaries_answer

    def axis(name, key, b, analytic, units):
        return xr.Dataset({"boundary": b, "boundary_status": "contact_lost",
                           "analytic_boundary": analytic},
                          coords={"value": ("value", [1.0], {"units": units})},
                          attrs={"axis": name, "config_key": key, "anomalies": "x; y"})

    text = "\n".join(boundaries_answer([axis("amplitude", "geometry.A", 0.2512, 0.25, "m"),
                                        axis("mu", "sphere.mu", math.nan, 0.3, "1")]))
    assert "amplitude at 0.2512 m (contact_lost; analytic 0.25 m)" in text
    assert "mu at - (contact_lost; analytic 0.3)" in text and "4 anomalies" in text


def _kinematic_run(base: Path, overrides: list[str]) -> str:
    """EN-01 computed into <base>/data(/runs/<key>) as `creatio run` lays it out (with its
    overrides.json off the default); its report's markdown."""
    from creatio.pipeline.config import resolve
    from creatio.pipeline.index import record_run
    from creatio.pipeline.run import compute_dataset

    r = resolve("en01", overrides, only_applicable=True)
    data_dir = base / "data"
    root = data_dir / "runs" / r.key if overrides else data_dir
    folder = root / "studies" / "en01"
    folder.mkdir(parents=True, exist_ok=True)
    record_run(root, "study", "en01", r.data, resolve("en01").data, None, r.sha256, data_dir)
    out = compute_dataset(r, folder / "en01.nc", "en01")
    return writer("en01")([out], root / "reports")["md"].read_text()


def test_a_kinematic_override_is_not_graded_against_the_notebook(tmp_path):
    """Issue 34.1 for EN-01: its published figures belong to the default geometry; a run at
    A = 0.1 names the key that differs and shows no published column or verdict, while the
    default run keeps its comparison."""
    other = _kinematic_run(tmp_path / "a", ["geometry.A=0.1"])
    assert "No published figure for this config" in other and "`geometry.A`: 0.18 -> 0.1" in other
    assert "published" not in other.split("No published figure", 1)[1]
    assert "agrees to the printed digits" not in other
    default = _kinematic_run(tmp_path / "b", [])
    assert "they are compared below" in default and "c_R published" in default
    assert "agrees to the printed digits" in default
