"""EN-07's report (docs/aerospace.md) on a small study (one platform, one law, two host
inertias): the JSON contract's keys exactly, its values against the datasets, the figures
written, and no platform passing when the similarity check fails."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import pytest
import xarray as xr

from creatio.pipeline.config import resolve
from creatio.reports import en07 as report
from creatio.studies import en07

LAW_KEYS = {"pass", "binding", "scale", "preload_N", "transport_s", "residual_drift_m",
            "P_actuator_peak_W", "E_actuator_J", "stroke_m", "bandwidth_hz", "max_strain",
            "mount_force_peak_N"}
CASE_KEYS = {"I_host_kg_m2", "mount_force_peak_N", "mount_force_rms_N", "torque_peak_N_m",
             "yaw_excursion_deg", "yaw_rate_peak_deg_s", "stored_momentum_N_m_s", "H_z_drift",
             "point_mass_yaw_deg"}


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Path]]:
    """The three datasets of a small EN-07 written to .nc, and the report of them."""
    cfg = copy.deepcopy(resolve("en07", ["study.requirements.rel_tol=0.2",
                                         "study.interfaces.inertias=[10,1000]",
                                         "study.similarity.scales=[0.5]",
                                         "study.similarity.pulls_g=[2.0]",
                                         "study.strain.n_alpha=48", "study.strain.n_R=9",
                                         "study.strain.n_t=25",
                                         "study.requirements.laws=[quintic]"]).obj)
    cfg.study.platforms = {"drop_tower": cfg.study.platforms["drop_tower"]}
    cfg.check()
    root = tmp_path_factory.mktemp("en07")
    paths = []
    for part in en07.parts(cfg):
        ds = en07.run(cfg, **part.args)
        ds.attrs.update({"study": "en07", "title": "EN-07 test"})
        path = root / f"{part.name}.nc"
        ds.to_netcdf(path)
        paths.append(path)
    report.write_report(paths, root / "reports")
    return root / "reports", paths


@pytest.mark.long
def test_contract_keys_and_values(written: tuple[Path, list[Path]]) -> None:
    out, paths = written
    s = json.loads((out / "en07.json").read_text())
    sim, req, itf = (xr.open_dataset(p) for p in paths)
    assert {"similarity", "platforms", "interfaces"} <= set(s)
    assert set(s["similarity"]["cases"][0]) >= {"s", "a_g", "max_position_error_scaled",
                                                "time_factor"}
    case = s["similarity"]["cases"][0]
    assert (case["s"], case["a_g"]) == (0.5, 2.0)
    assert case["time_factor"] == pytest.approx(0.5, rel=1e-15)
    assert case["max_position_error_scaled"] == float(sim.max_position_error_scaled[0])
    assert s["similarity"]["holds"] is True
    plat = s["platforms"]["drop_tower"]
    assert plat["window_s"] == 4.7 and plat["residual_g"] == 1e-6
    law = plat["laws"]["quintic"]
    assert LAW_KEYS <= set(law)
    assert law["scale"] == float(req.scale.sel(platform="drop_tower", law="quintic"))
    assert law["preload_N"] == pytest.approx(3.0 * 9.81, rel=1e-15)
    assert law["transport_s"] == pytest.approx(4.7 / 1.2, rel=1e-12)
    assert law["max_strain"] == float(req.attrs["max_strain"])
    assert law["pass"] is True and law["binding"] == "window+preload_max"
    rows = s["interfaces"]["cases"]
    assert [r["I_host_kg_m2"] for r in rows] == [10.0, 1000.0]
    for r in rows:
        assert set(r) == CASE_KEYS
        assert r["yaw_excursion_deg"] == pytest.approx(abs(r["point_mass_yaw_deg"]), rel=5e-3)
    assert rows[0]["yaw_excursion_deg"] == float(itf.yaw_excursion_deg[0])
    assert all(math.isfinite(s["cost"][k]) and s["cost"][k] > 0 for k in ("cpu_s", "wall_s"))
    for suffix in (".md", ".html", ".png", "_feasible.png", "_yaw.png"):
        assert (out / f"en07{suffix}").stat().st_size > 0
    md = (out / "en07.md").read_text()
    assert md.startswith("# EN-07 test\n\n- **Computed:**")
    assert "similarity holds" in md and "drop_tower: quintic passes" in md


@pytest.mark.long
def test_no_platform_passes_when_the_similarity_fails(written: tuple[Path, list[Path]]
                                                       ) -> None:
    _, paths = written
    runs: list[Any] = [xr.load_dataset(p) for p in paths]
    runs[0].attrs["holds"] = 0
    s = report.en07_summary(runs)
    assert s["similarity"]["holds"] is False
    law = s["platforms"]["drop_tower"]["laws"]["quintic"]
    assert law["pass"] is False and law["binding"] == "similarity_check_failed"
