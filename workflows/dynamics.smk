# Sphere studies (EN-02, EN-02R): one job per timestep (dt and dt / refine).


rule dynamic_dataset:
    output:
        "{root}/studies/{study}/{study}_dt{dt}.nc",
    wildcard_constraints:
        study="en02|en02r",
    params:
        creatio=CREATIO,
        sha=lambda wc: JOBS.sha(wc.root, wc.study),
        overrides=lambda wc: JOBS.cli_overrides(wc.root, wc.study),
    conda:
        "envs/creatio.yaml"
    log:
        "{root}/logs/{study}_dt{dt}.log",
    shell:
        "{params.creatio} task dataset {wildcards.study} {output} --dt {wildcards.dt} "
        "--expect-sha {params.sha} {params.overrides} 2> {log}"
