# Snakemake's own report: `snakemake --report data/report.html` (after `make all`, and after
# `snakemake scenes`, `snakemake benchmarks`, `snakemake sweep_en02_mu` for those to appear).
#
# Which outputs it holds, under which category (one per study; Scenes, Comparison, Sweeps,
# Benchmarks), with which caption (workflows/report/*.rst, rendered with the job's wildcards).
# Rules wrap their outputs with reported(...) / reported_scene(...); captions are resolved
# from workflows/rules/, where every rule lives.
import sys
from pathlib import Path

from creatio.studies.registry import KINDS as _REPORT_KINDS


report: "workflow.rst"


#: True for `snakemake --report ...`: the report then also takes in the scenes, sweeps and
#: benchmarks already built (a plain `snakemake all` never reruns them).
REPORTING = any(a == "--report" or a.startswith("--report=") for a in sys.argv)

#: Per kind of study: report file suffix -> (caption, what the file is).
REPORTED = {
    "kinematic": {
        ".png": ("kinematic_figure.rst", "figure: derivative check"),
        "_fd_error.csv": ("kinematic_table.rst", "table: derivative check"),
        ".html": ("study_markdown.rst", "report tables"),
    },
    "sphere": {
        ".png": ("sphere_histories.rst", "figure: time histories"),
        "_trajectory.png": ("sphere_trajectory.rst", "figure: centre path"),
        "_convergence.png": ("sphere_convergence.rst", "figure: dt vs dt/2, energy residual"),
        "_history.csv": ("sphere_table.rst", "table: time histories"),
        ".html": ("study_markdown.rst", "report tables"),
    },
    "material": {
        ".png": ("material_figure.rst", "figure: strain maps"),
        ".html": ("study_markdown.rst", "report tables"),
    },
    "analysis": {
        ".png": ("analysis_figure.rst", "figure"),
        ".md": ("analysis_markdown.rst", "report (markdown)"),
    },
}

#: Scene files -> (caption, what the file is). Only the poster is embedded: the page (its own
#: three.js and frames, 0.6-3.2 MB) and the animation (0.7-1.6 MB) are linked from its caption,
#: which kept the report from carrying five copies of three.js and every animation.
REPORTED_SCENE = {
    "poster.png": ("scene_poster.rst", "poster, with links to the page and the animation"),
}


def report_category(study: str) -> str:
    """The report category of a study: its notebook name (EN-02R), or Benchmarks."""
    from creatio.studies.registry import get

    if get(study).kind.name == "analysis":
        return "Benchmarks"
    head = study.rstrip("rvgfm")
    return f"{head[:2].upper()}-{head[2:]}{study[len(head):].upper()}"


def _config_label(wc) -> str:
    return "default" if wc.root == "data" else wc.root.rsplit("/", 1)[-1]


def reported(kind: str) -> list:
    """The report files of a kind of study, as rule outputs, flagged for the report where
    REPORTED says (under the study's category, labelled by content and config)."""
    k = _REPORT_KINDS[kind]
    out = []
    for suffix in k.reports:
        path = f"{{root}}/{k.report_dir}/{{study}}{suffix}"
        if suffix in REPORTED[kind]:
            caption, what = REPORTED[kind][suffix]
            path = report(
                path,
                caption=f"../report/{caption}",
                category=lambda wc: report_category(wc.study),
                labels=lambda wc, what=what: {"content": what, "config": _config_label(wc)},
            )
        out.append(path)
    return out


def reported_scene(path: str):
    """A scene file flagged for the report (category Scenes, labelled by scene and file)."""
    caption, what = REPORTED_SCENE[Path(path).name]
    return report(
        path,
        caption=f"../report/{caption}",
        category="Scenes",
        labels=lambda wc, what=what: {"scene": wc.scene, "content": what,
                                      "config": _config_label(wc)},
    )


def reported_plain(path: str, caption: str, category: str, what: str):
    """Any other output flagged for the report (the comparison, sweeps)."""
    return report(path, caption=f"../report/{caption}", category=category,
                  labels={"content": what})


def report_extras() -> list:
    """In report mode, the built scenes, benchmarks and worked sweep (their files exist):
    added to `all` so that their jobs are in the report's DAG. Empty otherwise."""
    if not REPORTING:
        return []
    out = []
    try:
        out += SCENES.built()
    except Exception as e:  # noqa: BLE001 - a report never fails on an extra
        print(f"creatio: report: scenes left out: {e}", file=sys.stderr)
    for targets in (lambda: ANALYSES.targets(), lambda: SWEEPS.worked("en02_mu"),
                    lambda: EN05.targets()):
        try:
            files = targets()
        except Exception as e:  # noqa: BLE001
            print(f"creatio: report: left out: {e}", file=sys.stderr)
            continue
        if all(Path(f).is_file() for f in files):
            out += files
    if config.get("sweep"):
        files = SWEEPS.outputs(config.get("study", ""), config["sweep"], config.get("overrides"))
        out += [f for f in files if Path(f).is_file()]
    return out
