"""Config validation at the boundary: each rule refused with a message naming key, value, rule."""

from __future__ import annotations

import subprocess
import sys

import pytest

from creatio.errors import ConfigError
from creatio.pipeline.config import applicable, output_root, resolve
from creatio.pipeline.planning import plan
from creatio.studies import registry

BAD = [
    # (study, overrides, key in message, words of the rule)
    ("ct02", ["geometry.R0=0"], "geometry.R0", "must be > 0"),
    ("ct02", ["geometry.R0=-1"], "geometry.R0", "must be > 0"),
    ("ct02", ["geometry.dR=0"], "geometry.dR", "must be > 0"),
    ("ct02", ["geometry.A=0.68"], "geometry.A", "0 <= A < R0"),
    ("ct02", ["geometry.A=-0.1"], "geometry.A", "0 <= A < R0"),
    ("ct02", ["geometry.Kr=0"], "geometry.Kr", "positive integer"),
    ("ct02", ["geometry.Ka=-2"], "geometry.Ka", "positive integer"),
    ("ct02", ["geometry.Kr=1.5"], "geometry.Kr", "Integer"),
    ("ct02", ["geometry.foo=1"], "geometry.foo", "not in"),
    ("ct02", ["study.h=[0.01,0]"], "study.h[1]", "must be > 0"),
    ("ct02", ["study.n_radii=1"], "study.n_radii", ">= 2"),
    ("ct02", ["study.inclinations_deg=[0,95]"], "study.inclinations_deg[1]", "[-90, 90]"),
    ("ct02", ["study.varying_gamma.amplitude=1.0"], "study.varying_gamma",
     "|gamma0| + G <= pi/2"),
    ("ct02", ["study.varying_gamma.amplitude=-0.1"], "study.varying_gamma.amplitude",
     "must be >= 0"),
    ("ct02", ["phases.r.delta=1"], "phases.r.delta", "not used by kind=linear"),
    ("ct02", ["phases.a.kind=helix"], "phases.a.kind", "constant, linear, quintic, sinusoid"),
    ("ct02", ["study.feature_h=0"], "study.feature_h", "must be > 0"),
    ("ct02", ["phases.a.kind=sinusoid", "phases.a.rate=0", "phases.a.amplitude=0.1"],
     "phases.a.kind", "takes only constant, linear"),
    ("en01", ["study.laws.a.a.kind=quintic", "study.laws.a.a.rate=0"], "study.laws.a.a.kind",
     "takes only"),
    ("en01", ["study.pattern.fd_step=0"], "study.pattern.fd_step", "must be > 0"),
    ("en01", ["study.laws.c.gamma.phi0=1.4"], "study.laws.c.gamma", "|gamma0| + G <= pi/2"),
    ("en02", ["phases.T=0"], "phases.T", "must be > 0"),
    ("en02", ["phases.gamma.phi0=100", "phases.gamma.unit=deg"], "phases.gamma",
     "[-pi/2, pi/2]"),
    ("en02", ["sphere.m=0"], "sphere.m", "must be > 0"),
    ("en02", ["sphere.b=-0.1"], "sphere.b", "must be > 0"),
    ("en02", ["sphere.mu=-0.1"], "sphere.mu", "must be >= 0"),
    ("en02", ["sphere.eps=0"], "sphere.eps", "must be > 0"),
    ("en02", ["sphere.g=-9.81"], "sphere.g", "must be >= 0"),
    ("en02", ["solver.dt=0"], "solver.dt", "must be > 0"),
    ("en02", ["solver.dt=-0.001"], "solver.dt", "must be > 0"),
    ("en02", ["solver.refine=1"], "solver.refine", ">= 2"),
    ("en02", ["solver.output_interval=0.003"], "solver.output_interval", "multiple"),
    ("en02", ["solver.method=euler"], "solver.method", "rk4"),
    ("en02", ["solver.dt=abc"], "solver.dt", "Float"),
    ("en02", ["study.initial.R=1.8"], "study.initial.R", "[0, geometry.dR"),
    ("en02", ["study.duration=120.0007"], "study.duration", "integer multiple"),
    ("en02", ["geometry=nowhere"], "geometry", "Could not find"),
    ("en02", ["sphere.muu=0.3"], "sphere.muu", "did you mean sphere.mu?"),
    ("en02", ["+sphere.colour=1"], "sphere.colour", "unknown key"),
    ("en02", ["sphere.mu=nan"], "sphere.mu", "finite"),
    ("en02", ["sphere.m=inf"], "sphere.m", "finite"),
    ("en02", ["solver.dt=-inf"], "solver.dt", "finite"),
]


@pytest.mark.parametrize(("study", "overrides", "key", "rule"), BAD)
def test_each_rule_is_refused_with_key_value_and_rule(study, overrides, key, rule):
    """A broken rule raises ConfigError whose message has the key, the rule and the value."""
    with pytest.raises(ConfigError) as info:
        resolve(study, overrides)
    msg = str(info.value)
    assert key in msg, msg
    assert rule in msg, msg
    assert info.value.key.startswith(key.split("[")[0]), msg
    for ov in overrides:  # the refused key's value, as the user wrote it, is in the message
        name, _, value = ov.partition("=")
        if name == info.value.key:
            assert value in msg, msg


def test_defaults_are_valid_and_hashes_stable_and_distinct():
    """Each default config validates; its hash is reproducible and differs between studies."""
    ids = [s.id for s in registry.STUDIES.values()]
    hashes = {s: resolve(s).sha256 for s in ids}
    assert len(set(hashes.values())) == len(ids)
    assert resolve("en02").sha256 == hashes["en02"]
    assert resolve("en02", ["sphere.mu=0.3"]).sha256 != hashes["en02"]


def test_degrees_are_converted_once():
    """phi_a travel 2160 deg is 12 pi rad in the numeric law (EN-02's pattern turns 360 deg)."""
    law = resolve("en02").obj.phases.laws()[1]
    assert law.delta == pytest.approx(12 * 3.141592653589793, rel=1e-15)
    assert law.T == 120.0


def test_overrides_apply_only_where_the_key_exists():
    """sphere.mu touches the sphere studies only; study.feature_h only CT-02."""
    ovs = ["sphere.mu=0.3", "geometry.A=0.1", "study.feature_h=2e-4"]
    assert applicable("ct02", ovs) == ["geometry.A=0.1", "study.feature_h=2e-4"]
    assert applicable("en01", ovs) == ["geometry.A=0.1"]
    assert applicable("en02", ovs) == ["sphere.mu=0.3", "geometry.A=0.1"]


def test_plan_keys_outputs_by_config_hash_and_refuses_unused_overrides(tmp_path):
    """Default configs keep stable paths; overridden ones go under runs/<hash>."""
    p = plan(["sphere.mu=0.3"], ["ct02", "en02"], data_dir="data")
    assert p["ct02"].root == "data"
    assert p["en02"].root == f"data/runs/{p['en02'].sha256[:12]}"
    assert p["en02"].datasets[0].endswith("en02_dt0.002.nc")
    assert p["en02"].datasets[1].endswith("en02_dt0.001.nc")
    same = plan(["sphere.mu=0.15"], ["en02"])  # equal to the default value: default paths
    assert same["en02"].root == "data"
    with pytest.raises(ConfigError, match="no selected study has these keys"):
        plan(["sphere.mu=0.3"], ["ct02"])
    assert output_root(resolve("ct02"), tmp_path) == tmp_path


def test_cli_refuses_bad_value_nonzero_and_writes_nothing(tmp_path):
    """`creatio run` with a bad value exits non-zero with the message and writes no file."""
    proc = subprocess.run(
        [sys.executable, "-m", "creatio.cli", "run", "study=ct02", "geometry.A=0.9"],
        cwd=tmp_path, capture_output=True, text=True,
    )
    assert proc.returncode == 2
    assert "geometry.A=0.9" in proc.stderr and "0 <= A < R0" in proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_task_refuses_a_config_file_of_another_study_and_a_foreign_dt(tmp_path):
    """A dataset task checks its config file's study and that --part is one of its datasets
    (a sphere study's: one per timestep, dt and dt / refine)."""
    cfg = tmp_path / "en02.yaml"
    cfg.write_text(resolve("en02").yaml)
    out = tmp_path / "x.nc"
    base = [sys.executable, "-m", "creatio.cli", "task", "dataset"]
    wrong_study = subprocess.run([*base, "ct02", str(out), "--config-file", str(cfg)],
                                 cwd=tmp_path, capture_output=True, text=True)
    assert wrong_study.returncode == 2 and "holds study en02" in wrong_study.stderr
    wrong_dt = subprocess.run([*base, "en02", str(out), "--part", "en02_dt0.003",
                               "--config-file", str(cfg)], cwd=tmp_path, capture_output=True,
                              text=True)
    assert wrong_dt.returncode == 2 and "--part='en02_dt0.003'" in wrong_dt.stderr
    assert "en02_dt0.002, en02_dt0.001" in wrong_dt.stderr
    assert not out.exists()


def test_probe_prints_surface_quantities(tmp_path):
    """`creatio probe` reports position, c_t, normal, |velocity| and J at one point."""
    proc = subprocess.run(
        [sys.executable, "-m", "creatio.cli", "probe", "alpha=30", "R=0.5", "t=1.0"],
        cwd=tmp_path, capture_output=True, text=True, check=True,
    )
    out = proc.stdout
    for word in ("position c", "velocity c_t", "unit normal n", "|velocity|", "J "):
        assert word in out
    # Viewer phases (phi_r = 0, phi_a = 29 deg), flat: rho = R0 + R, so x = 1.18 cos 30 deg.
    assert "1.021909976" in out and "0.590000000" in out
    assert list(tmp_path.iterdir()) == []


def test_resolved_configs_are_cached_on_disk_and_invalidated_by_any_conf_edit(tmp_path, repo):
    """A resolution is composed with Hydra once; later processes load it (no Hydra at all);
    editing a file under conf/ composes again and changes the hash."""
    import shutil

    conf = tmp_path / "conf"
    shutil.copytree(repo / "conf", conf)
    env = {**__import__("os").environ, "CREATIO_CONF_DIR": str(conf),
           "CREATIO_CONFIG_CACHE": str(tmp_path / "cache")}
    code = ("import sys; from creatio.pipeline.config import resolve; "
            "r = resolve('ct02', ['study.feature_h=2e-4']); "
            "print(r.sha256, 'hydra' in sys.modules)")

    def run() -> tuple[str, str]:
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, check=True).stdout.split()
        return out[0], out[1]

    first, composed = run()
    second, composed_again = run()
    assert composed == "True" and composed_again == "False" and first == second
    assert first == resolve("ct02", ["study.feature_h=2e-4"]).sha256
    study = conf / "study" / "ct02.yaml"
    study.write_text(study.read_text().replace("n_radii: 9", "n_radii: 11"))
    third, composed_third = run()
    assert composed_third == "True" and third != first


def test_a_warm_processs_kept_compositions_are_dropped_when_conf_changes(tmp_path, repo):
    """What a warm worker composed before forking (config.warm: EN-02's default composition
    and resolution) serves its jobs only while conf/ is unchanged: after an edit, a job's
    forget_if_changed drops them and the sweep base, the family links and the resolution
    are composed again from the edited file."""
    import shutil

    conf = tmp_path / "conf"
    shutil.copytree(repo / "conf", conf)
    env = {**__import__("os").environ, "CREATIO_CONF_DIR": str(conf),
           "CREATIO_CONFIG_CACHE": "off"}
    code = (
        "import pathlib, sys\n"
        "from creatio.pipeline import config\n"
        "config.warm('en02')\n"
        "kept = config.composed('en02')\n"
        "print(config.forget_if_changed(), config.composed('en02') is kept)\n"
        "p = pathlib.Path(sys.argv[1])\n"
        "p.write_text(p.read_text().replace('R: 0.43', 'R: 0.44'))\n"
        "print(config.forget_if_changed(), config.composed('en02') is kept,\n"
        "      config.composed('en02').study.initial.R,\n"
        "      config.resolve('en02').obj.study.initial.R)\n"
    )
    out = subprocess.run([sys.executable, "-c", code, str(conf / "study" / "en02.yaml")],
                         env=env, capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True", "True", "False", "0.44", "0.44"], out


def test_an_optional_key_the_default_leaves_out_still_applies():
    """`snakemake all --config 'overrides=["sphere.beta_deg=2"]'` reaches the sphere studies:
    a key whose null default the canonical text leaves out is applicable where its schema
    has it, not silently dropped; a key no schema has is still left out."""
    from creatio.pipeline.config import applicable

    ovs = ["sphere.beta_deg=2", "sphere.psi_deg=30", "sphere.nope=1"]
    assert applicable("en02", ovs) == ovs[:2]
    assert applicable("ct02", ovs) == []
