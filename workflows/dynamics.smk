# Sphere studies (EN-02, EN-02R): one job per timestep (dt and dt / refine); the dt in
# the file name is Python's exact float repr, so it travels to the job without rounding;
# the config travels as canonical resolved YAML (see kinematics.smk).


rule dynamic_dataset:
    output:
        "{root}/studies/{study}/{study}_dt{dt}.nc",
    wildcard_constraints:
        study="en02|en02r",
    params:
        creatio=CREATIO,
        config=lambda wc: JOBS.yaml(wc.root, wc.study),
    conda:
        "envs/creatio.yaml"
    log:
        "{root}/logs/{study}_dt{dt}.log",
    shell:
        "{params.creatio} task dataset {wildcards.study} {output} --dt {wildcards.dt} "
        "--config-yaml {params.config:q} 2> {log}"
