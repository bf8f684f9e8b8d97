# Releases and regression diffs of the default outputs (logic in creatio.pipeline.release).
#
#   snakemake release -c 2 --config version=0.2.0   make data/ current, freeze it in
#                                                   data/releases/0.2.0/ (never overwritten)
#   snakemake diff -c 2 --config against=0.1.0      data/reports/diff/0.1.0_vs_data.{txt,json}
#   snakemake diff -c 2 --config against=latest atol=1e-12 rtol=1e-9 'tol=["fd_error*=1e-8"]'
#
# The diff carries a digest of the release's files: an edited or deleted release file reruns
# it, and `creatio diff` refuses a release that no longer matches its manifest (exit 1).
# `release` has no output file on purpose: Snakemake must never delete or redo a release,
# and `creatio release` refuses an existing version. The diff report is written even when
# there are differences (read it, or gate on `creatio diff` itself, which exits 1).
from creatio.pipeline import release as _release


localrules:
    release,
    diff,
    diff_report,


rule release:
    input:
        lambda wc: _release.workflow_outputs(RUNS.plans, whole=True),
    params:
        creatio=CREATIO,
        version=lambda wc: _release.workflow_version(config),
    conda:
        "../envs/creatio.yaml"
    log:
        "data/logs/release.log",
    shell:
        "{params.creatio} release {params.version} 2> {log}"


rule diff:
    input:
        lambda wc: expand(
            "data/reports/diff/{version}_vs_data.{ext}",
            version=_release.workflow_against(config),
            ext=("txt", "json"),
        ),


rule diff_report:
    input:
        manifest="data/releases/{version}/MANIFEST.json",
        data=lambda wc: _release.workflow_outputs(RUNS.plans),
    output:
        txt="data/reports/diff/{version}_vs_data.txt",
        json="data/reports/diff/{version}_vs_data.json",
    wildcard_constraints:
        version=r"\d+\.\d+\.\d+(?:(?:a|b|rc)\d+)?",
    params:
        creatio=CREATIO,
        options=lambda wc: _release.workflow_diff_options(config, RUNS.plans),
        release=lambda wc: _release.workflow_release_digest(wc.version),
    conda:
        "../envs/creatio.yaml"
    log:
        "data/logs/diff_{version}.log",
    shell:
        "{params.creatio} diff {wildcards.version} data --exit-zero --quiet "
        "--text-out {output.txt} --json-out {output.json} {params.options} 2> {log}"
