# Parameter sweeps: one dataset job per point (the single-run rules), one aggregate.
#
#   snakemake sweep -c 2 --config study=en02 'sweep=["sphere.mu=0,0.15,0.3","phases.T=60,120"]'
#   snakemake sweep_en02_mu -c 2        the worked sweep of conf/sweeps/en02_mu.yaml


rule sweep:
    input:
        lambda wc: SWEEPS.outputs(
            config.get("study", ""), config.get("sweep", []), config.get("overrides", [])
        ),


rule sweep_en02_mu:
    input:
        lambda wc: SWEEPS.worked("en02_mu"),


rule sweep_aggregate:
    input:
        lambda wc: SWEEPS[wc.name].datasets,
    output:
        nc="data/sweeps/{name}/sweep.nc",
        md="data/sweeps/{name}/sweep.md",
        png="data/sweeps/{name}/sweep.png",
    params:
        creatio=CREATIO,
        args=lambda wc: SWEEPS[wc.name].cli_args(),
    conda:
        "../envs/creatio.yaml"
    log:
        "data/sweeps/{name}/sweep.log",
    shell:
        "{params.creatio} task sweep {params.args} 2> {log}"
