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
#   snakemake beyond -c 2            the studies beyond the notebook outside all (creatio ls)
#   snakemake en05 -c 2              EN-05: Sobol' indices, calibration, which test pins mu
#   snakemake --report data/report.html    Snakemake's report of everything built
#
# Thin on purpose: the --config is validated here; what it plans lives in the package
# (creatio.pipeline.invocation: the studies of all and beyond, analyses, sweeps, EN-05, and
# where a job re-invoked alone finds its configuration); the rules, report captions, schemas
# and envs live in workflows/. Local jobs run in a warm worker (creatio.pipeline.worker).
from snakemake.utils import min_version

from creatio.pipeline.invocation import Invocation
from creatio.pipeline.planning import check_workflow_config, pass_config_safely

min_version("9.0")


# No --config text reaches a shell: re-invoked jobs get it base64-encoded (and decode it here).
pass_config_safely(workflow.config_settings, config)
check_workflow_config(config, workflow.source_path("workflows/schemas/config.schema.yaml"))
PLAN = Invocation(config, workflow.basedir)


include: "workflows/rules/common.smk"
include: "workflows/report/report.smk"
include: "workflows/rules/studies.smk"
include: "workflows/rules/analyses.smk"
include: "workflows/rules/sweeps.smk"
include: "workflows/rules/release.smk"
include: "workflows/rules/scenes.smk"
include: "workflows/rules/beyond.smk"
include: "workflows/rules/en05.smk"
include: "workflows/rules/index.smk"


# The shared warm worker is found, or started to warm up, while Snakemake builds the DAG;
# onstart keeps it for local jobs; it outlives the invocation until it is idle.
PLAN.prestart_worker(workflow)


onstart:
    PLAN.start_worker(workflow)


onsuccess:
    PLAN.release_worker()
    list_results()


onerror:
    PLAN.release_worker()


localrules:
    all,


rule all:
    default_target: True
    input:
        lambda wc: RUNS.targets() + report_extras() + ["data/index.html"],
