# The names every rule file uses, from the invocation's plan (creatio.pipeline.invocation).
import sys
from pathlib import Path

from creatio.pipeline.code import code_version
from creatio.pipeline.index import refresh_index
from creatio.pipeline.planning import published_groups, wildcard_pattern

CREATIO = PLAN.command  # the interpreter that runs Snakemake, with -m creatio.cli
STUDY_IDS = PLAN.study_ids
ANALYSIS_IDS = PLAN.analysis_ids
JOBS = PLAN.jobs  # (output root, study) -> its resolved config, for every job
RUNS = PLAN.runs  # the studies of `all`
ANALYSES = PLAN.analyses
SWEEPS = PLAN.sweeps
BEYOND = PLAN.beyond
EN05 = PLAN.en05


wildcard_constraints:
    root=r"data|data/runs/[0-9a-f]{12}",


def list_results() -> None:
    """After a successful run: rewrite data/index.html when what it lists changed (rule
    index, index.smk), and say where it is."""
    page = refresh_index("data")
    if page is not None:
        print(f"creatio: results listed in {page} (creatio ls; creatio open NAME)",
              file=sys.stderr)
