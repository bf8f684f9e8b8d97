# Reports derived from the datasets: JSON contract, markdown, CSV and figures.


rule kinematic_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        json="{root}/reports/{study}.json",
        md="{root}/reports/{study}.md",
        png="{root}/reports/{study}.png",
        csv="{root}/reports/{study}_fd_error.csv",
    wildcard_constraints:
        study="ct02|en01",
    params:
        creatio=CREATIO,
    conda:
        "envs/creatio.yaml"
    log:
        "{root}/logs/{study}_report.log",
    shell:
        "{params.creatio} task report {wildcards.study} {wildcards.root}/reports {input} 2> {log}"


rule dynamic_report:
    input:
        lambda wc: JOBS.datasets(wc.root, wc.study),
    output:
        json="{root}/reports/{study}.json",
        md="{root}/reports/{study}.md",
        png="{root}/reports/{study}.png",
        csv="{root}/reports/{study}_history.csv",
        trajectory="{root}/reports/{study}_trajectory.png",
        convergence="{root}/reports/{study}_convergence.png",
    wildcard_constraints:
        study="en02|en02r",
    params:
        creatio=CREATIO,
    conda:
        "envs/creatio.yaml"
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
        md="{root}/reports/compare_en02_en02r.md",
        png="{root}/reports/compare_en02_en02r.png",
    params:
        creatio=CREATIO,
    conda:
        "envs/creatio.yaml"
    log:
        "{root}/logs/compare_en02_en02r.log",
    shell:
        "{params.creatio} task compare {wildcards.root}/reports {input.datasets} 2> {log}"
