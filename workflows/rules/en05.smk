# EN-05 (docs/studies.md, docs/model.md s.13): which inputs matter, fitting the model to a
# track, which test pins mu. Outside `all` and `beyond`: its Sobol' sample is N_max (d + 2)
# = 4,096 runs of EN-02 (a few minutes on 2 cores), in batch jobs like a sweep's.
#
#   snakemake en05 -c 2                                   data/reports/en05.* and the example
#   snakemake en05 -c 2 --config 'overrides=["study.sensitivity.base_sizes=[64,128]"]'
#   snakemake calibrate_example -c 1                      the committed synthetic track, fitted
#
# The ishigami, calibration and experiment datasets are the study's registry parts (the
# generic study_dataset rule); the sample's batches (en05_points) go to the point store
# data/sweeps/en05/<sample>/ (points reused by config hash), its indices to en05_sobol.nc.
# Under the sample's accuracy budget (study.sensitivity.budget) a pilot (en05_pilot) first
# chooses the tolerance the batches run at (<sample>/rung.json), and en05_sobol checks it on
# other points 100x tighter. EN05 (creatio.pipeline.points.En05Runs) is planned with the
# invocation.
from creatio.pipeline.calibrate import EXAMPLE_OVERRIDES, EXAMPLE_TRACK


localrules:
    en05,
    en05_report,
    calibrate_example,


ruleorder: en05_sobol > study_dataset


rule en05:
    input:
        lambda wc: EN05.targets(),


rule en05_pilot:
    input:
        lambda wc: EN05.sample(wc.name).config_file,
    output:
        "data/sweeps/en05/{name}/rung.json",
    params:
        creatio=CREATIO,
        code=code_version("datasets"),
    threads: 1
    conda:
        "../envs/creatio.yaml"
    log:
        "data/sweeps/en05/{name}/logs/pilot.log",
    shell:
        "{params.creatio} task en05 pilot --config-file {input} --out {output} 2> {log}"


rule en05_points:
    input:
        unpack(lambda wc: EN05.sample(wc.name).inputs),
    output:
        "data/sweeps/en05/{name}/batches/p{size}-{batch}.nc",
    wildcard_constraints:
        size=r"\d+",
        batch=r"\d{5}",
    params:
        creatio=CREATIO,
        code=code_version("datasets"),
    threads: 1
    conda:
        "../envs/creatio.yaml"
    log:
        "data/sweeps/en05/{name}/logs/p{size}-{batch}.log",
    shell:
        "{params.creatio} task en05 batch --config-file {input.config} "
        "--batch {wildcards.batch} --batch-size {wildcards.size} --out {output} 2> {log}"


rule en05_sobol:
    input:
        config="{root}/configs/en05.yaml",
        batches=lambda wc: EN05.batches(wc.root),
    output:
        "{root}/studies/en05/en05_sobol.nc",
    params:
        creatio=CREATIO,
        code=code_version("datasets"),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/en05/en05_sobol.log",
    shell:
        "{params.creatio} task en05 sobol --config-file {input.config} --out {output} 2> {log}"


rule en05_report:
    input:
        lambda wc: [*JOBS.datasets(wc.root, "en05"), f"{wc.root}/studies/en05/en05_sobol.nc"],
    output:
        json="{root}/reports/en05.json",
        md=report("{root}/reports/en05.md", caption="../report/en05_markdown.rst",
                  category="EN-05", labels={"content": "report (markdown)"}),
        png=report("{root}/reports/en05.png", caption="../report/en05_indices.rst",
                   category="EN-05", labels={"content": "figure: Sobol' indices"}),
        csv=report("{root}/reports/en05_sobol.csv", caption="../report/en05_table.rst",
                   category="EN-05", labels={"content": "table: Sobol' indices"}),
        calibration=report("{root}/reports/en05_calibration.png",
                           caption="../report/en05_calibration.rst", category="EN-05",
                           labels={"content": "figure: calibration round trip"}),
        design=report("{root}/reports/en05_design.png", caption="../report/en05_design.rst",
                      category="EN-05", labels={"content": "figure: which test pins mu"}),
    wildcard_constraints:
        root=r"data|data/runs/[0-9a-f]{12}",
    params:
        creatio=CREATIO,
        code=code_version("reports"),
    conda:
        "../envs/creatio.yaml"
    log:
        "{root}/logs/en05_report.log",
    shell:
        "{params.creatio} task report en05 {wildcards.root}/reports {input} 2> {log}"


rule calibrate_example:
    input:
        track=str(EXAMPLE_TRACK),  # in the repository, whatever the working directory
    output:
        nc="data/calibration/en02_example/calibration.nc",
        json="data/calibration/en02_example/calibration.json",
        md=report("data/calibration/en02_example/calibration.md",
                  caption="../report/calibration_markdown.rst", category="EN-05",
                  labels={"content": "calibration of the example track (markdown)"}),
        png=report("data/calibration/en02_example/calibration.png",
                   caption="../report/calibration_figure.rst", category="EN-05",
                   labels={"content": "calibration of the example track: residuals"}),
    params:
        creatio=CREATIO,
        code=code_version("datasets") + code_version("reports"),
        overrides=" ".join(EXAMPLE_OVERRIDES),
    conda:
        "../envs/creatio.yaml"
    log:
        "data/calibration/en02_example/calibrate.log",
    shell:
        "{params.creatio} calibrate study=en02 track={input.track} "
        "'fit=[sphere.mu,sphere.eps]' {params.overrides} out=data/calibration/en02_example "
        "2> {log}"
