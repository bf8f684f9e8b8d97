# Beyond the notebook (EN-02G, EN-03, EN-03M, EN-02F: docs/studies.md): sphere studies outside
# `all`, since together they compute for about a minute and compile the structure path and the
# hybrid contact/flight loop of the core.
#
#   snakemake beyond -c 2                                          data/reports/en02g.* ...
#   snakemake beyond -c 2 --config 'overrides=["sphere.mu=0.3"]'   -> data/runs/<hash>/
#   snakemake beyond -c 2 --config 'studies=["en02f"]'             one of them
#
# Their dataset and report jobs are the sphere studies' rules (study_dataset, sphere_report);
# this file adds the target, planned from the study registry (the studies with in_all=False
# of the sphere kind: BEYOND, creatio.pipeline.invocation); --config studies=[...] selects
# among them too (snakemake beyond --config 'studies=["en02f"]').
#
# The scenes that draw a beyond study's dataset (scene en04: EN-04's fastest closed loop beside
# the open-loop boundary) are built with it: planned under the same overrides (those they do
# not have are the studies' to refuse), by the scene rules of scenes.smk, which find their plan
# here (SCENES.fallbacks).
from creatio.scenes.plan import scenes_of

BEYOND_SCENES = SceneRuns(config.get("overrides"), scenes_of(BEYOND.studies), strict=False)
SCENES.fallbacks.append(BEYOND_SCENES)
JOBS.fallbacks.insert(0, lambda: BEYOND_SCENES.study_jobs(JOBS))


localrules:
    beyond,


rule beyond:
    input:
        lambda wc: PLAN.beyond_targets(),
        lambda wc: BEYOND_SCENES.targets(),
