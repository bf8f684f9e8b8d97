# creatio workflow: every study from its Hydra config to datasets, reports and figures.
#
#   snakemake all -c 2                                         default configs -> data/
#   snakemake all -c 2 --config 'overrides=["sphere.mu=0.3"]'  -> data/runs/<config hash>/
#   snakemake all -c 2 --config 'studies=["ct02"]'             a subset of the studies
#
#   snakemake sweep -c 2 --config study=en02 'sweep=["sphere.mu=0,0.15,0.3"]'
#   snakemake sweep_en02_mu -c 2                              the worked sweep (outside all)
#   snakemake benchmarks -c 1        work precision, stability map, physics boundaries
#   snakemake release -c 2 --config version=0.2.0    freeze data/ in data/releases/0.2.0/
#   snakemake diff -c 2 --config against=latest      data/reports/diff/<v>_vs_data.{txt,json}
#   snakemake all --workflow-profile profiles/slurm    the same on a SLURM cluster
#   snakemake scenes -c 2            the notebook's viewers: data/scenes/<scene>/ (creatio.scenes)
#   snakemake beyond -c 2            EN-02G, EN-03, EN-03M, EN-02F (beyond the notebook, outside all)
#   snakemake en05 -c 2              EN-05: Sobol' indices, calibration, which test pins mu
#   snakemake --report data/report.html    Snakemake's report of everything built
#
# Overrides are Hydra overrides, applied to every study whose config has the key. Study ids,
# their files and report rules come from the study registry (creatio.studies.registry).
import sys
from pathlib import Path

from snakemake.utils import min_version

from creatio.pipeline.planning import (
    JobConfigs,
    StudyRuns,
    SweepRegistry,
    analysis_ids,
    check_workflow_config,
    code_version,
    pass_config_safely,
    wildcard_pattern,
)
from creatio.studies.registry import KINDS

min_version("9.0")
# No --config text reaches a shell: re-invoked jobs get it base64-encoded (and decode it here).
pass_config_safely(workflow.config_settings, config)
check_workflow_config(config, workflow.source_path("workflow/schemas/config.schema.yaml"))

# The interpreter relative to the working directory when it lives there (.venv/bin/python):
# jobs run from it, and the report's job parameters show no clone's absolute path.
_PY = Path(sys.executable)
_PY = _PY.relative_to(Path.cwd()) if _PY.is_relative_to(Path.cwd()) else _PY
CREATIO = f'"{_PY}" -m creatio.cli'
STUDY_IDS = wildcard_pattern(folder="studies")
ANALYSIS_IDS = wildcard_pattern(folder="benchmarks")
JOBS = JobConfigs()
RUNS = StudyRuns(JOBS, config.get("overrides"), config.get("studies"))
ANALYSES = StudyRuns(JOBS, None, analysis_ids())
SWEEPS = SweepRegistry(JOBS, workflow.basedir)
# A job re-invoked on its own (a cluster node, a run: directive) re-parses this file
# without the targets: these re-plan what the invocation's --config asked for.
PLANNERS = [
    lambda: RUNS.plans,
    lambda: ANALYSES.plans,
    lambda: SWEEPS.outputs(
        config.get("study", ""),
        config["sweep"],
        config.get("overrides"),
        config.get("sweep_batch"),
        config.get("sweep_max_points"),
    )
    if config.get("sweep")
    else None,
    lambda: SWEEPS.worked("en02_mu"),
]
JOBS.fallbacks += PLANNERS
SWEEPS.fallbacks += PLANNERS[2:]


wildcard_constraints:
    root=r"data|data/runs/[0-9a-f]{12}",


include: "workflow/report/report.smk"
include: "workflow/rules/studies.smk"
include: "workflow/rules/analyses.smk"
include: "workflow/rules/sweeps.smk"
include: "workflow/rules/release.smk"
include: "workflow/rules/scenes.smk"
include: "workflow/rules/beyond.smk"
include: "workflow/rules/en05.smk"
include: "workflow/rules/index.smk"


# Cheap aggregation, reports and plots run where Snakemake runs, not as cluster jobs.
localrules:
    all,
    study_config,
    scene_config,
    benchmarks,
    kinematic_report,
    sphere_report,
    analysis_report,
    compare,
    sweep,
    sweep_en02_mu,
    sweep_aggregate,
    release,
    diff,
    diff_report,
    scenes,
    scene_library,
    scene_page,
    index,


rule all:
    default_target: True
    input:
        lambda wc: RUNS.targets() + report_extras() + ["data/index.html"],
