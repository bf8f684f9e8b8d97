# Analyses (work precision, stability map, physics boundaries): studies of their own kind,
# outside `all` (minutes, and timed). Their datasets and reports go to data/benchmarks/.
#
#   snakemake benchmarks -c 1        every analysis
#   snakemake data/benchmarks/stability_map.md -c 1          one of them
#
# Timings are single-threaded (the rules pin the BLAS and numba thread pools to one
# thread); run with -c 1 so no other job shares the machine while they are measured.

SINGLE_THREAD = "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1"


localrules:
    benchmarks,
    analysis_report,


rule benchmarks:
    input:
        lambda wc: ANALYSES.targets(),


rule analysis_dataset:
    input:
        config="{root}/configs/{study}.yaml",
    output:
        "{root}/benchmarks/{study}/{name}.nc",
    wildcard_constraints:
        study=ANALYSIS_IDS,
    params:
        creatio=CREATIO,
        env=SINGLE_THREAD,
        code=code_version("datasets"),
        part=lambda wc: JOBS.part(wc.root, wc.study, wc.name),
    threads: 1
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}/{name}.log",
    shell:
        "{params.env} {params.creatio} task dataset {wildcards.study} {output} "
        "--part {params.part} --config-file {input.config} 2> {log}"


rule analysis_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        reported("analysis"),
    wildcard_constraints:
        study=ANALYSIS_IDS,
    params:
        creatio=CREATIO,
        code=code_version("reports"),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/{study}_report.log",
    shell:
        "{params.creatio} task report {wildcards.study} {wildcards.root}/benchmarks {input} "
        "2> {log}"
