# creatio workflow: every study from its Hydra config to datasets, reports and figures.
#
#   snakemake all -c 2                                         default configs -> data/
#   snakemake all -c 2 --config 'overrides=["sphere.mu=0.3"]'  -> data/runs/<config hash>/
#   snakemake all -c 2 --config 'studies=["ct02"]'             a subset of the studies
#
#   snakemake sweep -c 2 --config study=en02 'sweep=["sphere.mu=0,0.15,0.3"]'
#   snakemake sweep_en02_mu -c 2                              the worked sweep (outside all)
#   snakemake release -c 2 --config version=0.2.0    freeze data/ in data/releases/0.2.0/
#   snakemake diff -c 2 --config against=latest      data/reports/diff/<v>_vs_data.{txt,json}
#
# Overrides are Hydra overrides, applied to every study whose config has the key.
import sys

from snakemake.exceptions import WorkflowError
from snakemake.utils import min_version

from creatio.config import STUDIES, ConfigError
from creatio.workflow import JobConfigs, SweepRegistry, compare_targets, plan

min_version("9.0")

CREATIO = f'"{sys.executable}" -m creatio.cli'
try:
    PLAN = plan(config.get("overrides", []), config.get("studies", STUDIES))
except ConfigError as e:
    raise WorkflowError(str(e)) from None
for _p in PLAN.values():
    if _p.overrides:
        print(f"creatio: {_p.study} {list(_p.overrides)} -> {_p.root}", file=sys.stderr)
JOBS = JobConfigs()
JOBS.add_plans(PLAN)
SWEEPS = SweepRegistry(JOBS, workflow.basedir)

wildcard_constraints:
    root=r"data|data/runs/[0-9a-f]{12}",


include: "workflows/kinematics.smk"
include: "workflows/dynamics.smk"
include: "workflows/reports.smk"
include: "workflows/sweeps.smk"
include: "workflows/release.smk"


rule all:
    default_target: True
    input:
        [f for p in PLAN.values() for f in p.reports],
        compare_targets(PLAN),
