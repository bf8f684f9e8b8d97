# Benchmarks and stress tests of the sphere integrators (outside `all`: a few minutes).
#
#   snakemake benchmarks -c 1        work precision, stability map and physics boundaries
#   snakemake data/benchmarks/work_precision.md -c 1     one of them
#
# Timings are single-threaded (the rules pin the BLAS and numba thread pools to one
# thread); run with -c 1 so no other job shares the machine while they are measured.

SINGLE_THREAD = "OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1"
BOUNDARY_AXES = ["T", "A", "b", "gamma", "mu"]


rule benchmarks:
    input:
        expand("data/benchmarks/work_precision.{ext}", ext=["nc", "json", "png", "md"]),
        expand("data/benchmarks/stability_{axis}.nc", axis=["mu", "eps"]),
        "data/benchmarks/stability.png",
        "data/benchmarks/stability.md",
        expand("data/benchmarks/boundary_{axis}.{ext}", axis=BOUNDARY_AXES, ext=["nc", "png"]),
        "data/benchmarks/boundaries.md",


rule work_precision:
    output:
        expand("data/benchmarks/work_precision.{ext}", ext=["nc", "json", "png", "md"]),
    params:
        creatio=CREATIO,
        env=SINGLE_THREAD,
    threads: 1
    conda:
        "envs/creatio.yaml"
    log:
        "data/logs/work_precision.log",
    shell:
        "{params.env} {params.creatio} benchmark data/benchmarks 2> {log}"


rule stability_map:
    output:
        expand("data/benchmarks/stability_{axis}.nc", axis=["mu", "eps"]),
        "data/benchmarks/stability.png",
        "data/benchmarks/stability.md",
    params:
        creatio=CREATIO,
        env=SINGLE_THREAD,
    threads: 1
    conda:
        "envs/creatio.yaml"
    log:
        "data/logs/stability_map.log",
    shell:
        "{params.env} {params.creatio} stability data/benchmarks 2> {log}"


rule physics_boundaries:
    output:
        expand("data/benchmarks/boundary_{axis}.{ext}", axis=BOUNDARY_AXES, ext=["nc", "png"]),
        "data/benchmarks/boundaries.md",
    params:
        creatio=CREATIO,
        env=SINGLE_THREAD,
    threads: 1
    conda:
        "envs/creatio.yaml"
    log:
        "data/logs/physics_boundaries.log",
    shell:
        "{params.env} {params.creatio} boundaries data/benchmarks 2> {log}"
