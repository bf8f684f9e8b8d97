# Kinematic studies (CT-02, EN-01): one dataset job per study. A dataset job's only
# config parameter is its canonical resolved YAML, so it reruns exactly when its resolved
# config changes, however the overrides that produced it were spelled.


rule kinematic_dataset:
    output:
        "{root}/studies/{study}/{study}.nc",
    wildcard_constraints:
        study="ct02|en01",
    params:
        creatio=CREATIO,
        config=lambda wc: JOBS.yaml(wc.root, wc.study),
    conda:
        "envs/creatio.yaml"
    log:
        "{root}/logs/{study}.log",
    shell:
        "{params.creatio} task dataset {wildcards.study} {output} "
        "--config-yaml {params.config:q} 2> {log}"
