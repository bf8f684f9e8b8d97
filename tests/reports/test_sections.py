"""Reports that describe the run they were made from (issue 34): a published comparison only
for the published case, checks derived from the run itself, a section for every feature a
run used (a controller, flight), figures embedded in the HTML, the answer first."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.reports.common import PUBLISHED_HEADER, markdown_html, published_row, table
from creatio.reports.sections import control_section, feature_sections, flight_applies
from creatio.reports.sphere import SUMMARY_ROWS, energy_check, printed_half_unit, timestep_check
from creatio.studies import registry
from creatio.studies.published import EN02

SHORT = ["phases.T=10", "study.duration=10"]


def _run(base: Path, overrides: list[str]) -> tuple[dict[str, Path], Path]:
    """Compute an EN-02 run into <base>/runs/<key> as `creatio run` lays it out (datasets,
    overrides.json for a non-default config), write its report; (report paths, root)."""
    from creatio.pipeline.config import resolve
    from creatio.pipeline.index import record_run
    from creatio.pipeline.run import compute_dataset
    from creatio.reports.sphere import write_report

    r = resolve("en02", overrides, only_applicable=True)
    data_dir = base / "data"
    root = data_dir / "runs" / r.key if overrides else data_dir
    folder = root / "studies" / "en02"
    folder.mkdir(parents=True, exist_ok=True)
    record_run(root, "study", "en02", r.data, resolve("en02").data, None, r.sha256, data_dir)
    data = [compute_dataset(r, folder / f"{p.name}.nc", p.name) for p in r.entry.parts(r.obj)]
    return write_report(data, root / "reports"), root


def _figures(md: str) -> list[tuple[str, str]]:
    return re.findall(r"^!\[([^]]*)\]\(([^)]+)\)", md, flags=re.M)


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """EN-02 over a 10 s cycle with mu = 0.2: off the published case in three keys."""
    return _run(tmp_path_factory.mktemp("short"), [*SHORT, "sphere.mu=0.2"])


# ------------------------------------------------------------------------------ published case
def test_the_registry_declares_the_keys_the_published_figures_depend_on():
    """EN-02's published case: physics, timing, method and step keys take a run off it; the
    step budget or the title do not; a group switched on from null always does."""
    en02 = registry.get("en02")
    changed = {"sphere.mu": [0.15, 0.3], "solver.max_rhs_evals": [50_000_000, 10],
               "study.title": ["a", "b"], "solver.dt": [0.002, 0.001],
               "control.omega_c": [None, 3.0], "newfeature.on": [None, True]}
    assert en02.published_keys(changed) == ["sphere.mu", "solver.dt", "control.omega_c",
                                            "newfeature.on"]
    assert registry.get("en02r").published_keys({"x.y": [1, 2]}) == ["x.y"]  # none declared


def test_an_override_run_has_no_published_comparison_and_names_its_keys(short_run):
    paths, root = short_run
    md = paths["md"].read_text()
    record = json.loads((root / "overrides.json").read_text())
    assert record["changes"]["sphere.mu"] == [0.15, 0.2]
    head = md.split("## Summary figures")[0]
    assert "No published figure for this config" in head
    assert "`sphere.mu`: 0.15 -> 0.2" in head and "`phases.T`: 120.0 -> 10.0" in head
    for word in ("published | computed - published", "agrees to the printed digits",
                 "ABOVE the bound", "below the bound", "differs by"):
        assert word not in md, word
    data = json.loads(paths["json"].read_text())
    assert data["published_case"] is False
    assert set(data["differs"]) == {"phases.T", "study.duration", "sphere.mu"}


def test_the_checks_are_this_runs_own(short_run):
    """The step check's Richardson estimate and the residual's observed order are computed
    from this run's two datasets, not read from the notebook."""
    paths, _ = short_run
    data = json.loads(paths["json"].read_text())
    t, e = data["checks"]["timestep"], data["checks"]["energy"]
    d = data["timestep_difference_m"]
    assert t["made"] and t["richardson_error_m"] == pytest.approx(d * 16 / 15, rel=1e-12)
    assert t["bound"] == printed_half_unit(max(data["initial_radius_m"],
                                              data["final_radius_m"]))
    r = data["energy_residual_by_dt_J"]
    R = [r["0.002"], r["0.001"]]
    if e["made"]:
        assert e["observed_order"] == pytest.approx(math.log2(R[0] / R[1]), rel=1e-12)
        assert e["passed"] == (e["observed_order"] >= 3.5)
    else:
        assert min(R) <= e["rounding_level_J"] and e["passed"] is None
        assert "not made" in e["verdict"]


def test_the_report_opens_with_its_config_and_answer(short_run):
    """Title naming the overrides; three to five answer lines right under it whose figures
    are the JSON's; then the paragraph with study, overrides and config hash."""
    paths, _ = short_run
    data = json.loads(paths["json"].read_text())
    lines = paths["md"].read_text().splitlines()
    assert lines[0].startswith("# EN-02") and " sphere.mu=0.2" in lines[0]
    block = lines[2:lines.index("", 2)]
    assert 3 <= len(block) <= 5 and block == data["answer"]
    assert block[0].startswith("- **Computed:** ") and block[-1].startswith("- **Rests on:** ")
    assert f"config {data['config_sha256'][:12]}" in block[0]
    assert f"ended at radius {data['final_radius_m']:#.4g} m" in block[1]
    assert f"by at most {data['timestep_difference_m']:.4g} m" in block[-1]
    assert "No published figure applies to this config" in block[-1]
    after = lines[len(block) + 3]
    assert after.startswith("Study `en02`, overrides `") and data["config_sha256"][:12] in after


def test_html_reports_embed_every_figure_of_the_markdown(short_run):
    paths, _ = short_run
    md, page = paths["md"].read_text(), paths["html"].read_text()
    figures = _figures(md)
    assert len(figures) == 3
    for alt, src in figures:
        assert f'<img src="{src}" alt="{alt}">' in page
        assert (paths["md"].parent / src).is_file()


def test_markdown_images_become_img_tags_with_their_alt_text():
    page = markdown_html("# T\n\n![a <b> figure](x y.png)\n\ntext\n")
    assert '<img src="x y.png" alt="a &lt;b&gt; figure">' in page
    assert "Figures of this report" not in page


# ------------------------------------------------------------------------------ checks
def _pair(d_scale: float, residuals: tuple[float, float], rtol: float | None = None):
    t = np.linspace(0.0, 1.0, 11)
    runs = []
    for k, dt in enumerate((0.002, 0.001)):
        centre = np.zeros((t.size, 3))
        centre[:, 0] = 1.0 + (d_scale if k == 0 else 0.0)
        ds = xr.Dataset({"centre": (("time", "component"), centre)}, coords={"time": t},
                        attrs={"dt": dt, "method": "dopri5" if rtol else "rk4",
                               "max_energy_residual": residuals[k]})
        if rtol:
            ds.attrs["rtol"] = rtol / 32 ** k
        runs.append(ds)
    return runs


CONFIG = {"geometry": {"R0": 0.68, "dR": 1.72}, "sphere": {"m": 1.0, "g": 9.81}}


def test_step_check_passes_below_the_printed_digit_and_fails_above_it():
    s = {"initial_radius_m": 1.11, "final_radius_m": 1.11}
    for d, passed in ((4e-4, True), (6e-4, False)):
        c = timestep_check(_pair(d, (1e-6, 1e-7)), CONFIG, {**s, "timestep_difference_m": d})
        assert c["richardson_error_m"] == pytest.approx(d * 16 / 15)
        assert c["bound"] == pytest.approx(5e-4) and c["passed"] is passed
    # adaptive: the difference against rtol x (R0 + dR)
    c = timestep_check(_pair(1e-8, (1e-6, 1e-7), rtol=1e-8), CONFIG,
                       {**s, "timestep_difference_m": 1e-8})
    assert c["bound"] == pytest.approx(1e-8 * 2.4) and c["passed"] is True


def test_energy_check_measures_the_order_or_says_it_cannot():
    ok = energy_check(_pair(0.0, (1.6e-7, 1e-8)), CONFIG)
    assert ok["made"] and ok["observed_order"] == pytest.approx(4.0) and ok["passed"]
    slow = energy_check(_pair(0.0, (4e-7, 2e-7)), CONFIG)
    assert slow["made"] and slow["observed_order"] == pytest.approx(1.0) and not slow["passed"]
    assert "FAILS" in slow["verdict"]
    floor = 100 * np.finfo(float).eps * 9.81 * 2.4
    noise = energy_check(_pair(0.0, (5e-15, 1e-15)), CONFIG)
    assert noise["rounding_level_J"] == pytest.approx(floor)
    assert not noise["made"] and noise["passed"] is None and "not made" in noise["verdict"]


# ------------------------------------------------------------------------------ features
def _controlled(status: str = "ok") -> xr.Dataset:
    t = np.linspace(0.0, 10.0, 101)
    travel = -360.0 * (1 - np.exp(-t))
    return xr.Dataset(
        {"travel": ("time", travel), "phase_a": ("time", 6 * -travel),
         "lead": ("time", np.zeros_like(t)), "lead_command": ("time", np.zeros_like(t)),
         "phase_a_rate": ("time", np.ones_like(t)),
         "phase_a_acceleration": ("time", np.ones_like(t))},
        coords={"time": t},
        attrs={"control": 1, "control_goal_deg": -360.0, "control_arrival_tol_deg": 2.0,
               "control_k_theta": 0.09, "control_k_omega": 0.06, "arrival_time": 4.3,
               "settling_time": 8.0, "overshoot_deg": 35.97, "final_error_deg": 0.0177,
               "max_lead_deg": 5.5, "max_phase_a_rate": 10.6,
               "max_phase_a_acceleration": 288.3, "status": status,
               "carried": int(status == "ok"), "dt": 0.002})


def test_control_section_reports_the_datasets_readouts(tmp_path):
    config = {"geometry": {"Ka": 6}, "control": {"omega_c": 3.0, "u_max": None}}
    sec = control_section([_controlled()], config, tmp_path, "x")
    text = "\n".join(sec.lines)
    assert "| arrival (s) | 4.3 |" in text and "| settling (s) | 8 |" in text
    assert "| overshoot past the goal (deg) | 35.97 |" in text
    assert "| outer loop pole frequency omega_c (rad/s) | 3 |" in text
    assert "| servo acceleration limit (rad/s^2) | none |" in text
    assert sec.summary["control"]["arrival_s"] == 4.3 and sec.figures[0].is_file()
    assert "at 4.3 s" in sec.answer[0]


def test_a_lost_sphere_gets_no_arrival(tmp_path):
    sec = control_section([_controlled("contact_lost")], {"control": {}}, tmp_path, "x")
    text = "\n".join(sec.lines)
    assert "| arrival (s) | 4.3 |" not in text and "the sphere was lost" in text
    assert math.isnan(sec.summary["control"]["arrival_s"]) and "no arrival" in sec.answer[0]


def test_features_apply_only_where_the_run_used_them(tmp_path):
    plain = _controlled().assign_attrs(control=0)
    assert feature_sections([plain], {"control": None}, tmp_path, "x") == []
    assert [s.name for s in feature_sections([_controlled()], {"control": {}}, tmp_path,
                                             "x")] == ["control"]
    flight = xr.Dataset({"event_kind": ("event", np.array([0, 1], np.int8),
                                        {"flag_meanings": "separation impact"}),
                         "event_time": ("event", [1.0, 1.5]),
                         "event_flight_height": ("event", [np.nan, 0.02])},
                        attrs={"flights": 1, "impacts": 1, "flight_time": 0.5,
                               "max_flight_height": 0.02, "impact_loss": 0.1})
    assert flight_applies({}, flight)
    [sec] = feature_sections([flight], {}, tmp_path, "x")
    text = "\n".join(sec.lines)
    assert "| flights | 1 |" in text and "| 1.5 | impact | 0.02 |" in text


# ------------------------------------------------------------------------------ end to end
@pytest.mark.long
def test_the_default_run_keeps_its_published_comparison(tmp_path):
    """The default EN-02 (no overrides.json) compares the same rows as before the change."""
    paths, _ = _run(tmp_path, [])
    md = paths["md"].read_text()
    data = json.loads(paths["json"].read_text())
    rows = [published_row(label, data[key], EN02[key]) for label, key in SUMMARY_ROWS
            if key in EN02]
    assert "\n".join(table(PUBLISHED_HEADER, rows)) in md
    assert {r[4] for r in rows} <= {"agrees to the printed digits", "below the bound"}
    assert data["published_case"] is True and data["differs"] == {}
    assert "No published figure" not in md and "FAILS" not in md


@pytest.mark.long
def test_a_controlled_run_has_its_control_section(tmp_path):
    paths, root = _run(tmp_path, [*SHORT, "control=pd"])
    md = paths["md"].read_text()
    ds = xr.open_dataset(next((root / "studies" / "en02").glob("en02_dt0.002.nc")))
    assert "## Control" in md and "`control`: none -> set" in md
    assert f"| arrival (s) | {float(ds.attrs['arrival_time']):.4g} |" in md
    assert f"| settling (s) | {float(ds.attrs['settling_time']):.4g} |" in md
    data = json.loads(paths["json"].read_text())
    assert data["control"]["arrival_s"] == float(ds.attrs["arrival_time"])
    page = paths["html"].read_text()
    assert all(f'<img src="{src}"' in page for _, src in _figures(md))
    assert "en02_control.png" in page


def test_a_tilted_run_has_its_tilt_section_and_names_its_keys(tmp_path):
    """A feature that came later (the mounting tilt) reports through the same mechanism: its
    section gives the gravity vector g (sin b cos p, sin b sin p, -cos b), its answer line the
    horizontal part g sin b, and the differing keys are named one by one (two new keys of
    `sphere` are not a group switched on)."""
    paths, _ = _run(tmp_path, [*SHORT, "sphere.beta_deg=2", "sphere.psi_deg=30"])
    md = paths["md"].read_text()
    b, p = math.radians(2.0), math.radians(30.0)
    assert "## Tilt" in md and "`sphere.beta_deg`: None -> 2.0" in md
    assert "`sphere`: none -> set" not in md
    tilt = json.loads(paths["json"].read_text())["tilt"]
    assert tilt["gravity_m_s2"] == pytest.approx(
        [9.81 * math.sin(b) * math.cos(p), 9.81 * math.sin(b) * math.sin(p),
         -9.81 * math.cos(b)], rel=1e-12)
    assert f"horizontal part of {9.81 * math.sin(b):.4g} m/s^2" in md
