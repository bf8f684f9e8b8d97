# Beyond the notebook (EN-02G, EN-03, EN-03M, EN-02F: docs/studies.md): sphere studies outside
# `all`, since together they compute for about a minute and compile the structure path and the
# hybrid contact/flight loop of the core.
#
#   snakemake beyond -c 2                                          data/reports/en02g.* ...
#   snakemake beyond -c 2 --config 'overrides=["sphere.mu=0.3"]'   -> data/runs/<hash>/
#
# Their dataset and report jobs are the sphere studies' rules (study_dataset, sphere_report);
# this file adds the target, planned from the study registry (the studies with in_all=False
# of the sphere kind), and lets a job re-invoked alone find its configuration.
from creatio.studies.registry import select as select_studies

BEYOND = StudyRuns(JOBS, config.get("overrides"),
                   [s.id for s in select_studies(kind="sphere", in_all=False)])
# planned last: a job re-invoked alone that no other planner knows is one of these
JOBS.fallbacks.append(lambda: BEYOND.plans)


localrules:
    beyond,


rule beyond:
    input:
        lambda wc: BEYOND.targets(),
