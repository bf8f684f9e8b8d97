"""Sizes, angles and the words of a refusal at the config boundary (issues 34.7, 38.5-38.7,
38.13): every size that sets an allocation or a run count is refused before anything runs,
against its stated limit, naming the key; a start angle is bounded; Hydra's own options
refuse interpolations; a mistyped name or key gets the nearest one; each refusal is one line
with exit status 2 and writes nothing."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import is_dataclass
from pathlib import Path
from typing import Any

import pytest
from inproc import run_cli

from creatio.errors import ConfigError
from creatio.studies import registry
from creatio.studies.schema import MAX_ITEMS, MAX_RUNS, MAX_SAMPLES, MAX_START_DEG

REPO = Path(__file__).resolve().parents[2]

#: Every scalar size of every study: (key, a value past its limit). Lists are walked apart
#: (each list's length is a size: test_every_list_is_bounded). A fixed step's output
#: interval is a multiple of solver.dt: it is pushed with solver.dt (WITH). Every study of the
#: sphere kind has the sphere's sizes unless it lists its own (a new one needs no line here).
SIZES: dict[str, list[tuple[str, Any]]] = {
    **{s.id: [("study.duration", 1e9), ("solver.output_interval", 1e-6), ("solver.dt", 1e-9),
              ("solver.refine", 10**9)]
       for s in registry.STUDIES.values() if s.kind.name == "sphere"},
    "ct02": [("study.n_radii", 10**7), ("study.n_angles", 10**7)],
    "en01": [("study.n_radii", 10**7), ("study.n_angles", 10**7),
             ("study.regularity.n_radii", 10**5), ("study.regularity.n_angles", 10**5),
             ("study.pattern.T", 1e9), ("study.pattern.sample_interval", 1e-6)],
    "en02f": [("study.duration", 1e9), ("solver.output_interval", 1e-6), ("solver.dt", 1e-9),
              ("solver.refine", 10**9), ("study.drop.duration", 1e9), ("study.drop.dt", 1e-9),
              ("study.cycles_s", [1e9])],
    "en04": [("study.control.duration", 1e9),
             ("study.control.extrema.n_alpha", 10**7), ("study.control.extrema.n_R", 10**7),
             ("study.actuation.extrema.n_alpha", 10**7), ("study.actuation.extrema.n_R", 10**7),
             ("study.actuation.quadrature.n_alpha", 10**7),
             ("study.actuation.quadrature.n_R", 10**7),
             ("study.actuation.quadrature.growth", 1e3),
             ("study.actuation.quadrature.max_levels", 1000),
             ("study.actuation.quadrature.check_interval", 1e-6),
             ("study.oscillation.duration", 1e9)],
    "en05": [("study.sensitivity.base_sizes", [2**20]), ("study.sensitivity.resamples", 10**7),
             ("study.calibration.seeds", 10**6), ("study.calibration.spread_seeds", 10**6),
             ("study.camera.rate_hz", 1e9), ("study.calibration.cycle_s", 1e9),
             ("study.design.cycles_s", [1e9]), ("study.sensitivity.budget.points", 10**7)],
    "en06": [*((f"study.{g}.{n}", 10**7) for g in ("strain", "beyond", "fatigue")
               for n in ("n_alpha", "n_R", "n_t")),
             ("study.fatigue_check.samples_per_half_turn", 10**7),
             ("study.fatigue_check.n_R", 10**7),
             ("study.tolerances.sobol.base_sizes", [2**20]),
             ("study.tolerances.sobol.resamples", 10**7),
             ("study.tolerances.allocation.scan", 10**7),
             ("study.tolerances.allocation.azimuths", 10**7),
             ("study.tolerances.joint.n", 10**7),
             ("study.tilt_check.cycle_s", 1e9),
             ("study.ribs.seeds", 10**7)],
    "en07": [("study.actuation.n_alpha", 10**7), ("study.actuation.n_R", 10**7),
             ("study.actuation.growth", 1e3), ("study.actuation.max_levels", 1000),
             ("study.actuation.extrema_n_alpha", 10**7), ("study.actuation.extrema_n_R", 10**7),
             *((f"study.strain.{n}", 10**7) for n in ("n_alpha", "n_R", "n_t"))],
    "boundaries": [("study.analytic_samples", 10**8)],
    "stability_map": [("study.samples", 10**6), ("study.duration", 1e9),
                      ("study.duration_check.duration", 1e9)],
    # study.full_state's steps are among study.methods' (their partners): bounded with them
    "work_precision": [("study.methods.rk4.steps_per_output", [50, 10**6]),
                       ("study.methods.radau5.dense_dt", [1e-9]),
                       ("study.unlisted.steps_per_output", [10**6]),
                       ("study.reference.fixed_steps_per_output", 10**6),
                       ("study.repeats", 10**6), ("study.jit.t_end", 1e6)],
}

#: The numbers that look like sizes (an integer, a duration, an interval, a cycle, a rate of
#: samples) but set none, or whose size other rules bound: why each is not in SIZES.
NOT_SIZES = {
    "geometry.Kr": "the surface's radial cycles: a shape, no allocation",
    "geometry.Ka": "the surface's cavities: a shape, no allocation",
    "solver.max_rhs_evals": "the budget itself (it bounds a run's steps)",
    "phases.T": "a law's cycle length: the run's length is study.duration",
    "study.sensitivity.seed": "a seed",
    "study.sensitivity.batch_size": "splits the design into jobs (0: about two)",
    "study.calibration.example_seed": "one of the seeds (below seeds)",
    "study.actuation.sample_interval": "a multiple of the base's dt (its rows <= steps)",
    "study.control.path_interval": "a multiple of the run's step (its rows <= the run's)",
    "study.control.robustness.quintic_T": "a cycle, at most study.control.duration",
    "study.oscillation.amplitude_factor": "an amplitude ratio",
    "study.budget_s": "a time budget: it lowers the repeats of a slow setting, never raises them",
    "study.surfaces.en02.T": "a law's cycle length (EN-06's surfaces): its times are n_t",
    "study.surfaces.en02r.T": "a law's cycle length (EN-06's surfaces): its times are n_t",
    "study.strain.candidates": "points refined, bounded to [1, 64] by its own rule",
    "study.strain.max_levels": "halvings, bounded to [1, 60] by its own rule",
    "study.fatigue_check.n_alpha": "must divide 2 Ka samples_per_half_turn (96): bounded by it",
    "study.tolerances.sobol.seed": "a seed: no allocation",
    "study.tolerances.joint.seed": "a seed: no allocation",
    "study.tolerances.allocation.iterations": "bisections, bounded to [1, 60] by their own rule",
    "study.tolerances.budget.points": "the accuracy check's subsample: at most the part's own runs",
    "study.tolerances.budget.seed": "a seed: no allocation",
    "study.tolerances.budget.max_tighten": "10x tightenings, bounded to [0, 6] by its own rule",
}
#: Studies whose config holds no list (nothing for test_every_list_is_bounded to walk).
NO_LISTS: set[str] = set()
SIZE_NAME = re.compile(r"(duration|interval|(^|\.)T$|(^|\.)dt$|cycle_s$|rate_hz|growth|levels|"
                       r"seeds?$|samples|size|(^|\.)n_)")
#: The analyses' schemas keep their own sizes (their modules, not the study schemas): they
#: are walked with the studies (their base configs, under bases, are studies' configs).
ANALYSES = [s.id for s in registry.select(kind="analysis")]
STUDIES = list(registry.STUDIES)


def _leaves(data: dict, prefix: str = "") -> Iterator[tuple[str, Any]]:
    for name, value in data.items():
        key = f"{prefix}{name}"
        if key == "bases":
            continue
        if isinstance(value, dict):
            yield from _leaves(value, f"{key}.")
        elif not isinstance(value, bool):
            yield key, value


def _reachable(obj: Any, key: str) -> bool:
    node = obj
    for part in key.split(".")[:-1]:
        node = getattr(node, part, None)
        if not is_dataclass(node):
            return False
    return True


WITH = {"solver.output_interval": {"solver.dt": 1e-6}}


def _refusal(study: str, changes: dict[str, Any]) -> ConfigError:
    """The refusal of changes to a study's default config: varied, or composed with them as
    overrides where a key lies inside a mapping (work_precision's study.methods.rk4)."""
    from creatio.pipeline.config import resolve
    from creatio.studies.schema import vary

    base = resolve(study).obj
    with pytest.raises(ConfigError) as info:
        if all(_reachable(base, key) for key in changes):
            vary(base, changes)
        else:
            resolve(study, [f"{key}={value!r}" for key, value in changes.items()])
    return info.value


def test_the_size_table_names_every_size_key_of_every_study():
    """Every integer, and every number named like a size, of every study's config (the
    analyses' included) is in SIZES or in NOT_SIZES with its reason: a size added to a
    schema must be listed here (and bounded)."""
    from creatio.pipeline.config import resolve

    missing = []
    for study in STUDIES:
        listed = {k for k, _ in SIZES.get(study, [])}
        for key, value in _leaves(resolve(study).data):
            scalar = isinstance(value, int | float)
            sized = isinstance(value, int) or (isinstance(value, float)
                                               and SIZE_NAME.search(key))
            if scalar and sized and key not in listed and key not in NOT_SIZES:
                missing.append(f"{study}: {key}")
    assert missing == []


@pytest.mark.parametrize(("study", "key", "value"),
                         [(s, k, v) for s, sizes in SIZES.items() for k, v in sizes])
def test_every_size_past_its_limit_is_refused_naming_its_key(study, key, value):
    """In one line naming the key and a stated limit (MAX_SAMPLES rows or points, MAX_RUNS
    runs, a run's budget of evaluations), before anything is computed."""
    error = _refusal(study, {key: value, **WITH.get(key, {})})
    text = str(error)
    assert "\n" not in text
    assert error.key == key or error.key.startswith(f"{key}["), text
    limits = (f"{MAX_SAMPLES:,}", f"{MAX_RUNS:,}", "max_rhs_evals", "10,000 (time)",
              "50,000,000")
    assert "more than" in error.rule and any(n in error.rule for n in limits), text


@pytest.mark.parametrize("study", list(registry.STUDIES))
def test_every_list_is_bounded(study):
    """A list's length is a number of runs or samples: each list a sweep point can set
    (every study's, the analyses' included) is refused past MAX_ITEMS values, naming it."""
    from creatio.pipeline.config import resolve

    base = resolve(study)
    lists = [(k, v) for k, v in _leaves(base.data)
             if isinstance(v, list) and _reachable(base.obj, k)]
    assert bool(lists) != (study in NO_LISTS), study
    for key, value in lists:
        item = value[0] if value else 1e-6
        error = _refusal(study, {key: [item] * (MAX_ITEMS + 1)})
        assert error.key == key and f"more than {MAX_ITEMS:,} values" in error.rule, error


def test_the_issue_grids_are_refused_and_the_defaults_are_within_every_limit():
    """EN-04's 29-million-run controller grid, counted: 5 x 3 x 3 x 3 cases by default, a
    grid of 120 x 120 x 40 x 50 at dt and dt / refine is 57.6 million runs."""
    grid = {"study.control.omega_max": [1.0] * 120, "study.control.omega_c": [3.0] * 120,
            "study.control.omega_n": [20.0] * 40, "study.control.delta_max_deg": [5.0] * 50}
    error = _refusal("en04", grid)
    runs = 2 * (120 * 120 * 40 * 50 + 25 + 9)
    assert f"asks for {runs:,} runs" in error.rule and error.key in grid


@pytest.mark.parametrize("value, ok", [(360.0, True), (-360.0, True), (30.0, True),
                                       (360.5, False), (1e15, False), (-1e3, False)])
def test_a_start_angle_is_bounded_to_one_turn(value, ok):
    """study.initial.alpha_deg in [-360, 360] (bounded, never reduced: a reduced value would
    run another config than the one typed)."""
    from creatio.pipeline.config import resolve
    from creatio.studies.schema import vary

    base = resolve("en02g").obj
    if ok:
        assert vary(base, {"study.initial.alpha_deg": value}).study.initial.alpha_deg == value
    else:
        with pytest.raises(ConfigError, match=re.escape(f"[-{MAX_START_DEG:g}, "
                                                         f"{MAX_START_DEG:g}] degrees")):
            vary(base, {"study.initial.alpha_deg": value})


def test_the_velocity_scene_point_is_bounded_like_a_start_angle():
    from creatio.scenes.config import resolve

    assert resolve("velocity_normal", ["scene.alpha_deg=-360"]).obj.scene.alpha_deg == -360.0
    with pytest.raises(ConfigError) as info:
        resolve("velocity_normal", ["scene.alpha_deg=1e15"])
    assert info.value.key == "scene.alpha_deg" and "[-360, 360] degrees" in info.value.rule


@pytest.mark.parametrize(("entry", "ok"), [
    ("fd_error*=1e-9,1e-6", True), ("x=0", True), ("x=abc", False), ("x", False),
    ("=1e-9", False), ("x=1,2,3", False), ("x=-1", False), ("x=nan", False),
    ("x=1e-9,inf", False),
])
def test_diff_tolerances_are_checked_with_the_other_config_keys(entry, ok):
    """`snakemake diff --config 'tol=[...]'`: NAME=ATOL[,RTOL], finite and >= 0, refused at
    the boundary (it failed after 78 s inside the diff job)."""
    from creatio.pipeline.planning import check_tol

    if ok:
        check_tol("tol[0]", entry)
    else:
        with pytest.raises(ConfigError, match=r"^invalid config: tol\[0\]="):
            check_tol("tol[0]", entry)


def test_a_mistyped_key_or_name_gets_the_nearest_one():
    from creatio.pipeline.planning import plan
    from creatio.pipeline.sweep import plan_sweep
    from creatio.scenes.plan import SceneRuns

    with pytest.raises(ConfigError, match=r"sphere\.muu='0.3': unknown key \(did you mean "
                                          r"sphere\.mu\?\)"):
        plan(["sphere.muu=0.3"], ["en02"])
    with pytest.raises(ConfigError, match=r"did you mean en02\?"):
        plan([], ["en2"])
    with pytest.raises(ConfigError, match=r"did you mean en02\?"):
        plan_sweep("en2", ["sphere.mu=0,1"])
    with pytest.raises(ConfigError, match=r"sphere\.muu='0': unknown key \(did you mean "
                                          r"sphere\.mu\?\)"):
        plan_sweep("en02", ["sphere.muu=0,1"])
    with pytest.raises(ConfigError, match=r"did you mean en02\?"):
        _ = SceneRuns([], ["en2"]).plans
    with pytest.raises(ConfigError, match=r"sphere\.muu='0.3': unknown key \(did you mean "
                                          r"sphere\.mu\?\)"):
        _ = SceneRuns(["sphere.muu=0.3"], ["en02"]).plans


def test_a_scene_refusal_names_the_key_typed():
    """sphere.mu=-1 for the en02 scene is refused as sphere.mu, not as the base's key it is
    routed to (bases.en02.sphere.mu)."""
    from creatio.scenes.plan import SceneRuns

    with pytest.raises(ConfigError) as info:
        _ = SceneRuns(["sphere.mu=-1"], ["en02"]).plans
    assert info.value.key == "sphere.mu" and info.value.rule == "must be >= 0"
    with pytest.raises(ConfigError) as info:
        _ = SceneRuns(["sphere.mu=0,3"], ["en02"]).plans
    assert info.value.key == "sphere.mu" and "bases." not in str(info.value)
    assert "a comma makes a sweep" in info.value.rule


@pytest.mark.parametrize(("text", "words"), [
    ("sphere.mu=range(0,0.3,abc)", "'abc' is not a number"),
    ("sphere.mu=range(0,0.3,0.1,4)", "takes 2 or 3 numbers, not 4"),
    ("sphere.mu=interval(0,x)", "'x' is not a number"),
    ("sphere.mu=0,]", "sweep syntax: KEY=V1,V2"),
])
def test_a_sweep_hydra_cannot_read_says_what_is_wrong(text, words):
    from creatio.pipeline.sweep import parse_axes

    with pytest.raises(ConfigError) as info:
        parse_axes([text])
    assert words in info.value.rule and "\n" not in str(info.value)


def _creatio(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """The command in this process (inproc.py): its refusal is the test, not the process."""
    return run_cli(*args, cwd=cwd)


@pytest.mark.parametrize(("args", "words"), [
    (["run", "study=en2"], "(did you mean en02?)"),
    (["run", "study=en02", "sphere.mu=0,3"], "a comma makes a sweep: run it with creatio run -m"),
    (["run", "-m", "study=en02", "sphere.mu=range(0,0.3,abc)"], "'abc' is not a number"),
    (["run", "study=ct02", "study.title=${oc.env:HOME}", "--cfg", "job", "--resolve"],
     "interpolations (${...}) are not accepted"),
    (["run", "study=ct02", "--info", "config", "study.title=${oc.env:HOME}"],
     "interpolations (${...}) are not accepted"),
    (["run", "study=en02g", "study.initial.alpha_deg=1e15"], "must lie in [-360, 360] degrees"),
    (["run", "study=en04", "study.control.duration=1e9"], f"more than {MAX_SAMPLES:,}"),
    (["run", "analysis=stability_map", "study.samples=1000000"], f"more than {MAX_RUNS:,}"),
    (["run", "analysis=boundaries", "study.analytic_samples=100000000"],
     f"more than {MAX_SAMPLES:,}"),
    (["run", "analysis=work_precision", "study.reference.fixed_steps_per_output=1000000"],
     "more than bases.en02.solver.max_rhs_evals = 50,000,000"),
    (["probe", "alpha=1e15"], "must lie in [-360, 360] degrees"),
])
def test_the_command_line_refuses_in_one_line_writing_nothing(tmp_path, args, words):
    proc = _creatio(*args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], proc.stderr
    assert str(Path.home()) not in proc.stdout
    assert list(tmp_path.iterdir()) == []


def _snakemake(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "snakemake", "-s", str(REPO / "Snakefile"),
                           "-d", str(tmp_path), "-c", "1", *args], capture_output=True,
                          text=True, cwd=tmp_path, timeout=300)


@pytest.mark.parametrize(("args", "words"), [
    (["all", "--config", 'overrides=["sphere.muu=0.3"]'],
     "sphere.muu='0.3': unknown key (did you mean sphere.mu?)"),
    (["diff", "--config", "against=0.2.0", 'tol=["x=abc"]'], "tol[0]='x=abc': must be"),
    (["scenes", "--config", 'scenes=["en2"]'], "(did you mean en02?)"),
    (["scenes", "--config", 'overrides=["sphere.mu=-1"]', 'scenes=["en02"]'],
     "sphere.mu=-1.0: must be >= 0"),
])
def test_snakemake_refuses_in_one_line_writing_nothing(tmp_path, args, words):
    proc = _snakemake(tmp_path, *args)
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = [ln for ln in proc.stderr.splitlines() if ln.startswith("creatio")]
    assert len(lines) == 1 and words in lines[0], proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "data").exists()

