"""Trust (issue 28): no user text reaches a shell, no stale result is reused, no unbounded
expansion, every refusal one line. Each class has the issue's example and one more of it."""

from __future__ import annotations

import base64
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from inproc import run_cli

REPO = Path(__file__).resolve().parents[2]


def snakemake(workdir: Path, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """The project's Snakefile in workdir (-c 1), run from workdir (a file an injected
    command touched would land there)."""
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"), "-d", str(workdir),
         "-c", "1", *args],
        capture_output=True, text=True, timeout=timeout, cwd=workdir,
        env={**os.environ, "CREATIO_DEBUG": ""},
    )


def creatio(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None
            ) -> subprocess.CompletedProcess:
    """The command in this process (inproc.py): what it says, writes and returns is the
    test; the tests about the process itself (Ctrl-C, a closed stderr) start their own."""
    return run_cli(*args, cwd=cwd, env=env)


def one_line(proc: subprocess.CompletedProcess, code: int, words: str) -> None:
    """The process failed with `code` and one line of stderr containing `words` (a notice that
    a loop is being compiled, printed on a cold cache before the run, is not that line)."""
    assert proc.returncode == code, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    lines = [ln for ln in proc.stderr.strip().splitlines()
             if ln.startswith("creatio") and not ln.startswith("creatio: compiling ")]
    assert len(lines) == 1 and words in lines[0], proc.stderr[-3000:]


# ------------------------------------------------------------- class 1: shell injection
# (the --config entry as typed, the title the study gets, the files it must not create)
INJECTIONS = {
    "issue-example": ("overrides=['study.title=''$(touch injected)''']",
                      "$(touch injected)", ("injected",)),
    "backticks-semicolon-newline": (
        'overrides=["study.title=\'`touch pwned`; touch pwned2 #\\n$(touch pwned3)\'"]',
        "`touch pwned`; touch pwned2 #\n$(touch pwned3)", ("pwned", "pwned2", "pwned3")),
}


@pytest.mark.parametrize("name", list(INJECTIONS))
def test_override_text_never_reaches_a_shell(tmp_path, name):
    """Snakemake re-invokes itself through /bin/sh for the `run:` config rules (and for every
    job on a cluster), writing --config with repr(): `$(...)` in an override ran. The title
    now arrives verbatim in the config, the dataset and the report; no command ran."""
    entry, title, planted = INJECTIONS[name]
    proc = snakemake(tmp_path, "all", "--config", entry, 'studies=["ct02"]')
    assert proc.returncode == 0, proc.stderr[-3000:]
    for where in (tmp_path, tmp_path / "data", REPO):
        assert not any((where / f).exists() for f in planted), f"injected into {where}"
    (config,) = tmp_path.glob("data/runs/*/configs/ct02.yaml")
    assert yaml.safe_load(config.read_text())["study"]["title"] == title
    import xarray as xr

    (dataset,) = tmp_path.glob("data/runs/*/studies/ct02/ct02.nc")
    with xr.open_dataset(dataset) as ds:
        assert ds.attrs["title"] == title


@pytest.mark.parametrize(("entry", "title"), [
    ("overrides=[\"study.title='a b'\"]", "a b"),
    # YAML single quotes ('' is one '), inside them Hydra's quoted string (\' is one ')
    ("overrides=['study.title=''it\\''s \"a b\"''']", "it's \"a b\""),
])
def test_quoted_values_work_end_to_end(tmp_path, entry, title):
    """`study.title='a b'` failed with a shell syntax error; quotes of both kinds pass."""
    proc = snakemake(tmp_path, "all", "--config", entry, 'studies=["ct02"]',
                     "--until", "study_config")
    assert proc.returncode == 0, proc.stderr[-3000:]
    (config,) = tmp_path.glob("data/runs/*/configs/ct02.yaml")
    assert yaml.safe_load(config.read_text())["study"]["title"] == title


def test_re_invoked_jobs_get_only_shell_inert_config_text():
    """What Snakemake writes into a re-invoked job's command line is one entry of URL-safe
    base64 (no quote, `$`, backtick, `;`, space or newline), which decodes to exactly the
    config the invocation parsed."""
    from types import SimpleNamespace

    from snakemake.cli import parse_config

    from creatio.pipeline.planning import PASSED_CONFIG, pass_config_safely

    typed = ["overrides=['study.title=''$(touch x)''', \"a=`b`;\\nc\"]", "studies=[ct02]"]
    settings = SimpleNamespace(config_args=list(typed))
    main = parse_config(typed)
    pass_config_safely(settings, dict(main))
    (passed,) = settings.config_args
    key, _, text = passed.partition("=")
    assert key == PASSED_CONFIG and set(text) <= set(
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_=")
    job_config = parse_config(settings.config_args)  # what the re-invoked job parses
    job_settings = SimpleNamespace(config_args=list(settings.config_args))
    pass_config_safely(job_settings, job_config)
    assert job_config == main and job_settings.config_args == settings.config_args
    assert json.loads(base64.urlsafe_b64decode(text)) == typed


def test_sweep_values_with_shell_text_stay_text(tmp_path):
    """A sweep's axes reach its batch jobs' command line: values holding `$(...)`, `;` and
    backticks are points like any other (titles of two ct02 points), and run nothing."""
    import xarray as xr

    proc = snakemake(tmp_path, "sweep", "--config", "study=ct02",
                     "sweep=[\"study.title='$(touch a)','b;`touch c`'\"]")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert not any((tmp_path / f).exists() for f in ("a", "c"))
    (path,) = tmp_path.glob("data/sweeps/*/sweep.nc")
    with xr.open_dataset(path) as ds:
        assert list(ds.study__title.values) == ["$(touch a)", "b;`touch c`"]
        assert list(ds.status.values) == ["ok", "ok"]


# ------------------------------------------------------------------ class 3: stale results
def _counts(path: Path) -> dict[str, int]:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return {k: int(ds.attrs[k]) for k in ("computed", "reused", "refused", "failed")
                if k in ds.attrs}


def test_sweep_points_are_reused_only_by_the_same_code(tmp_path, monkeypatch):
    """The issue's case: after a code change a wider sweep mixed old rows with new ones. A
    point is reused only from a batch that recorded the current datasets code version."""
    from creatio.pipeline import sweep

    data = str(tmp_path / "data")
    base = ["phases.T=2.0"]
    narrow = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2"], base, data, batch_size=2)
    assert _counts(sweep.run_batch(narrow, 0)) == {"computed": 2, "reused": 0, "refused": 0,
                                                 "failed": 0}
    wide = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2,0.3"], base, data, batch_size=3)
    assert _counts(sweep.run_batch(wide, 0)) == {"computed": 1, "reused": 2, "refused": 0,
                                                 "failed": 0}
    monkeypatch.setattr(sweep, "_code", lambda: "0123456789ab")  # new code
    wider = sweep.plan_sweep("en02", ["sphere.mu=0.05,0.1,0.2,0.3"], base, data, batch_size=4)
    assert _counts(sweep.run_batch(wider, 0)) == {"computed": 4, "reused": 0, "refused": 0,
                                                 "failed": 0}


def test_multirun_recomputes_batches_of_other_code(tmp_path, monkeypatch):
    """`creatio run -m` (write_sweep with compute_missing) reused any batch file present;
    one of other code is computed again, a current one kept."""
    from creatio.pipeline import sweep

    monkeypatch.chdir(tmp_path)
    plan = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2"], ["phases.T=2.0"], batch_size=2)
    sweep.write_sweep(plan, compute_missing=True)
    batch = Path(plan.batch_file(0))
    first = batch.stat().st_mtime_ns
    sweep.write_sweep(plan, compute_missing=True)
    assert batch.stat().st_mtime_ns == first  # same code: kept
    monkeypatch.setattr(sweep, "_code", lambda: "0123456789ab")
    sweep.write_sweep(plan, compute_missing=True)
    assert batch.stat().st_mtime_ns != first
    assert _counts(batch) == {"computed": 2, "reused": 0, "refused": 0,
                                                 "failed": 0}


# ------------------------------------------------------- class 2: sweeps bypass validation
def _rows(path: Path) -> list[tuple[str, str]]:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        return [(str(s), str(m)) for s, m in zip(ds.status.values, ds.message.values,
                                                 strict=True)]


def test_a_non_finite_sweep_point_is_invalid_with_its_reason(tmp_path):
    """The issue's example: `geometry.R0=0.68,inf` on CT-02 ended "ok" full of NaN. The
    point meets the single run's validation and is recorded invalid, the other one runs."""
    from creatio.pipeline import sweep

    plan = sweep.plan_sweep("ct02", ["geometry.R0=0.68,inf"], [], str(tmp_path / "data"),
                            batch_size=2)
    (ok, refused) = _rows(sweep.run_batch(plan, 0))
    assert ok == ("ok", "")
    assert refused == ("invalid", "invalid config: geometry.R0=inf: must be a finite number")


@pytest.mark.parametrize("key", ["sphere.mu", "sphere.g", "phases.T", "sphere.b",
                                 "sphere.eps"])
def test_inf_and_tiny_sweep_points_never_crash_a_batch(tmp_path, key):
    """An inf or 1e-300 point of mu, g, T, b or eps crashed its batch and so the sweep; each
    is refused as a single run refuses it, in one line naming the key, and the rest run."""
    from creatio.pipeline import sweep
    from creatio.pipeline.config import resolve

    default = resolve("en02").data
    for part in key.split("."):
        default = default[part]
    plan = sweep.plan_sweep("en02", [f"{key}={default},inf,1e-300"], ["phases.T=2.0"]
                            if key != "phases.T" else [], str(tmp_path / "data"), batch_size=3)
    rows = _rows(sweep.run_batch(plan, 0))
    assert rows[0][0] in ("ok", "contact_lost"), rows
    for (status, message), value in zip(rows[1:], ("inf", "1e-300"), strict=True):
        # phases.T is checked through the key that follows it (study.duration: ${phases.T})
        named = "study.duration" if key == "phases.T" else key
        assert status == "invalid" and message.startswith(f"invalid config: {named}="), message
        with pytest.raises(Exception) as single:  # the single run's refusal, word for word
            resolve("en02", [f"{key}={value}"])
        assert message == str(single.value)


def test_a_point_failing_inside_its_run_is_recorded_and_the_rest_run(tmp_path, monkeypatch):
    """A run that raises (past validation) is one `failed` row with a one-line message; the
    batch goes on and the point is never reused."""
    from creatio.pipeline import sweep

    real = sweep._run_point

    def flaky(entry, obj):
        if obj.sphere.mu == 0.2:
            raise FloatingPointError("overflow in the right-hand side\nsecond line")
        return real(entry, obj)

    monkeypatch.setattr(sweep, "_run_point", flaky)
    plan = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2,0.3"], ["phases.T=2.0"],
                            str(tmp_path / "data"), batch_size=3)
    path = sweep.run_batch(plan, 0)
    rows = _rows(path)
    assert [s for s, _ in rows][1] == "failed" and "failed" not in (rows[0][0], rows[2][0])
    assert rows[1][1].startswith("FloatingPointError: overflow in the right-hand side at ")
    assert "\n" not in rows[1][1]
    assert _counts(path)["failed"] == 1
    monkeypatch.setattr(sweep, "_run_point", real)
    assert _counts(sweep.run_batch(plan, 0)) == {"computed": 1, "reused": 2, "refused": 0,
                                                 "failed": 0}


def test_a_multirun_point_is_validated_like_a_single_run(tmp_path):
    """`creatio run -m` (Hydra's multirun syntax) goes through the same batches: the inf
    point is invalid with the single run's message, exit 0, the aggregate written."""
    import xarray as xr

    proc = creatio("run", "-m", "study=ct02", "geometry.R0=0.68,inf", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (path,) = tmp_path.glob("data/sweeps/*/sweep.nc")
    with xr.open_dataset(path) as ds:
        assert list(ds.status.values) == ["ok", "invalid"]
        assert "geometry.R0=inf: must be a finite number" in str(ds.message.values[1])


# ------------------------------------------- class 4: interpolations from the environment
def test_an_env_interpolation_in_an_override_is_refused_in_one_line(tmp_path):
    """The issue's example: `${oc.env:FOO}` copied FOO into the datasets, and the config
    cache keyed the unresolved text (FOO=first, then second: same run, title "first").
    Refused, exit 2, one line naming the key; nothing written, whatever FOO holds."""
    for foo in ("first", "second"):
        proc = snakemake(tmp_path, "all", "--config", 'overrides=["study.title=${oc.env:FOO}"]',
                         'studies=["ct02"]')
        one_line(proc, 2, "invalid config: study.title='${oc.env:FOO}': interpolations")
        assert foo not in proc.stderr
        assert not (tmp_path / "data").exists()
    proc = creatio("run", "study=ct02", "study.title=${oc.env:FOO}", cwd=tmp_path,
                   env={"FOO": "first"})
    one_line(proc, 2, "study.title='${oc.env:FOO}': interpolations")
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("call", ["quoted", "escaped", "reference", "sweep", "probe", "scene"])
def test_every_way_in_refuses_interpolations(call, monkeypatch):
    """Quoted (`'${oc.env:X}'`), escaped (a literal `${` that a later pass would resolve) and
    plain references are refused alike, in a sweep axis, a probe and a scene override too."""
    from creatio.errors import ConfigError
    from creatio.pipeline.config import resolve
    from creatio.pipeline.sweep import parse_axes
    from creatio.scenes.config import resolve as resolve_scene

    monkeypatch.setenv("CREATIO_SECRET", "leaked")
    attempts = {
        "quoted": lambda: resolve("en02", ["study.title='${oc.env:CREATIO_SECRET}'"]),
        "escaped": lambda: resolve("en02", ["study.title='\\${oc.env:CREATIO_SECRET}'"]),
        "reference": lambda: resolve("en02", ["sphere.mu=${sphere.eps}"]),
        "sweep": lambda: parse_axes(["sphere.mu=0.1,${oc.env:CREATIO_SECRET}"]),
        "scene": lambda: resolve_scene("en02", ["scene.title=${oc.env:CREATIO_SECRET}"]),
        "probe": None,
    }
    if call == "probe":
        proc = creatio("probe", "alpha=${oc.env:CREATIO_SECRET}")
        one_line(proc, 2, "alpha='${oc.env:CREATIO_SECRET}': interpolations")
        return
    with pytest.raises(ConfigError, match=r"interpolations \(\$\{\.\.\.\}\) are not accepted") \
            as err:
        attempts[call]()
    assert "leaked" not in str(err.value) and "\n" not in str(err.value)


def test_a_config_file_holding_a_resolver_is_refused(tmp_path):
    """A task's config file is resolved by OmegaConf too: a resolver in it (a file edited
    by hand, or planted) is refused by key; the environment is not read, no dataset made."""
    from creatio.pipeline.config import resolve

    data = yaml.safe_load(resolve("ct02").yaml)
    data["study"]["title"] = "${oc.env:CREATIO_SECRET}"
    config = tmp_path / "ct02.yaml"
    config.write_text(yaml.safe_dump(data))
    out = tmp_path / "ct02.nc"
    proc = creatio("task", "dataset", "ct02", str(out), "--config-file", str(config),
                   env={"CREATIO_SECRET": "leaked"})
    one_line(proc, 2, "study.title='${oc.env:CREATIO_SECRET}': resolvers")
    assert "leaked" not in proc.stderr and not out.exists()
    assert list(tmp_path.iterdir()) == [config]


# -------------------------------------------- class 5: sizes checked before expansion
@pytest.mark.parametrize(("sweep", "limit", "size"), [
    (["sphere.mu=range(0,100000000,1)"], 10_000_000, "100,000,000"),
    (["sphere.mu=range(0,1e8,1)"], 10_000_000, "100,000,000"),  # a float range
    (["sphere.mu=range(0,3000,1)", "phases.T=range(1,3001,1)"], 1_000_000, "9,000,000"),
])
def test_a_huge_sweep_is_refused_before_it_is_expanded(sweep, limit, size):
    """The issue's example: a range was expanded before the size check (1e8 points took
    7 GB before the refusal). The size is computed from the override: refused in one line
    with the count, having allocated almost nothing."""
    import tracemalloc

    from creatio.errors import ConfigError
    from creatio.pipeline.sweep import plan_sweep

    tracemalloc.start()
    try:
        with pytest.raises(ConfigError, match=f"'{size} points': exceeds {limit:,}"):
            plan_sweep("en02", sweep, [], max_points=limit)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, f"{peak / 1e6:.0f} MB allocated before the refusal"


def test_a_large_allowed_sweep_gives_its_jobs_the_range_not_its_values():
    """With a raised limit, 1e6 points planned: each batch job's command carries the range
    as typed (it held every value: 4000 jobs x 7 MB took 24 GB) and the raised limit, and a
    job re-plans the very same sweep from it."""
    import shlex

    from creatio.pipeline.sweep import plan_sweep

    plan = plan_sweep("en02", ["sphere.mu=range(0,1000000,1)"], [], max_points=1_000_000)
    assert plan.n_points == 1_000_000 and plan.n_batches == 4000
    args = plan.cli_args()
    assert args == ("--study en02 --sweep 'sphere.mu=range(0,1000000,1)' --batch-size 250 "
                    "--max-points 1000000")
    words = shlex.split(args)
    again = plan_sweep(words[1], [words[3]], [], batch_size=int(words[5]),
                       max_points=int(words[7]))
    assert again.name == plan.name and again.overrides(999_999) == ("sphere.mu=999999",)


@pytest.mark.parametrize(("target", "overrides", "key"), [
    ("scene:surface_family", ["scene.gamma_step_deg=1e-6"], "scene.gamma_step_deg"),  # issue's
    ("scene:en02", ["scene.playback.fps=4000"], "scene.playback.fps"),
    ("ct02", ["study.n_radii=100000"], "study.n_radii"),
    ("en01", ["study.regularity.n_angles=100000"], "study.regularity.n_angles"),
    ("en01", ["study.pattern.sample_interval=1e-5"], "study.pattern.sample_interval"),
    ("en02", ["solver.dt=1e-5", "solver.output_interval=1e-5"], "solver.output_interval"),
    ("en02f", ["study.cycles_s=[200000]"], "solver.output_interval"),
    ("en02f", ["study.drop.duration=1e5"], "study.drop.duration"),
])
def test_every_computable_size_is_checked_at_validation(target, overrides, key):
    """A grid, a history, a slider or a scene's frames is sized from the config: beyond its
    bound it is refused by key, in one line, before anything is allocated (gamma_step_deg
    = 1e-6 passed validation and died in a MemoryError)."""
    from creatio.errors import ConfigError
    from creatio.pipeline.config import resolve
    from creatio.scenes.config import resolve as resolve_scene

    kind, _, name = target.rpartition(":")
    with pytest.raises(ConfigError) as err:
        (resolve_scene if kind == "scene" else resolve)(name, overrides)
    assert str(err.value).startswith(f"invalid config: {key}=") and "more than" in str(err.value)
    assert "\n" not in str(err.value)


def test_the_sweep_limit_has_a_ceiling(tmp_path):
    """--config sweep_max_points beyond 10 million is refused by the workflow's schema in one
    line (the aggregate holds every point in memory), before any planning."""
    proc = snakemake(tmp_path, "sweep", "-n", "--config", "study=en02",
                     'sweep=["sphere.mu=range(0,100000000,1)"]', "sweep_max_points=100000000")
    one_line(proc, 2, "sweep_max_points=100000000")
    assert "10000000" in proc.stderr


# ------------------------------------------------------ class 6: refusals in one line
@pytest.mark.parametrize(("entry", "words"), [
    ('scenes=["xx"]', "scenes=['xx']: must be among"),  # the example
    ('overrides=["scene.playback.fps=0"]', "scene.playback.fps=0.0: must be finite and > 0"),
    ('overrides=["sphere.muu=0.3"]', "sphere.muu='0.3': unknown key (did you mean sphere.mu?)"),
])
def test_a_refused_scene_config_is_one_line(tmp_path, entry, words):
    """Scene planning raised InputFunctionException with a traceback; now creatio's line,
    exit 2, nothing planned or written."""
    proc = snakemake(tmp_path, "scenes", "--config", entry)
    one_line(proc, 2, words)
    assert "InputFunctionException" not in proc.stderr
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize(("args", "words"), [
    (["study=en02f", "study.cycles_s=[0.0015]"],  # the example
     "study.cycles_s[0]=0.0015: must be an integer multiple of solver.dt = 0.001"),
    (["study=en02g", "sphere.g=0"], "sphere.g=0.0: must be > 0: every EN-02G run starts"),
])
def test_checks_that_built_problems_are_validation_now(tmp_path, args, words):
    """EN-02F's cycles and EN-02G's gravity reached the numeric core's ValueError, keyless;
    they are refused at validation naming the key, exit 2, nothing written."""
    proc = creatio("run", *args, cwd=tmp_path)
    one_line(proc, 2, words)
    assert "ValueError" not in proc.stderr and not (tmp_path / "data").exists()


def test_a_problem_refusal_past_the_rules_is_named_by_its_key(monkeypatch):
    """The safety net behind the rules: a value only a run's problem refuses becomes a
    ConfigError naming the config key of the problem's field."""
    from creatio.errors import ConfigError
    from creatio.pipeline.config import resolve
    from creatio.studies import schema

    cfg = resolve("en02").obj

    def refuse(self):
        raise ValueError("eps must be finite and > 0, got 1e-31")

    monkeypatch.setattr(schema.DynamicConfig, "stability_problems", refuse)
    with pytest.raises(ConfigError) as err:
        cfg.check()
    assert str(err.value) == ("invalid config: sphere.eps=0.01: the run refuses it: eps must "
                              "be finite and > 0, got 1e-31")


# ------------------------------ stale names (import circles: tests/architecture/test_layers.py)
def test_no_stale_module_names_in_the_workflow():
    """workflow/rules/release.smk (now workflows/) named creatio.release, which does not
    exist; every creatio.X the Snakefile and the rules name is a module (or a name in
    one)."""
    import importlib
    import re

    texts = [REPO / "Snakefile", *sorted((REPO / "workflows").rglob("*.smk"))]
    for path in texts:
        for name in re.findall(r"(?<![/\w])creatio(?:\.\w+)+", path.read_text()):
            if name.endswith((".yaml", ".yml")):  # a file (envs/creatio.yaml), not a module
                continue
            module, _, attr = name.rpartition(".")
            try:
                importlib.import_module(name)
            except ImportError:
                assert hasattr(importlib.import_module(module), attr), f"{path.name}: {name}"


# ------------------------------------------------ class 7: releases and diffs trust less
def _copy_release(tmp_path: Path) -> tuple[Path, Path]:
    """(data dir, release dir): the committed release 0.1.0 copied under tmp_path/data, and
    its files copied into data/ as the current outputs (a diff of them finds nothing)."""
    import shutil

    data = tmp_path / "data"
    release = data / "releases" / "0.1.0"
    shutil.copytree(REPO / "data" / "releases" / "0.1.0", release)
    for path in release.rglob("*"):
        path.chmod(0o644 if path.is_file() else 0o755)
        if path.is_file() and path.name != "MANIFEST.json":
            target = data / path.relative_to(release)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)
    return data, release


def test_a_deleted_or_changed_release_file_fails_the_diff_in_one_line(tmp_path):
    """The issue's example: with a release file deleted, `creatio diff 0.1.0 data` exited 0
    with a warning, and a sha256 mismatch was a warning. Both exit 1 in one line naming the
    file, with nothing compared; the intact release compares clean (exit 0)."""
    data, release = _copy_release(tmp_path)
    assert creatio("diff", "0.1.0", "data", "--studies", "ct02", cwd=tmp_path).returncode == 0
    (release / "studies" / "ct02" / "ct02.nc").unlink()
    proc = creatio("diff", "0.1.0", "data", cwd=tmp_path)
    one_line(proc, 1, "studies/ct02/ct02.nc: missing")
    assert proc.stdout == ""
    report = release / "reports" / "en01.json"
    report.write_bytes(report.read_bytes() + b" ")
    proc = creatio("diff", "data", "0.1.0", cwd=tmp_path)
    one_line(proc, 1, "reports/en01.json: sha256")
    proc = creatio("release", "verify", "0.1.0", cwd=tmp_path)
    one_line(proc, 1, "2 problem(s): studies/ct02/ct02.nc: missing; reports/en01.json: sha256")


@pytest.mark.parametrize("bad", ["../../../../etc/hostname", "/etc/hostname",
                                 "studies/../../../x.nc", ".hidden/x.nc"])
def test_manifest_paths_outside_the_release_are_refused(tmp_path, bad):
    """MANIFEST paths like ../../../../etc/hostname were followed by verify and diff; a
    manifest naming any file outside its release is damaged: one line, exit 2."""
    data, release = _copy_release(tmp_path)
    manifest = json.loads((release / "MANIFEST.json").read_text())
    manifest["files"][0]["path"] = bad
    (release / "MANIFEST.json").write_text(json.dumps(manifest))
    for args in (["release", "verify", "0.1.0"], ["diff", "0.1.0", "data"]):
        proc = creatio(*args, cwd=tmp_path)
        one_line(proc, 2, f"path {bad!r} lies outside the release")


def test_release_list_survives_null_fields_and_names_a_damaged_manifest(tmp_path):
    """`creatio release list` crashed on null fields; it lists such a release, and a
    damaged one as damaged, and goes on to the next."""
    import shutil

    data, release = _copy_release(tmp_path)
    manifest = json.loads((release / "MANIFEST.json").read_text())
    for key in ("created", "total_size"):
        manifest[key] = None
    manifest["studies"]["ct02"] = None
    (release / "MANIFEST.json").write_text(json.dumps(manifest))
    broken = data / "releases" / "0.2.0"
    shutil.copytree(release, broken)
    (broken / "MANIFEST.json").write_text(json.dumps({**manifest, "files": None}))
    proc = creatio("release", "list", cwd=tmp_path)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("0.1.0 ") and "13 files" in lines[0] and "? kB" in lines[0]
    assert lines[1].startswith("0.2.0") and "damaged: " in lines[1]


def test_an_empty_output_is_refused_even_when_only_fingerprinted(tmp_path):
    """A 0-byte figure or table (a killed writer's) was recorded in the manifest without a
    word; released or only fingerprinted, an empty file is refused by name."""
    from creatio.errors import ReleaseError
    from creatio.pipeline.release import Layout, StudyFiles, make_release

    data, _ = _copy_release(tmp_path)
    (data / "reports" / "ct02.png").write_bytes(b"")
    layout = Layout((StudyFiles("ct02", "0" * 64, ("studies/ct02/ct02.nc",),
                                ("reports/ct02.json", "reports/ct02.png")),), ())
    with pytest.raises(ReleaseError, match=r"empty files .*reports/ct02\.png"):
        make_release("0.2.0", data, layout=layout)
    assert not (data / "releases" / "0.2.0").exists()


def test_a_killed_release_leaves_no_temporary_directory_for_good(tmp_path):
    """SIGKILL of `creatio release` left `.X.tmp-PID/` for good; the next release removes
    every one whose process is gone (read-only files included) and keeps a live one's."""
    import signal

    data, _ = _copy_release(tmp_path)
    releases = data / "releases"
    proc = subprocess.Popen(["sleep", "60"])
    try:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        dead = releases / f".0.2.0.tmp-{proc.pid}"
        (dead / "studies").mkdir(parents=True)
        (dead / "studies" / "x.nc").write_bytes(b"partial")
        (dead / "studies" / "x.nc").chmod(0o444)
        live = releases / f".0.3.0.tmp-{os.getppid()}"
        live.mkdir()
        proc = creatio("release", "0.2.0", cwd=tmp_path)
        assert not dead.exists() and live.exists()
        assert "Traceback" not in proc.stderr  # refused or not, the leftover went first
    finally:
        live.rmdir()


def test_the_diff_rule_reruns_when_a_release_file_changes(tmp_path):
    """`snakemake diff` ignored edited release files: its rule carries a digest of the
    release's files, which an edit, a deletion or a restore changes."""
    from creatio.pipeline.release import workflow_release_digest

    data, release = _copy_release(tmp_path)
    before = workflow_release_digest("0.1.0", data)
    report = release / "reports" / "ct02.md"
    text = report.read_bytes()
    report.write_bytes(text + b"\n")
    edited = workflow_release_digest("0.1.0", data)
    report.unlink()
    deleted = workflow_release_digest("0.1.0", data)
    report.write_bytes(text)
    assert len({before, edited, deleted}) == 3
    assert workflow_release_digest("0.1.0", data) == before
    rule = (REPO / "workflows" / "rules" / "release.smk").read_text()
    assert "release=lambda wc: _release.workflow_release_digest(wc.version)" in rule


# --------------------------------------------------------------- class 8: absurd "ok"
@pytest.mark.parametrize(("args", "words"), [
    (["study=en02f", "study.cycles_s=[0.001]", "study.restitutions=[0.0]"],  # the issue's
     "energy residual 1.79e+26 J exceeds 1000 m g (R0 + dR) = 2.35e+04 J"),
])
def test_a_run_whose_own_checks_are_absurd_never_ends_ok(tmp_path, args, words):
    """EN-02F over a 1 ms cycle ended ok with a residual of 1.8e26 J and 487 m between its
    timesteps: it ends with exit 1 in one line naming the check, its datasets say
    checks_failed (the run's own status beside it), and no report is written. (The other
    example, eps = 1e-30 under radau5, wrote two rows at t = 0: the core writes a row once
    now, tests/dynamics/test_progress.py; the check of repeated times is tested below.)"""
    import xarray as xr

    proc = creatio("run", *args, cwd=tmp_path)
    one_line(proc, 1, words)
    assert "no report written" in proc.stderr
    assert not list(tmp_path.glob("data/runs/*/reports"))
    datasets = sorted(tmp_path.glob("data/runs/*/studies/*/*_dt*.nc"))
    assert len(datasets) == 2
    for path in datasets:
        with xr.open_dataset(path) as ds:
            assert ds.attrs["status"] == "checks_failed" and ds.attrs["checks"]
            assert "run_status" in ds.attrs


def test_the_bounds_pass_every_published_run_and_catch_just_beyond():
    """The released EN-02 and EN-02R datasets (residuals ~1e-14 J) pass; a residual just
    beyond 1000 m g (R0 + dR), a NaN residual of an energy-integrating run, repeated times
    and a partner further than R0 + dR are each named."""
    import numpy as np
    import xarray as xr

    from creatio.pipeline.checks import dataset_problems, run_problems

    release = REPO / "data" / "releases" / "0.1.0" / "studies"
    for name in ("en02/en02_dt0.002.nc", "en02r/en02r_dt0.002.nc"):
        with xr.open_dataset(release / name) as ds:
            ds.load()
        assert run_problems([ds]) == []
        bound = 1e3 * 1.0 * 9.81 * (0.68 + 1.72)  # m = 1 kg, R0 + dR = 2.4 m
        ds.attrs["max_energy_residual"] = 0.999 * bound
        assert dataset_problems(ds) == []
        ds.attrs["max_energy_residual"] = 1.001 * bound
        assert dataset_problems(ds) == [f"energy residual {1.001 * bound:.3g} J exceeds 1000 m "
                                        f"g (R0 + dR) = {bound:.3g} J"]
        ds.attrs["max_energy_residual"] = float("nan")
        assert "not finite" in dataset_problems(ds)[0]
        ds.attrs["max_energy_residual"] = 1e-14
        twice = xr.concat([ds.isel(time=[0]), ds], dim="time")
        assert "1 output time(s) repeat" in dataset_problems(twice)[0]
        far = ds.copy(deep=True)
        far["centre"] = far.centre + np.array([2.5, 0.0, 0.0])
        far.attrs["dt"] = 0.001
        (problem,) = run_problems([ds, far])
        assert "end up 2.5 m apart, more than the membrane's size R0 + dR = 2.4 m" in problem


def test_a_sweep_point_with_absurd_checks_is_recorded_checks_failed(tmp_path, monkeypatch):
    """In a sweep the same point is a row with status checks_failed and the reason; the
    others run as usual. The absurd point is radau5 at eps = 1e-30 as the core wrote it
    before it wrote a row once (t = 0 twice, put back here)."""
    import xarray as xr

    from creatio.pipeline import checks, sweep

    real = checks.dataset_problems

    def start_written_twice(ds):
        if ds.attrs.get("status") == "step_size_collapse":
            ds = xr.concat([ds.isel(time=[0]), ds], dim="time")
        return real(ds)

    monkeypatch.setattr(checks, "dataset_problems", start_written_twice)

    plan = sweep.plan_sweep("en02", ["sphere.eps=0.01,1e-30"],
                            ["solver=radau5", "phases.T=2.0"], str(tmp_path / "data"),
                            batch_size=2)
    (good, bad) = _rows(sweep.run_batch(plan, 0))
    assert good[0] != "checks_failed"
    assert bad[0] == "checks_failed" and "repeat" in bad[1] and "step_size_collapse" in bad[1]


# ------------------------------------------------------------------ class 9: the caches
CACHED = '''
from creatio.dynamics.jit import njit

@njit(cache=True)
def triple(x):
    return 3.0 * x

print(triple(2.0),
      sum(triple.stats.cache_hits.values()))
'''


def _cached(tmp_path: Path) -> subprocess.CompletedProcess:
    """Compile (or load) a small cached function with the project's numba cache under
    tmp_path/numba; prints its result and how many entries it loaded from the cache."""
    (tmp_path / "cachedmod.py").write_text(CACHED)
    return subprocess.run([sys.executable, "cachedmod.py"], capture_output=True, text=True,
                          cwd=tmp_path, env={**os.environ, "CREATIO_NUMBA_CACHE":
                                             str(tmp_path / "numba")})


def test_a_truncated_numba_cache_is_rebuilt_with_one_warning(tmp_path):
    """The issue's example: truncated cache files failed every run (UnpicklingError, no file
    named) and were never repaired. The damaged entry is named once, removed and compiled
    anew; the next process loads the rebuilt entry."""
    first = _cached(tmp_path)
    assert first.returncode == 0 and first.stdout.split() == ["6.0", "0"], first.stderr
    files = [p for p in (tmp_path / "numba").rglob("*") if p.suffix in (".nbi", ".nbc")]
    assert files
    for path in files:
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    damaged = _cached(tmp_path)
    assert damaged.returncode == 0 and damaged.stdout.split() == ["6.0", "0"]
    warnings = damaged.stderr.strip().splitlines()
    assert len(warnings) == 1 and "could not be loaded (UnpicklingError" in warnings[0]
    assert ".nbi" in warnings[0] and "rebuilds it" in warnings[0]
    again = _cached(tmp_path)
    assert again.returncode == 0 and again.stdout.split() == ["6.0", "1"] and again.stderr == ""


def test_garbage_in_a_numba_cache_entry_is_rebuilt(tmp_path):
    """Another damage: a data file replaced by bytes that are no pickle at all."""
    assert _cached(tmp_path).returncode == 0
    for path in (tmp_path / "numba").rglob("*.nbc"):
        path.write_bytes(b"not a pickle, not numba's")
    damaged = _cached(tmp_path)
    assert damaged.returncode == 0 and damaged.stdout.split() == ["6.0", "0"]
    assert damaged.stderr.count("\n") == 1 and "could not be loaded" in damaged.stderr
    assert _cached(tmp_path).stdout.split() == ["6.0", "1"]


def test_an_unwritable_numba_cache_runs_uncached_with_one_warning(monkeypatch, capsys):
    """A full cache filesystem failed runs instead of running uncached: a save that fails
    with ENOSPC (every save, here) gives one warning and the compiled function runs."""
    import errno

    from numba.core import caching

    from creatio.dynamics import jit

    def full(self, name, data):
        raise OSError(errno.ENOSPC, "No space left on device", self._data_path(name))

    monkeypatch.setattr(caching.IndexDataCacheFile, "_save_data", full)
    monkeypatch.setattr(jit, "_WARNED", set())

    @jit.njit(cache=True)
    def square_plus_one(x):
        return x * x + 1.0

    @jit.njit(cache=True)
    def cube(x):
        return x * x * x

    assert square_plus_one(3.0) == 10.0 and cube(2.0) == 8.0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device): running uncached" in err


@pytest.fixture
def config_cache(tmp_path, monkeypatch):
    """The config cache in tmp_path/configs, the in-process memo cleared around the test."""
    from creatio.pipeline import config

    monkeypatch.setenv("CREATIO_CONFIG_CACHE", str(tmp_path / "configs"))
    config._resolve.cache_clear()
    yield tmp_path / "configs"
    config._resolve.cache_clear()


def _entry(cache: Path, overrides: tuple[str, ...] = ()) -> Path:
    from creatio.pipeline import config

    path = config._cache_path(config._cache_spec("en02", overrides))
    assert path is not None and path.parent == cache
    return path


def test_a_planted_pickle_in_the_config_cache_runs_nothing(config_cache, tmp_path):
    """The issue's example: the config cache loaded any pickle it found, so a planted file
    ran code. Entries are JSON checked by an HMAC: a pickle planted under the entry's name
    (old or new) is never unpickled, it is removed and the config composed anew."""
    import pickle

    from creatio.pipeline import config

    marker = tmp_path / "ran"

    class Payload:
        def __reduce__(self):
            return (Path.touch, (marker,))

    path = _entry(config_cache)
    path.parent.mkdir(parents=True)
    for planted in (path, path.with_suffix(".pkl")):
        planted.write_bytes(pickle.dumps(Payload()))
    resolved = config.resolve("en02")
    assert not marker.exists() and resolved.obj.sphere.mu == 0.15
    assert json.loads(path.read_text())["sha256"] == resolved.sha256  # rebuilt, ours


def test_a_cached_config_keeps_the_order_of_its_keys(config_cache):
    """An entry read back from the cache is the composed config in its own order: the
    stability map's axes (mu, eps) name its datasets in that order. Entries were written
    with sorted keys, and a cache hit listed eps first."""
    from creatio.pipeline import config

    composed = config.resolve("stability_map")
    config._resolve.cache_clear()
    assert config._cache_path(config._cache_spec("stability_map", ())).is_file()
    cached = config.resolve("stability_map")
    assert list(composed.data["study"]["axes"]) == ["mu", "eps"]
    assert list(cached.data["study"]["axes"]) == ["mu", "eps"]
    assert cached.sha256 == composed.sha256


def test_a_swapped_or_forged_config_cache_entry_is_not_used(config_cache):
    """A swapped entry changed mu; now an entry is used only when its own key, HMAC, YAML
    and data agree: swapped (another resolution's entry), forged (data edited, HMAC kept)
    and a key file others may read are each refused, and the true config comes back."""
    from creatio.pipeline import config

    other = config.resolve("en02", ["sphere.mu=0.3"])
    config.resolve("en02")
    default, swapped = _entry(config_cache), _entry(config_cache, ("sphere.mu=0.3",))
    text = default.read_text()
    default.write_text(swapped.read_text())  # swapped
    config._resolve.cache_clear()
    assert config.resolve("en02").obj.sphere.mu == 0.15 and other.obj.sphere.mu == 0.3
    entry = json.loads(default.read_text())
    entry["data"]["sphere"]["mu"] = 0.3  # forged: data edited, HMAC left as it was
    default.write_text(json.dumps(entry))
    config._resolve.cache_clear()
    assert config.resolve("en02").obj.sphere.mu == 0.15
    assert default.read_text() == text  # the forged entry was replaced by a true one
    (config_cache / ".key").chmod(0o644)  # a key others can read protects nothing
    config._resolve.cache_clear()
    assert config._cache_key(create=False) is None
    assert config.resolve("en02").obj.sphere.mu == 0.15


def test_a_cached_config_is_the_validated_one_for_every_study(config_cache):
    """What a verified entry is rebuilt into (without OmegaConf) equals what validation
    made, for every study and analysis, and loads in milliseconds."""
    from creatio.pipeline import config
    from creatio.studies import registry

    for study in registry.STUDIES:
        fresh = config.resolve(study)
        config._resolve.cache_clear()
        cached = config.resolve(study)
        assert cached is not fresh and cached.obj == fresh.obj and cached.yaml == fresh.yaml


# ------------------------------------------------------------------ class 11: small ones
def test_ctrl_c_inside_the_compiled_loop_exits_130_in_one_line(tmp_path):
    """The issue's example: Ctrl-C during a run printed "SystemError: CPUDispatcher(...)
    returned a result with an exception set", exit 1. It is an interrupt: one line, 130,
    and no dataset (none half-written). The two timesteps run one after the other in the
    command's own process (CREATIO_FORK=off), so the loop Ctrl-C reaches is its own; Ctrl-C's
    default disposition is restored for the command, as a terminal gives it (a shell that
    starts the suite in the background, `cmd &`, passes SIGINT on ignored)."""
    import signal
    import time

    proc = subprocess.Popen(
        [sys.executable, "-m", "creatio.cli", "run", "study=en02", "solver.dt=0.00005"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "CREATIO_DEBUG": "", "CREATIO_FORK": "off"},
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    lines = []
    for line in proc.stdout:  # (Hydra logs to stdout) the first run written: the second,
        lines.append(line)  # at dt / 2 = 2.5e-5 s, is in its compiled loop for seconds
        if "wrote" in line:
            break
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, "".join(lines) + out + err
    assert err == "creatio run: interrupted (nothing half-written is kept; rerun to finish)\n"
    assert len(list(tmp_path.glob("data/runs/*/studies/en02/*.nc"))) == 1
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]


def test_an_interrupt_in_disguise_is_an_interrupt(tmp_path, monkeypatch):
    """What numba raises for Ctrl-C inside a compiled call (a SystemError chained to the
    KeyboardInterrupt) is described as an interrupt (130), and stops a sweep batch instead
    of becoming a failed point."""
    from creatio import cli
    from creatio.pipeline import sweep

    def disguised(*args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as e:
            raise SystemError("CPUDispatcher(<function run>) returned a result with an "
                              "exception set") from e

    try:
        disguised()
    except SystemError as e:
        assert cli.describe(e) == (cli.INTERRUPTED, 130)
    assert cli.describe(SystemError("something else"))[1] == 1
    monkeypatch.setattr(sweep, "_run_point", disguised)
    plan = sweep.plan_sweep("en02", ["sphere.mu=0.1,0.2"], [], str(tmp_path / "data"))
    with pytest.raises(KeyboardInterrupt):
        sweep.run_batch(plan, 0)
    assert not (tmp_path / "data").exists()


def test_a_failure_whose_log_cannot_be_written_is_said_on_stdout(tmp_path):
    """A job's stderr is its log; on a full disk the log stayed empty and the failure was
    said nowhere. The one line goes to stdout instead (Snakemake's own output)."""
    with open("/dev/full", "w") as full:
        proc = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "study=en02",
                               "sphere.mu=nan"], stdout=subprocess.PIPE, stderr=full,
                              text=True, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stdout == "creatio run: invalid config: sphere.mu=nan: must be a finite number\n"


def test_beyond_builds_only_the_selected_studies(tmp_path):
    """`snakemake beyond --config 'studies=["en02f"]'` built all four; it plans en02f
    alone, and a selection naming none of them is refused in one line."""
    proc = snakemake(tmp_path, "beyond", "-n", "--config", 'studies=["en02f"]')
    assert proc.returncode == 0, proc.stderr[-3000:]
    planned = set(re.findall(r"data/studies/(\w+)/", proc.stdout + proc.stderr))
    assert planned == {"en02f"}
    proc = snakemake(tmp_path, "beyond", "-n", "--config", 'studies=["ct02"]')
    one_line(proc, 2, "studies=['ct02']: names no study of `snakemake beyond`")


@pytest.mark.parametrize(("args", "words"), [
    (["run", "study=en02", "study.id=en02r"], "study.id='en02r': names the config"),  # issue's
    (["run", "study=en02", "+study.id=en02r"], "study.id='en02r': names the config"),
    (["run", "-m", "study=en02", "study.id=en02,en02r"], "study.id='en02,en02r': names"),
])
def test_a_study_cannot_be_relabelled(tmp_path, args, words):
    """`creatio run study=en02 study.id=en02r` labelled EN-02's outputs as EN-02R: the id
    names the config and is refused as an override (and as a sweep axis), exit 2."""
    proc = creatio(*args, cwd=tmp_path)
    one_line(proc, 2, words)
    assert not (tmp_path / "data").exists()
