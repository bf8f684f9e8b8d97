# Every study's datasets and reports, planned from the study registry (creatio.studies.registry).
# A dataset job's only config parameter is its canonical resolved YAML, so it reruns exactly
# when its resolved config changes, however the overrides that produced it were spelled; its
# part (the file stem: en02_dt0.001, ...) selects which dataset of the study it computes.


rule study_dataset:
    output:
        "{root}/studies/{study}/{name}.nc",
    wildcard_constraints:
        study=STUDY_IDS,
    params:
        creatio=CREATIO,
        config=lambda wc: JOBS.yaml(wc.root, wc.study),
        part=lambda wc: JOBS.part(wc.root, wc.study, wc.name),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}/{name}.log",
    shell:
        "{params.creatio} task dataset {wildcards.study} {output} --part {params.part} "
        "--config-yaml {params.config:q} 2> {log}"


rule kinematic_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        reported("kinematic"),
    wildcard_constraints:
        study=wildcard_pattern("kinematic"),
    params:
        creatio=CREATIO,
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}_report.log",
    shell:
        "{params.creatio} task report {wildcards.study} {wildcards.root}/reports {input} 2> {log}"


rule sphere_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        reported("sphere"),
    wildcard_constraints:
        study=wildcard_pattern("sphere"),
    params:
        creatio=CREATIO,
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}_report.log",
    shell:
        "{params.creatio} task report {wildcards.study} {wildcards.root}/reports {input} 2> {log}"


rule compare:
    input:
        json=["{root}/reports/en02.json", "{root}/reports/en02r.json"],
        datasets=lambda wc: [
            JOBS.datasets(wc.root, "en02")[0],
            JOBS.datasets(wc.root, "en02r")[0],
        ],
    output:
        md=reported_plain("{root}/reports/compare_en02_en02r.md", "compare_markdown.rst",
                          "Comparison", "report (markdown)"),
        png=reported_plain("{root}/reports/compare_en02_en02r.png", "compare_figure.rst",
                           "Comparison", "figure: both centre paths"),
    params:
        creatio=CREATIO,
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/compare_en02_en02r.log",
    shell:
        "{params.creatio} task compare {wildcards.root}/reports {input.datasets} 2> {log}"
