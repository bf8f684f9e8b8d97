"""EN-06 (docs/materials.md) on small grids: the datasets against the model functions and
closed forms recomputed here, the fatigue count's closed-form check, the size refusals, and
the report's contract and opening lines."""

from __future__ import annotations

import copy
import functools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
import yaml
from scipy.optimize import minimize_scalar

from creatio.errors import ConfigError
from creatio.model import fatigue as FT
from creatio.model import strain as S
from creatio.pipeline.config import CONF_DIR, validate
from creatio.studies import en06
from creatio.studies.en06_schema import En06Config

#: Small grids (the defaults take about 30 s): every base grid holds t = T / 2 and R = 0.
SMALL = ["study.strain.n_alpha=48", "study.strain.n_R=9", "study.strain.n_t=25",
         "study.beyond.n_alpha=16", "study.beyond.n_R=8", "study.beyond.n_t=5",
         "study.fatigue.n_alpha=8", "study.fatigue.n_R=5", "study.fatigue.n_t=96"]


def compose(overrides: list[str]) -> Any:
    """EN-06's config composed from conf/ by Hydra on its own schema and EN-02's (its base,
    bases.en02), as the pipeline composes a registered study, then validated."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.config_store import ConfigStore
    from hydra.core.global_hydra import GlobalHydra

    from creatio.studies.schema import DynamicConfig

    for name, schema in (("en06", En06Config), ("en02", DynamicConfig)):
        ConfigStore.instance().store(group="schema", name=name, node=schema,
                                     package="_global_")
    gh = GlobalHydra.instance()
    outer, gh.hydra = gh.hydra, None
    try:
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            cfg = hydra_compose(config_name="config", overrides=["study=en06", *overrides])
    finally:
        GlobalHydra.instance().hydra = outer
    return validate(cfg, schema=En06Config)


@functools.cache
def default_data() -> dict[str, Any]:
    """The default config, composed once, as plain data."""
    return compose([]).data


@pytest.fixture(scope="module")
def small() -> Any:
    """The small config, its two datasets."""
    cfg = compose(SMALL).obj
    return cfg, en06.run(cfg, "strain"), en06.run(cfg, "fatigue")


def test_strain_part_matches_the_model_and_the_closed_forms(small: Any) -> None:
    """Per surface: the maximum as strain.maximum gives it, EN-02R's at the inner edge equal
    to A^2 (Ka / R0)^2 / 2 and EN-02's to max_R of b(R) = A^2 Ka^2 sin^2(kR) / (2 rho^2) (both
    to the refinement's 1e-6); stretch sqrt(1 + 2 eps1); the map at the worst time and the
    envelope as the field gives them on the whole grid at once."""
    cfg, ds, _ = small
    g = cfg.study.strain
    surf = cfg.geometry.surface()
    A, Ka, R0, k = surf.A, surf.Ka, surf.R0, surf.k
    res = minimize_scalar(lambda r: -0.5 * A**2 * Ka**2 * math.sin(k * r) ** 2 / (R0 + r) ** 2,
                          bounds=(0.0, surf.dR / 4), method="bounded",
                          options={"xatol": 1e-12})
    closed = {"en02": -res.fun, "en02r": 0.5 * A**2 * (Ka / R0) ** 2}
    alpha = 2 * math.pi * np.arange(g.n_alpha) / g.n_alpha
    R = np.linspace(0.0, surf.dR, g.n_R)
    for i, name in enumerate(ds.surface.values):
        _, motion, T = en06.motion_of(cfg, str(name))
        times = np.linspace(0.0, T, g.n_t)
        field = S.largest_face_strain(surf, motion, 0.0)
        m = S.maximum(field, surf.dR, times, n_alpha=g.n_alpha, n_R=g.n_R, rtol=g.rtol,
                      candidates=g.candidates, max_levels=g.max_levels)
        assert float(ds.max_strain[i]) == m.value
        assert (float(ds.max_strain_R[i]), float(ds.max_strain_alpha[i]),
                float(ds.worst_time[i])) == (m.R, m.alpha, m.t)
        assert float(ds.max_strain[i]) == pytest.approx(closed[str(name)], rel=1e-6)
        assert float(ds.max_stretch[i]) == pytest.approx(math.sqrt(1 + 2 * m.value), rel=1e-12)
        assert float(ds.min_stretch[i]) == pytest.approx(1.0, abs=1e-12)
        full = field(alpha[None, :, None], R[None, None, :], times[:, None, None])
        np.testing.assert_array_equal(ds.strain_envelope.values[i], full.max(axis=(0, 1)))
        np.testing.assert_array_equal(ds.strain_map.values[i],
                                      field(alpha[None, :], R[:, None], np.asarray(m.t)))
    assert float(ds.max_strain_R.sel(surface="en02r")) == 0.0
    assert float(ds.worst_time.sel(surface="en02r")) == pytest.approx(60.0, abs=1e-9)
    for name in ("strain_map", "max_strain", "max_stress", "beyond_ultimate_fraction"):
        assert ds[name].attrs["units"]


def test_materials_stress_and_area_beyond_match_the_model(small: Any) -> None:
    """Per material and surface: the stress maximum is the neo-Hookean / SVK law at the
    maximum's point (at gamma = 0: mu (l^2 - l^-2) and E eps1 / (1 - nu^2)), the face
    strain's maximum strain.maximum's at the material's h, the area beyond eps_u
    strain.area_beyond's."""
    cfg, ds, _ = small
    g, b = cfg.study.strain, cfg.study.beyond
    surf = cfg.geometry.surface()
    for i, name in enumerate(ds.surface.values):
        _, motion, T = en06.motion_of(cfg, str(name))
        for j, mname in enumerate(ds.material.values):
            mat = cfg.study.materials[str(mname)]
            st = S.strains(surf, motion, float(ds.max_stress_alpha[j, i]),
                           float(ds.max_stress_R[j, i]), float(ds.max_stress_t[j, i]))
            e1 = float(st.membrane.principal()[0])
            if mat.law.value == "neo_hookean":
                lam = math.sqrt(1 + 2 * e1)
                law = mat.shear_modulus * (lam**2 - lam**-2)
            else:
                law = mat.youngs_modulus * e1 / (1 - mat.poisson**2)
            assert float(ds.max_stress[j, i]) == pytest.approx(law, rel=1e-10)
            faces = S.largest_face_strain(surf, motion, mat.thickness)
            m = S.maximum(faces, surf.dR, np.linspace(0.0, T, g.n_t), n_alpha=g.n_alpha,
                          n_R=g.n_R, rtol=g.rtol, candidates=g.candidates,
                          max_levels=g.max_levels)
            assert float(ds.max_face_strain[j, i]) == m.value
            ab = S.area_beyond(faces, surf, motion, mat.eps_u, np.linspace(0.0, T, b.n_t),
                               n_alpha=b.n_alpha, n_R=b.n_R)
            assert float(ds.beyond_ultimate_fraction[j, i]) == ab.fraction
            np.testing.assert_array_equal(ds.beyond_ultimate_mask.values[j, i], ab.mask.T)
    # the illustrative fabric (eps_u = 0.03) is exceeded everywhere, the elastomer nowhere
    np.testing.assert_array_equal(ds.beyond_ultimate_fraction.sel(material="fabric"), 1.0)
    np.testing.assert_array_equal(ds.beyond_ultimate_fraction.sel(material="elastomer"), 0.0)


def test_fatigue_part_matches_fatigue_map_and_the_closed_form_check(small: Any) -> None:
    """Damage maps, maximum, where and life as fatigue.fatigue_map gives them; the check
    counts 12 cycles at every point with range and mean at rounding level."""
    cfg, _, ds = small
    fg = cfg.study.fatigue
    surf = cfg.geometry.surface()
    alpha = 2 * math.pi * np.arange(fg.n_alpha) / fg.n_alpha
    R = np.linspace(0.0, surf.dR, fg.n_R)
    for i, name in enumerate(ds.surface.values):
        _, motion, T = en06.motion_of(cfg, str(name))
        for j, mname in enumerate(ds.material.values):
            mat = cfg.study.materials[str(mname)]
            fm = FT.fatigue_map(S.largest_face_strain(surf, motion, mat.thickness),
                                mat.strain_life(), alpha, R, T * np.arange(fg.n_t) / fg.n_t)
            np.testing.assert_array_equal(ds.damage.values[j, i], fm.damage.T)
            np.testing.assert_array_equal(ds.cycles.values[j, i], fm.cycles.T)
            assert (float(ds.max_damage[j, i]), float(ds.life[j, i]), float(ds.worst_R[j, i]),
                    float(ds.worst_alpha[j, i])) == (fm.max_damage, fm.life, fm.R_max,
                                                      fm.alpha_max)
    assert float(ds.life.sel(material="fabric").max()) == 0.0  # mean beyond eps_u: at once
    assert 0.0 < float(ds.life.sel(material="elastomer", surface="en02r")) < float(
        ds.life.sel(material="elastomer", surface="en02"))
    assert float(ds.check_cycles_min) == float(ds.check_cycles_max) == 12.0
    assert float(ds.check_expected) == 12.0
    assert 0.0 <= float(ds.check_range_error) < 1e-14
    assert 0.0 <= float(ds.check_mean_error) < 1e-14


def test_phase_times_land_on_multiples_of_pi_over_m() -> None:
    """EN-02's phi_a at the check's times is n pi / 8 to rounding (every extreme sampled)."""
    cfg = compose(SMALL).obj
    _, motion, T = en06.motion_of(cfg, "en02")
    times = en06.phase_times(motion.phi_a, T, 8)
    assert times.size == 96
    np.testing.assert_allclose(motion.phi_a(times).value, np.arange(96) * math.pi / 8,
                               atol=1e-12)


@pytest.mark.parametrize(("override", "key", "rule"), [
    ("study.fatigue.n_t=100000", "study.fatigue.n_t", "more than 2,000,000"),
    ("study.strain.n_alpha=100000", "study.strain.n_alpha", "more than 2,000,000"),
    ("study.beyond.n_R=1000000", "study.beyond.n_R", "more than 2,000,000"),
    ("study.strain.n_alpha=2", "study.strain.n_alpha", "must be >= 3"),
    ("study.fatigue_check.n_alpha=50", "study.fatigue_check.n_alpha", "must divide"),
    ("study.fatigue_check.samples_per_half_turn=7",
     "study.fatigue_check.samples_per_half_turn", "even number"),
    ("study.fatigue_check.surface=en03", "study.fatigue_check.surface", "must be one of"),
    ("study.materials.fabric.eps_u=-1", "study.materials.fabric.eps_u", "must be > 0"),
])
def test_bad_sizes_and_values_are_refused_in_one_line(override: str, key: str,
                                                      rule: str) -> None:
    """Each is refused before anything runs: one line naming the key, the value, the rule
    (the composed default config with the override set, validated as the pipeline does)."""
    dotted, _, text = override.partition("=")
    data = copy.deepcopy(default_data())
    *path, name = dotted.split(".")
    node = data
    for part in path:
        node = node[part]
    node[name] = yaml.safe_load(text)
    with pytest.raises(ConfigError) as err:
        validate(data, schema=En06Config)
    message = str(err.value)
    assert "\n" not in message
    assert err.value.key == key
    assert override.split("=")[1] in message and rule in message


def test_report_contract_and_opening_lines(small: Any, tmp_path: Path) -> None:
    """The JSON holds the contract's keys with the datasets' values; the markdown opens with
    the computed maximum strain; the figures are written."""
    from creatio.reports.en06 import write_report
    from creatio.store.netcdf import write_dataset

    _, strain, fatigue = small
    paths = []
    for ds in (strain, fatigue):
        ds = ds.copy()
        ds.attrs.update({"study": "en06", "title": "EN-06 test", "config_sha256": "0" * 64})
        paths.append(write_dataset(ds, tmp_path / f"en06_{ds.attrs['part']}.nc"))
    out = write_report(paths, tmp_path / "reports")
    s = json.loads(out["json"].read_text())
    for i, name in enumerate(strain.surface.values):
        v = s["strain"][str(name)]
        assert set(v) >= {"max_strain", "R_m", "alpha_deg", "t_s", "max_stretch",
                          "max_face_strain", "grid"}
        assert v["max_strain"] == float(strain.max_strain[i])
        assert v["alpha_deg"] == pytest.approx(math.degrees(float(strain.max_strain_alpha[i])))
    for j, m in enumerate(strain.material.values):
        v = s["materials"][str(m)]
        assert set(v) >= {"max_stress_Pa", "beyond_ultimate_area_fraction",
                          "life_transport_cycles", "worst_R_m", "worst_alpha_deg",
                          "cycles_per_transport_at_worst"}
        assert v["max_stress_Pa"] == float(strain.max_stress[j].max())
        assert v["life_transport_cycles"] == float(fatigue.life[j].min())
    assert s["fatigue_check"]["cycles_per_point"] == 12.0
    assert s["fatigue_check"]["max_range_error"] == float(fatigue.check_range_error)
    head = "\n".join(out["md"].read_text().splitlines()[:6])
    for value in strain.max_strain.values:
        assert f"{float(value):.4g}" in head
    assert "material coordinates" in head and "illustrative" in head
    assert out["html"].exists()
    for key in ("png", "envelope", "fatigue"):
        assert out[key].stat().st_size > 10_000


def test_parts_units_and_an_unknown_part(small: Any) -> None:
    """The strain and fatigue parts first (the tolerances' follow: test_en06_tolerances),
    every numeric variable with its units and the assumptions stated; a part the study does
    not have is named with the choices."""
    assert [p.name for p in en06.parts(small[0])][:2] == ["en06_strain", "en06_fatigue"]
    for ds in small[1:]:
        assert isinstance(ds, xr.Dataset)
        assert "material coordinates" in ds.attrs["assumptions"]
        for name, var in ds.variables.items():
            if var.dtype.kind in "fiu":
                assert var.attrs.get("units"), name
    with pytest.raises(ValueError, match="part must be one of strain, fatigue, tilt, sobol, "
                       "allocation, joint.*, got 'nothing'"):
        en06.run(small[0], "nothing")
