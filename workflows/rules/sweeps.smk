# Parameter sweeps in batches: a few jobs of many points each, one aggregate.
#
#   snakemake sweep -c 2 --config study=en02 'sweep=["sphere.mu=0,0.15,0.3","phases.T=60,120"]'
#   snakemake sweep -c 2 --config study=en02 'sweep=[...]' sweep_batch=50   (points per job)
#   snakemake sweep_en02_mu -c 2        the worked sweep of conf/sweeps/en02_mu.yaml
#
# A batch job composes the base config once and varies it per point; a point any earlier
# sweep of the study computed is reused, so adding points computes only the new ones.


localrules:
    sweep,
    sweep_en02_mu,
    sweep_aggregate,


rule sweep:
    input:
        lambda wc: PLAN.sweep_targets(),


rule sweep_en02_mu:
    input:
        lambda wc: SWEEPS.worked("en02_mu"),


rule sweep_batch:
    output:
        "data/sweeps/{name}/batches/b{size}-{batch}.nc",
    wildcard_constraints:
        size=r"\d+",
        batch=r"\d{5}",
    params:
        creatio=CREATIO,
        code=code_version("datasets"),
        args=lambda wc: SWEEPS[wc.name].cli_args(),
    threads: 1
    conda:
        "../envs/creatio.yaml"
    log:
        "data/sweeps/{name}/logs/b{size}-{batch}.log",
    shell:
        "{params.creatio} task sweep-batch {params.args} --batch {wildcards.batch} "
        "--out {output} 2> {log}"


rule sweep_aggregate:
    input:
        lambda wc: SWEEPS[wc.name].batches,
    output:
        nc="data/sweeps/{name}/sweep.nc",
        md=reported_plain("data/sweeps/{name}/sweep.md", "sweep_markdown.rst", "Sweeps",
                          "{name}: table (markdown)"),
        png=reported_plain("data/sweeps/{name}/sweep.png", "sweep_figure.rst", "Sweeps",
                           "{name}: figure"),
    params:
        creatio=CREATIO,
        code=code_version("reports"),
        args=lambda wc: SWEEPS[wc.name].cli_args(),
    conda:
        "../envs/creatio.yaml"
    log:
        "data/sweeps/{name}/sweep.log",
    shell:
        "{params.creatio} task sweep {params.args} 2> {log}"
