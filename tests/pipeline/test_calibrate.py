"""`creatio calibrate` and EN-05's pipeline: every bad track refused in one line with exit 2
and nothing written; the committed example track is what the model makes; the Sobol'
sample's point list runs through the sweep batch runner, its points reused by config hash;
the mass's total index on the kinematic outputs is zero within the estimator's noise."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.pipeline import calibrate, points
from creatio.pipeline.config import resolve
from creatio.pipeline.sweep import run_batch
from creatio.studies import en05

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "tracks" / "en02_synthetic.csv"
GOOD = "# study: en02\n# noise_m: 0.001\nt_s,x_m,y_m\n0.1,0.5,0.6\n0.2,0.5,0.6\n0.3,0.5,0.6\n"


def _lines(text: str) -> list[str]:
    return [ln for ln in text.splitlines() if ln.strip()]


BAD = {
    "missing column": ("t_s,x_m\n0.1,0.5\n0.2,0.5\n0.3,0.5\n", "missing column y_m"),
    "nan": (GOOD.replace("0.2,0.5,0.6", "0.2,nan,0.6"), "not a finite number"),
    "not increasing": (GOOD.replace("0.3,0.5", "0.15,0.5"), "times must increase"),
    "outside the run": (GOOD.replace("0.3,0.5", "130.0,0.5"), "outside the run"),
    "wrong units": (GOOD.replace("x_m", "x_mm"), "x must be in metres"),
    "time units": (GOOD.replace("t_s", "t_ms"), "t must be in seconds"),
    "wrong study": (GOOD.replace("study: en02", "study: en02r"), "track of study en02r"),
    "off the frame grid": (GOOD.replace("0.3,0.5", "0.3123,0.5"), "frame grid"),
    "bad noise": (GOOD.replace("0.001", "-1"), "noise_m"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_every_bad_track_is_refused_in_one_line_and_nothing_is_written(case, tmp_path,
                                                                       capsys):
    text, words = BAD[case]
    track = tmp_path / "track.csv"
    track.write_text(text)
    out = tmp_path / "out"
    code = calibrate.main(["study=en02", f"track={track}", "fit=[sphere.mu,sphere.eps]",
                           f"out={out}"])
    err = capsys.readouterr().err
    assert code == 2
    assert len(_lines(err)) == 1 and words in err, err
    assert str(track) in err
    assert not out.exists()


def test_refusal_through_the_command_line(tmp_path):
    """The console command: exit 2, one line on stderr, no traceback, nothing written."""
    track = tmp_path / "track.csv"
    track.write_text(BAD["missing column"][0])
    env = {**os.environ, "CREATIO_CONFIG_CACHE": "off"}
    env.pop("CREATIO_DEBUG", None)
    p = subprocess.run([sys.executable, "-m", "creatio.cli", "calibrate", "study=en02",
                        f"track={track}", f"out={tmp_path / 'out'}"], capture_output=True,
                       text=True, env=env, cwd=tmp_path)
    assert p.returncode == 2
    assert _lines(p.stderr) == [next(iter(_lines(p.stderr)))]
    assert "missing column y_m" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "out").exists() and not (tmp_path / "data").exists()


@pytest.mark.parametrize(("args", "key"), [
    (["fit=[sphere.muu]"], "fit"),
    (["sphere.mu=-1"], "sphere.mu"),
    (["noise=abc"], "noise"),
    (["start=[0.1]"], "start"),
])
def test_bad_arguments_are_refused_in_one_line(args, key, capsys, tmp_path):
    code = calibrate.main(["study=en02", f"track={EXAMPLE}", "phases.T=10", *args,
                           f"out={tmp_path / 'out'}"])
    err = capsys.readouterr().err
    assert code == 2 and len(_lines(err)) == 1 and f"{key}=" in err, err


def test_the_example_track_is_made_by_the_model(tmp_path):
    """examples/tracks/en02_synthetic.csv is what `creatio task en05 track` writes from
    EN-05's calibration settings (the model at the truth plus the example seed's noise)."""
    made = calibrate.write_example_track(resolve("en05"), tmp_path / "track.csv")
    cfg = resolve("en02", list(calibrate.EXAMPLE_OVERRIDES)).obj
    a = calibrate.read_track(made, "en02", cfg.study.duration)
    b = calibrate.read_track(EXAMPLE, "en02", cfg.study.duration)
    assert "SYNTHETIC" in EXAMPLE.read_text().splitlines()[0]
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_allclose(a.xyz, b.xyz, rtol=0, atol=1e-12)


def test_calibrate_the_example_track(tmp_path):
    """The committed example fitted back: the truth inside the joint 95 % confidence region
    (seed 0's eps interval alone misses it, at 2.05 standard errors: 5 % of seeds do), both
    keys identifiable, the residual rms at the stated noise; the report files written."""
    out = tmp_path / "cal"
    assert calibrate.main(["study=en02", f"track={EXAMPLE}", "fit=[sphere.mu,sphere.eps]",
                           *calibrate.EXAMPLE_OVERRIDES, f"out={out}"]) == 0
    import json

    from scipy import stats

    s = json.loads((out / "calibration.json").read_text())
    keys = ["sphere.mu", "sphere.eps"]
    truth = np.array([0.05, 0.01])
    se = np.array([s["stderr"][k] for k in keys])
    cov = np.array(s["correlation"]) * np.outer(se, se)
    d = np.array([s["estimate"][k] for k in keys]) - truth
    assert d @ np.linalg.solve(cov, d) <= stats.chi2.ppf(0.95, 2)  # joint 95 % region
    assert all(s["identifiable"][k] for k in keys)
    assert s["residual_rms_m"] == pytest.approx(s["noise_m"], rel=0.1)
    # the working model's error at the estimate, checked 100x tighter, within 1e-2 of the
    # noise, on every frame; the report says so in the words
    acc = s["numerical_error"]
    assert acc["ok"] and acc["budget_m"] == pytest.approx(1e-2 * s["noise_m"])
    assert acc["observed_m"] <= acc["budget_m"] and acc["points"] == s["frames"]
    assert acc["line"] in (out / "calibration.md").read_text()
    assert acc["line"].startswith("numerical error <= ")
    # in range: nothing held, the interval the fit's own, the record says ok
    assert not any(s["at_bound"].values()) and s["unconstrained"] == {}
    assert s["interval"] == s["interval_95"] and s["status"] == "ok" and not s["next_step"]
    assert s["kind"] == "calibration" and s["parameters"] == keys and s["created"]
    assert {p.name for p in out.iterdir()} >= {"calibration.nc", "calibration.json",
                                               "calibration.md", "calibration.png"}


# ------------------------------------------------------------------- the Sobol' sample
@pytest.fixture(scope="module")
def small_sample(tmp_path_factory):
    """EN-05's sample at N = 16 (128 runs of EN-02) in a private point store."""
    root = tmp_path_factory.mktemp("en05")
    resolved = resolve("en05", ["study.sensitivity.base_sizes=[8,16]",
                                "study.sensitivity.batch_size=64",
                                "study.sensitivity.budget=null"])
    sample = points.en05_sample(resolved, data_dir=str(root))
    plan = sample.plan()
    for k in range(plan.n_batches):
        run_batch(plan, k)
    return resolved, sample, plan


def test_point_list_runs_through_the_sweep_batches_and_reuses_points(small_sample, tmp_path):
    """Each point is the design's row (the axes zipped, not a product); its row carries
    EN-05's outputs; a rerun of a batch into another file reuses every point."""
    resolved, sample, plan = small_sample
    assert plan.n_points == 16 * 8 == sample.n_points and plan.n_batches == 2
    assert plan.overrides(3) == tuple(f"{k}={v[3]}" for k, v in plan.axes)
    again = run_batch(plan, 1, tmp_path / "again.nc")
    with xr.open_dataset(again) as ds:
        assert ds.attrs["reused"] == 64 and ds.attrs["computed"] == 0
        assert set(en05.OUTPUTS) <= set(ds.data_vars)


def test_mass_total_index_is_zero_within_the_estimators_noise_on_kinematic_outputs(
        small_sample):
    """docs/model.md s.13.1: the kinematic outputs do not depend on m, so the ST of m is
    zero within the estimator's noise (the largest bootstrap half-width of that output's
    indices) and below 1e-6: what is left is radau5's step sequence seeing m through the
    energy accumulators' scale (1e-10 on the final radius), not an estimator's resolution.
    (Its own half-width measures the spread of that deterministic remainder: at N = 512 the
    study finds 7e-10 +- 5e-10 on the final radius, so "within its own interval" is not what
    holds; docs/studies.md EN-05.) An output constant over the design has no index: min N /
    (m g) is 1 at the start of every run. W_surface depends on m, exactly as m
    (tests/studies/test_en05.py)."""
    resolved, sample, _ = small_sample
    ds = points.sobol_dataset(resolved, sample)
    j = list(ds.input.values).index("m")
    for out in en05.KINEMATIC_OUTPUTS:
        k = list(ds.output.values).index(out)
        st = ds.ST.values[-1, k, j]
        if math.isnan(st):
            assert np.ptp(ds[out].values) == 0.0, out  # constant: no index
            continue
        noise = float(np.max(ds.ST_conf.values[-1, k]))
        assert abs(st) <= noise, (out, st, noise)
        assert abs(st) < 1e-6, (out, st)
    k = list(ds.output.values).index("surface_work")
    assert ds.ST.values[-1, k, j] > 1e-2
    assert ds.runs_not_ok.values[-1] == int(np.sum(ds.status.values != "ok"))


def test_the_en05_target_builds_everything_into_its_hash_dir(tmp_path):
    """`snakemake en05` on a small configuration (N = 4 and 8, 3 seeds, two cycles): the
    sample's batch jobs, the parts, the Sobol' dataset, the report contract, the example's
    calibration; a second invocation has nothing to do."""
    import json

    small = ["study.sensitivity.base_sizes=[4,8]", "study.calibration.seeds=3",
             "study.calibration.spread_seeds=3", "study.design.cycles_s=[8.0,120.0]",
             "study.design.mu=[0.05]"]
    cmd = [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d",
           str(tmp_path), "-c", "2", "en05", "--config",
           "overrides=[" + ",".join(f'"{o}"' for o in small) + "]"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    root = tmp_path / "data" / "runs" / resolve("en05", small).key
    data = json.loads((root / "reports" / "en05.json").read_text())
    assert set(data) >= {"sobol", "ishigami", "carried_fraction", "calibration", "design"}
    assert set(data["sobol"]) == {"4", "8"}
    entry = data["sobol"]["8"]["final_radius"]
    assert set(entry) >= {"S1", "ST", "S1_conf", "ST_conf", "runs", "runs_not_ok"}
    assert entry["runs"] == 64 and set(entry["S1"]) == {"mu", "eps", "b", "m", "A", "T"}
    assert set(data["ishigami"]) >= {"S1", "ST", "S1_closed_form", "ST_closed_form"}
    assert set(data["calibration"]) >= {"truth", "estimate", "stderr", "interval_95",
                                        "residual_rms_m", "noise_m", "coverage_95", "seeds"}
    assert set(data["design"]) >= {"T_s", "mu", "sigma_mu", "camera_noise_m", "camera_hz",
                                   "pins_mu_to_0_01"}
    assert data["design"]["pins_mu_to_0_01"] == {"0.05": [8.0]}
    for name in ("en05.md", "en05.png", "en05_sobol.csv", "en05_calibration.png",
                 "en05_design.png"):
        assert (root / "reports" / name).stat().st_size > 0
    assert (tmp_path / "data" / "calibration" / "en02_example" / "calibration.json").is_file()
    batches = points.en05_sample(resolve("en05", small), data_dir=str(tmp_path / "data"))
    assert len(list((tmp_path / "data" / "sweeps" / "en05").glob("*/batches/p*.nc"))) == \
        batches.plan().n_batches
    again = subprocess.run([*cmd, "-n"], capture_output=True, text=True, timeout=600)
    assert "Nothing to be done" in again.stdout + again.stderr


# --------------------------------------------------------- plausible tracks, bounded fits
def _track_in(tmp_path, scale: float, name: str):
    """GOOD's points (0.78 m from the centre, inside the annulus) with coordinates x scale."""
    lines = GOOD.splitlines()
    rows = [f"{t},{float(x) * scale!r},{float(y) * scale!r}"
            for t, x, y in (ln.split(",") for ln in lines[3:])]
    path = tmp_path / name
    path.write_text("\n".join([*lines[:3], *rows]) + "\n")
    return path


@pytest.mark.parametrize(("scale", "unit", "factor"), [(1e3, "millimetres", "x 1e-3"),
                                                       (1e2, "centimetres", "x 1e-2")])
def test_a_track_in_other_units_is_refused_with_the_unit_it_looks_like(scale, unit, factor,
                                                                       tmp_path, capsys):
    """Points ~780 m (or 78 m) from the centre lie far outside EN-02's annulus [0.68, 2.4] m:
    one line naming the distance and the unit, exit 2, nothing written, no fit started."""
    track = _track_in(tmp_path, scale, "track.csv")
    out = tmp_path / "out"
    code = calibrate.main(["study=en02", f"track={track}", f"out={out}"])
    err = capsys.readouterr().err
    assert code == 2 and len(_lines(err)) == 1, err
    distance = math.hypot(0.5, 0.6) * scale
    assert f"~{distance:.3g} m from the centre" in err
    assert f"they look like {unit} ({factor} puts them in the annulus)" in err
    assert "[0.68, 2.4] m" in err and "3 of 3 points" in err
    assert not out.exists()


def test_points_just_outside_the_annulus_in_metres_are_refused_without_a_unit(tmp_path,
                                                                              capsys):
    """5 m from the centre is beyond R0 + dR + b = 2.52 m, and no unit scale puts it inside."""
    track = _track_in(tmp_path, 5.0 / math.hypot(0.5, 0.6), "far.csv")
    code = calibrate.main(["study=en02", f"track={track}", f"out={tmp_path / 'out'}"])
    err = capsys.readouterr().err
    assert code == 2 and "~5 m from the centre" in err and "do not look like metres" in err
    assert not (tmp_path / "out").exists()


def test_the_annulus_check_accepts_the_sphere_radius_of_slack():
    """A point b inside R0 is accepted, one a millimetre further is not."""
    cfg = resolve("en02").obj
    r_ok = cfg.geometry.R0 - cfg.sphere.b + 1e-9
    for r, fine in ((r_ok, True), (r_ok - 1e-3, False)):
        track = en05.Track(np.array([0.0, 0.1, 0.2]), np.array([[r, 0.0]] * 3), ("x", "y"))
        if fine:
            calibrate.check_annulus(cfg, track, "t.csv")
        else:
            with pytest.raises(calibrate.TrackError, match="1 of|3 of"):
                calibrate.check_annulus(cfg, track, "t.csv")


def test_a_fit_that_leaves_the_range_is_held_at_the_bound_and_never_printed(tmp_path,
                                                                          monkeypatch):
    """A track made by the model at mu = 0.02, below EN-02's declared range [0.05, 0.3]: the
    unconstrained fit finds mu near 0.02 (the truth), the report holds mu at 0.05, calls it
    not identifiable, prints no estimate outside the range, gives every table its units,
    points to EN-05's design, and writes the record `creatio ls` lists."""
    import json

    monkeypatch.chdir(tmp_path)  # a checkout without EN-05's report: the pointer says how
    track = tmp_path / "low.csv"
    calibrate.write_example_track(resolve("en05", [
        "study.calibration.truth=[0.02,0.01]", "study.calibration.window_s=[1.0,3.0]",
        "study.camera.rate_hz=10"]), track)
    out = tmp_path / "cal"
    assert calibrate.main(["study=en02", f"track={track}", "phases.T=10", f"out={out}"]) == 0
    s = json.loads((out / "calibration.json").read_text())
    ranges = {"sphere.mu": [0.05, 0.30], "sphere.eps": [0.002, 0.05]}
    assert s["physical_range"] == ranges
    x, se = s["unconstrained"]["sphere.mu"]
    assert x < 0.05 and abs(x - 0.02) < 4 * se  # the track did point below the range
    for k, (lo, hi) in ranges.items():
        assert lo <= s["estimate"][k] <= hi, (k, s["estimate"][k])
    assert s["estimate"]["sphere.mu"] == 0.05 and s["at_bound"]["sphere.mu"]
    assert not s["identifiable"]["sphere.mu"] and s["interval"]["sphere.mu"] == [None, None]
    assert "not identifiable: sphere.mu" in s["status"] and s["run_status"] == "ok"
    assert "snakemake en05" in s["next_step"]
    assert {"kind", "study", "track", "parameters", "estimate", "interval", "identifiable",
            "status", "created"} <= set(s)
    assert s["kind"] == "calibration" and s["parameters"] == ["sphere.mu", "sphere.eps"]
    assert s["units"] == {"sphere.mu": "1", "sphere.eps": "m/s"} and s["created"]
    md = (out / "calibration.md").read_text()
    rows = {ln.split("|")[1].strip(): [c.strip() for c in ln.split("|")[2:-1]]
            for ln in md.split("Correlation")[0].splitlines() if ln.startswith("| sphere.")}
    assert rows["sphere.mu"][:2] == ["1", "0.05 (held at the bound)"]
    assert rows["sphere.eps"][0] == "m/s"
    assert "| key | unit | estimate |" in md and "Correlation (dimensionless)" in md
    assert f"{x:.4g}" not in md.split("Correlation")[0]  # never shown as the estimate
    with xr.open_dataset(out / "calibration.nc") as ds:
        assert list(ds.unit.values) == ["1", "m/s"]
        assert np.all((ds.estimate.values >= ds.physical_range.values[:, 0])
                      & (ds.estimate.values <= ds.physical_range.values[:, 1]))


def test_design_pointer_names_the_cycles_from_en05s_report(tmp_path):
    """Built: the cycle lengths EN-05's design found, per mu; not built: the command."""
    import json

    report = tmp_path / "en05.json"
    assert "`snakemake en05 -c 2` computes it" in calibrate.design_pointer(report)
    report.write_text(json.dumps({"design": {
        "pins_mu_to_0_01": {"0.05": [8.0, 10.0], "0.3": []}, "camera_noise_m": 0.001,
        "camera_hz": 30.0, "target": 0.01}}))
    text = calibrate.design_pointer(report)
    assert "mu = 0.05: T = 8, 10 s; mu = 0.3: no cycle" in text
    assert "1 mm, 30 Hz camera" in text and "+-0.01" in text
