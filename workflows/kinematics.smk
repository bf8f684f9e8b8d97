# Kinematic studies (CT-02, EN-01): one dataset job per study.


rule kinematic_dataset:
    output:
        "{root}/studies/{study}/{study}.nc",
    wildcard_constraints:
        study="ct02|en01",
    params:
        creatio=CREATIO,
        sha=lambda wc: JOBS.sha(wc.root, wc.study),
        overrides=lambda wc: JOBS.cli_overrides(wc.root, wc.study),
    conda:
        "envs/creatio.yaml"
    log:
        "{root}/logs/{study}.log",
    shell:
        "{params.creatio} task dataset {wildcards.study} {output} --expect-sha {params.sha} "
        "{params.overrides} 2> {log}"
