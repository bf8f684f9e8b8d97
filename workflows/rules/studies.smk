# Every study's datasets and reports, planned from the study registry (creatio.studies.registry).
# A study's canonical resolved YAML is written to {root}/configs/<study>.yaml by a rule whose
# only parameter is its sha256: it reruns exactly when the resolved config changes, however
# the overrides that produced it were spelled, and its rerun reason is one line. The dataset
# jobs read that file, and carry the hash of the code that computes them (CODE in
# creatio.pipeline.planning): new code reruns them. A dataset's part (the file stem:
# en02_dt0.001, ...) selects which dataset of the study it computes.
#
# A report job's `published` parameter names what the notebook publishes of its study (empty
# for none): the report captions promise only what the study has.


localrules:
    study_config,
    kinematic_report,
    sphere_report,
    material_report,
    demonstrator_report,
    compare,


rule study_config:
    output:
        "{root}/configs/{study}.yaml",
    wildcard_constraints:
        study=f"{STUDY_IDS}|{ANALYSIS_IDS}",
    params:
        config_sha256=lambda wc: JOBS.sha(wc.root, wc.study),
    priority: lambda wc: PLAN.dataset_priority(wc.study, wc.root)  # see study_dataset
    log:
        "{root}/logs/{study}_config.log",
    run:
        with PLAN.lock:
            JOBS.write(wildcards.root, wildcards.study, output[0], log[0])


rule study_dataset:
    input:
        config="{root}/configs/{study}.yaml",
    output:
        "{root}/studies/{study}/{name}.nc",
    wildcard_constraints:
        study=STUDY_IDS,
    params:
        creatio=CREATIO,
        code=code_version("datasets"),
        part=lambda wc: JOBS.part(wc.root, wc.study, wc.name),
    # one sphere job first (it compiles what the others load), the kinematic ones beside it
    priority: lambda wc: PLAN.dataset_priority(wc.study, wc.root, wc.name)
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}/{name}.log",
    shell:
        "{params.creatio} task dataset {wildcards.study} {output} --part {params.part} "
        "--config-file {input.config} 2> {log}"


rule kinematic_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        reported("kinematic"),
    wildcard_constraints:
        study=wildcard_pattern("kinematic"),
    params:
        creatio=CREATIO,
        code=code_version("reports"),
        published=lambda wc: published_groups(wc.study),
    priority: 1  # beside the first sphere job's compilation (PLAN.dataset_priority)
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
        code=code_version("reports"),
        published=lambda wc: published_groups(wc.study),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}_report.log",
    shell:
        "{params.creatio} task report {wildcards.study} {wildcards.root}/reports {input} 2> {log}"


rule material_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        reported("material"),
    wildcard_constraints:
        study=wildcard_pattern("material"),
    params:
        creatio=CREATIO,
        code=code_version("reports"),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}_report.log",
    shell:
        "{params.creatio} task report {wildcards.study} {wildcards.root}/reports {input} 2> {log}"


# EN-07's report (docs/aerospace.md): its outputs listed from the registry's kind (not in
# Snakemake's own report).
from creatio.studies.registry import KINDS as _STUDY_KINDS


rule demonstrator_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        [f"{{root}}/reports/{{study}}{suffix}" for suffix in _STUDY_KINDS["demonstrator"].reports],
    wildcard_constraints:
        study=wildcard_pattern("demonstrator"),
    params:
        creatio=CREATIO,
        code=code_version("reports"),
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
        code=code_version("reports"),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/compare_en02_en02r.log",
    shell:
        "{params.creatio} task compare {wildcards.root}/reports {input.datasets} 2> {log}"
