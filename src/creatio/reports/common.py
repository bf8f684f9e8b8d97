"""What every report shares: strict JSON, number formatting, markdown tables, matplotlib, and
the sphere kind's report frame (load a dt pair, write the JSON contract, compare the runs).

Reports are derived from datasets and never recompute a study. Numbers are formatted one
way everywhere (:func:`fmt`): four significant digits, scientific below 1e-3.
"""

from __future__ import annotations

import contextlib
import csv
import html
import json
import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.ticker import ScalarFormatter  # noqa: E402

from creatio.store.atomic import atomic_save, atomic_write  # noqa: E402
from creatio.studies.published import Published  # noqa: E402

__all__ = ["FAILURES", "PUBLISHED_HEADER", "RECORD", "RunCase", "as_list", "cell",
           "config_label", "config_paragraph", "config_title", "draw_figures",
           "figures_later", "finish_figure", "finite_max", "fmt", "h_key", "markdown_html",
           "nested", "paths_figure", "plt", "published_row",
           "readable_y", "run_case", "run_difference", "run_header", "start_report",
           "status_counts", "strict_json", "study_status", "table", "value_key", "write_csv",
           "write_markdown"]


def strict_json(data: Any) -> str:
    """Strict JSON: NaN and infinities (a figure not computed) become null."""
    def clean(x: Any) -> Any:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, list | tuple):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(data), indent=2, allow_nan=False) + "\n"


def h_key(h: float) -> str:
    """The h label of the report contract: Python's shortest float repr (0.01, 1e-05)."""
    return repr(float(h))


def nested(names: Sequence[str], keys: Sequence[str], values: np.ndarray) -> dict:
    """{name: {key: value}} from rows of values."""
    return {n: {k: float(v) for k, v in zip(keys, row, strict=True)}
            for n, row in zip(names, values, strict=True)}


def fmt(x: Any) -> str:
    """A number as reports print it: 4 significant digits, scientific below 1e-3; a
    published figure with the digits the notebook prints (1.110, not 1.11)."""
    if isinstance(x, Published):
        return x.text
    if isinstance(x, float | np.floating):
        return "nan" if math.isnan(x) else f"{x:.4g}" if abs(x) >= 1e-3 or x == 0 else f"{x:.3e}"
    return str(x)


#: Columns of a computed-vs-published table (reports of the notebook's studies).
PUBLISHED_HEADER = ["figure", "computed", "published", "computed - published", "agreement"]


def published_row(label: str, computed: float, published: Published) -> list[str]:
    """One row of a computed-vs-published table: the computed value to three more decimals
    than the notebook prints (or four significant digits beside a bound or a magnitude), the
    published digits, the difference and the verdict (Published.verdict)."""
    if not math.isfinite(computed):
        return [label, "not computed", published.text, "", published.verdict(computed)]
    if published.kind == "value":
        shown = f"{computed:.{published.decimals + 3}f}"
    else:
        shown = fmt(float(computed))
    d = float(computed) - float(published)
    diff = "0" if d == 0 else f"{d:+.3e}" if abs(d) < 1e-3 or abs(d) >= 1e5 else f"{d:+.4g}"
    return [label, shown, published.text, diff, published.verdict(float(computed))]


def cell(x: Any) -> str:
    """A table cell: the number formatted by :func:`fmt`, with ``|`` escaped so that a
    label such as ``max |C' - C'_fd|`` stays inside its cell when rendered."""
    return fmt(x).replace("|", "\\|")


def table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """Markdown table lines (cells formatted by :func:`fmt`, ``|`` escaped); every row must
    have one cell per header (a column without a header is a bug, not a blank)."""
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"table row {list(row)} has {len(row)} cells for {len(header)} "
                             f"columns {list(header)}")
    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return lines


def readable_y(ax: Any, y: Any) -> None:
    """No offset notation on the y axis (it hides the values); a series constant to
    rounding is drawn flat in the middle of a readable range around its value."""
    ax.ticklabel_format(axis="y", useOffset=False)
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return
    lo, hi = float(y.min()), float(y.max())
    scale = max(abs(lo), abs(hi))
    if scale > 0 and hi - lo <= 1e-6 * scale:
        pad = 1e-3 * scale
        ax.set_ylim(lo - pad, hi + pad)


def fixed_layout(fig: Any, left: float, right: float, bottom: float, top: float,
                 wgap: float = 0.0, hgap: float = 0.0) -> None:
    """Place a figure's grid of subplots by its margins and the gaps between panels, in
    inches, instead of ``fig.tight_layout()``, which measures every tick label before the
    draw measures them again: a third of a sphere report's drawing time here. The margins a
    figure passes are those tight_layout gives for the notebook's studies, with room to
    spare for longer tick labels."""
    width, height = fig.get_size_inches()
    spec = next(ax.get_subplotspec() for ax in fig.axes if ax.get_subplotspec() is not None)
    rows, cols = spec.get_topmost_subplotspec().get_gridspec().get_geometry()
    inner_w = width - left - right
    inner_h = height - bottom - top
    panel_w = (inner_w - (cols - 1) * wgap) / cols
    panel_h = (inner_h - (rows - 1) * hgap) / rows
    fig.subplots_adjust(left=left / width, right=1.0 - right / width, bottom=bottom / height,
                        top=1.0 - top / height, wspace=wgap / panel_w, hspace=hgap / panel_h)


def write_text(path: Path, text: str) -> Path:
    """Write a report file through a temporary sibling and a rename: a killed report job
    leaves the previous file or none, never a partial one."""
    with atomic_write(path) as fh:
        fh.write(text)
    return Path(path)


def save_figure(fig: Any, path: Path, **kwargs: Any) -> Path:
    """Save a matplotlib figure the same way (format from the suffix)."""
    return atomic_save(path, lambda tmp: fig.savefig(tmp, **kwargs))


#: The queues of figures to draw later (:func:`figures_later`), innermost last.
_LATER: list[list[Callable[[], None]]] = []


@contextlib.contextmanager
def figures_later(queue: list[Callable[[], None]] | None) -> Iterator[None]:
    """Within it, :func:`draw_figures` appends a report's figures to queue instead of
    drawing them, so that the caller can say its result first and draw them after (queue
    None: they are drawn at once, as outside it)."""
    if queue is None:
        yield
        return
    _LATER.append(queue)
    try:
        yield
    finally:
        _LATER.pop()


def draw_figures(tasks: Sequence[Callable[[], None]]) -> None:
    """Draw a report's independent figures (each task saves its files atomically): at once,
    in forked children where a core is free (creatio.store.forked), or queued for later
    within :func:`figures_later`."""
    if _LATER:
        _LATER[-1].extend(tasks)
        return
    from creatio.store.forked import run_all

    run_all(tasks)


#: Style of a report's HTML page (Snakemake's report shows it inline; a browser offline).
_CSS = ("body{font:14px/1.45 system-ui,sans-serif;margin:1.2em;color:#222;max-width:70em}"
        "table{border-collapse:collapse;margin:.6em 0}th,td{border:1px solid #ccc;"
        "padding:.2em .55em;text-align:right}th{background:#f3f3f3}td:first-child,"
        "th:first-child{text-align:left}code{background:#f3f3f3;padding:0 .2em}"
        "p.figures{color:#666;font-size:12px}figure{margin:.8em 0}figure img{max-width:100%}"
        "figcaption{color:#555;font-size:12px}")
_CELL = re.compile(r"(?<!\\)\|")


def _inline(text: str) -> str:
    """Markdown inline code and bold as HTML, the rest escaped."""
    out = html.escape(text.replace("\\|", "|"))
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    return re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", out)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in _CELL.split(line.strip().strip("|"))]


def markdown_html(text: str) -> str:
    """A report's markdown (headings, paragraphs, bullet lists, the tables of :func:`table`,
    images) as a standalone HTML page, so that Snakemake's report shows the tables instead
    of offering the markdown as a download. Every ``![alt](file)`` becomes an ``<img>`` with
    that alt text and a caption, its source relative as in the markdown (the figures sit
    beside the page)."""
    body: list[str] = []
    lines = text.splitlines()
    i = 0
    title = "report"
    while i < len(lines):
        line = lines[i]
        if line.startswith("|") and i + 1 < len(lines) and set(lines[i + 1]) <= set("|-: "):
            head = _cells(line)
            body.append("<table><tr>" + "".join(f"<th>{_inline(c)}</th>" for c in head)
                        + "</tr>")
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                body.append("<tr>" + "".join(f"<td>{_inline(c)}</td>"
                                             for c in _cells(lines[i])) + "</tr>")
                i += 1
            body.append("</table>")
            continue
        m = re.match(r"^(#{1,4}) (.*)", line)
        if m:
            level = len(m.group(1))
            if level == 1:
                title = m.group(2)
            body.append(f"<h{level}>{_inline(m.group(2))}</h{level}>")
        elif (img := re.match(r"^!\[([^]]*)\]\(([^)]+)\)", line)):
            alt, src = html.escape(img.group(1)), html.escape(img.group(2), quote=True)
            body.append(f'<figure><img src="{src}" alt="{alt}"><figcaption>{alt}'
                        "</figcaption></figure>")
        elif line.startswith(("* ", "- ")):
            body.append(f"<ul><li>{_inline(line[2:])}</li></ul>")
        elif line.strip():
            body.append(f"<p>{_inline(line.strip())}</p>")
        i += 1
    return ("<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
            f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
            + "\n".join(body).replace("</ul>\n<ul>", "\n") + "</body></html>\n")


def write_markdown(path: Path, text: str) -> Path:
    """Write a report's markdown and, beside it (same stem, .html), its HTML page."""
    write_text(path.with_suffix(".html"), markdown_html(text))
    return write_text(path, text)


# ---------------------------------- the sphere kind's reports (EN-02F, EN-02G, EN-03, EN-03M)
#: Statuses of a numerical failure (the others are physical outcomes, recorded per run).
FAILURES = ("non_finite", "step_failed", "step_size_collapse")


def as_list(datasets: xr.Dataset | Sequence[xr.Dataset]) -> list[xr.Dataset]:
    """One dataset or several, as a list."""
    return [datasets] if isinstance(datasets, xr.Dataset) else list(datasets)


def run_difference(coarse: xr.DataArray, fine: xr.DataArray) -> np.ndarray:
    """Max over the common output times of |centre_coarse - centre_fine| for each run of a
    stacked centre (run, time, component) or one run (time, component); NaN where a run has
    no common sample (before the last dim pair: any leading run dimensions are kept)."""
    common = np.intersect1d(np.round(coarse.time.values, 9), np.round(fine.time.values, 9))
    a = coarse.sel(time=common, method="nearest").values
    b = fine.sel(time=common, method="nearest").values
    d = np.linalg.norm(a - b, axis=-1)
    with np.errstate(all="ignore"):
        finite = np.isfinite(d)
        out = np.where(finite.any(axis=-1), np.nanmax(np.where(finite, d, -np.inf), axis=-1),
                       np.nan)
    return out


def finite_max(values: Any) -> float:
    """The largest finite value, NaN where there is none."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(v.max()) if v.size else math.nan


def study_status(statuses: Sequence[str]) -> str:
    """A study's status: "ok" unless one of its runs failed numerically."""
    return "failed" if any(s in FAILURES for s in statuses) else "ok"


def status_counts(statuses: Sequence[str]) -> dict[str, int]:
    """How many runs ended with each status."""
    out: dict[str, int] = {}
    for s in statuses:
        out[str(s)] = out.get(str(s), 0) + 1
    return out


def value_key(x: float) -> str:
    """A coordinate value as a JSON key: 5, 0.5, inf."""
    return "inf" if math.isinf(x) else f"{x:g}"


def _pair_line(runs: Sequence[xr.Dataset]) -> str:
    a = runs[0].attrs
    method = str(a.get("method", "rk4"))
    if "rtol" in a:
        return (f"{method} (adaptive) at rtol = {a['rtol']:g} compared with rtol = "
                f"{runs[-1].attrs.get('rtol', math.nan):g}")
    return f"{method.upper()} at dt = {a['dt']:g} s compared with dt = {runs[-1].attrs['dt']:g} s"


def run_header(ds: xr.Dataset, runs: Sequence[xr.Dataset], study: str) -> list[str]:
    """A report's first lines: title, the compared steps (or tolerances), config and code."""
    return [f"# {ds.attrs.get('title', study)}", "",
            f"{_pair_line(runs)}; config sha256 `{ds.attrs.get('config_sha256', '')[:12]}`, "
            f"creatio {ds.attrs.get('creatio_version')}, commit "
            f"{str(ds.attrs.get('git_commit', ''))[:10]}.", ""]


def write_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
    """A table as CSV, written atomically (NumPy floats as plain numbers)."""
    with atomic_write(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(header))
        w.writerows([[v if not isinstance(v, float | np.floating) else float(v) for v in row]
                     for row in rows])


def _report_paths(outdir: Path, study: str) -> dict[str, Path]:
    return {"json": outdir / f"{study}.json", "md": outdir / f"{study}.md",
            "html": outdir / f"{study}.html", "png": outdir / f"{study}.png",
            "csv": outdir / f"{study}_history.csv",
            "trajectory": outdir / f"{study}_trajectory.png",
            "convergence": outdir / f"{study}_convergence.png"}


def _load_runs(datasets: Sequence[Path]) -> tuple[list[xr.Dataset], dict]:
    from creatio.store.netcdf import read_dataset

    loaded = [read_dataset(p) for p in datasets]
    return [ds for ds, _ in loaded], loaded[0][1]


def start_report(datasets: Sequence[Path], outdir: str | Path,
           summary: Any) -> tuple[list[xr.Dataset], dict, dict[str, Path]]:
    """What every writer here does first: load the datasets, summarise them with
    summary(runs), write the JSON contract; returns (runs, summary, output paths)."""
    runs, _ = _load_runs(datasets)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    s = summary(runs)
    paths = _report_paths(outdir, s["study"])
    write_text(paths["json"], strict_json(s))
    return runs, s, paths


def finish_figure(fig: Any, path: Path) -> None:
    """Save and close a figure, with no offset notation on any linear y axis (an offset
    such as 1e-6 - 3.6e2 hides the values a reader looks for)."""
    for ax in fig.axes:
        if isinstance(ax.yaxis.get_major_formatter(), ScalarFormatter):
            ax.ticklabel_format(axis="y", useOffset=False)
    fig.tight_layout()
    save_figure(fig, path, dpi=100)
    plt.close(fig)


def paths_figure(named: Sequence[tuple[str, xr.Dataset]], path: Path, title: str) -> None:
    """Centre paths of named runs in the structure's frame and in the world frame."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 6))
    for label, ds in named:
        X = ds.centre.values
        W = ds.world_centre.values if "world_centre" in ds else X
        ax1.plot(X[:, 0], X[:, 1], lw=0.8, label=label)
        ax2.plot(W[:, 0], W[:, 1], lw=0.8, label=label)
    for ax, name in ((ax1, "in the structure's frame"), (ax2, "in the world frame")):
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(f"centre path {name}", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    finish_figure(fig, path)


# ---------------------------------------------- the config a report speaks about (issue 34)
#: The record the pipeline writes beside a run folder's files (creatio.pipeline.index):
#: the overrides as given and {key: [default, this run]} for every key the config changes.
RECORD = "overrides.json"


@dataclass
class RunCase:
    """Which config a report speaks about: the study, the overrides (as given), the keys
    its config changes from the default, and whether the notebook's figures apply."""

    study: str
    sha256: str
    overrides: list[str] = field(default_factory=list)
    changes: dict[str, list[Any]] = field(default_factory=dict)
    differs: dict[str, list[Any]] = field(default_factory=dict)
    has_published: bool = False
    #: top-level config group -> how many leaf keys the run's config has under it
    leaves: dict[str, int] = field(default_factory=dict)

    @property
    def published_case(self) -> bool:
        """Whether the report compares with the notebook: it publishes figures of this study
        and the run changes none of the keys they depend on."""
        return self.has_published and not self.differs

    def differs_text(self) -> str:
        """The differing keys as `key: default -> this run`, a group switched on as one (every
        key under it was null by default: `control`, not two new keys of `sphere`)."""
        def switched_on(head: str) -> bool:
            under = [v for k, v in self.differs.items() if k.startswith(head + ".")]
            return (len(under) > 1 and all(v[0] is None for v in under)
                    and len(under) >= self.leaves.get(head, 0))

        parts: list[str] = []
        for key, (old, new) in self.differs.items():
            head = key.split(".")[0]
            text = (f"`{head}`: none -> set" if "." in key and switched_on(head)
                    else f"`{key}`: {old} -> {new}")
            if text not in parts:
                parts.append(text)
        return ", ".join(parts)

    def json(self) -> dict[str, Any]:
        """The contract keys: published_case, overrides, differs (key: [default, run])."""
        return {"published_case": self.published_case, "overrides": list(self.overrides),
                "differs": {k: list(v) for k, v in self.differs.items()}}


def _record(datasets: Sequence[Path]) -> dict[str, Any] | None:
    """The run folder's record (overrides.json at the datasets' output root), None for a
    default run (the data directory has none)."""
    from creatio.store.regular import read_json
    from creatio.studies.registry import KINDS

    if not datasets:
        return None
    folder = Path(datasets[0]).resolve().parent.parent  # <root>/<dataset_dir>/<study>/x.nc
    if folder.name not in {k.dataset_dir for k in KINDS.values()}:
        return None
    try:  # absent (the default run), a pipe or garbage: no record
        data = read_json(folder.parent / RECORD)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def given_overrides(ds: xr.Dataset) -> list[str] | None:
    """The overrides as the user typed them, from the dataset's history when `creatio run`
    made it (``... created by creatio X: creatio run study=en02 control=pd``); None else."""
    history = str(ds.attrs.get("history", ""))
    _, sep, command = history.rpartition(": ")
    words = command.split()
    if not sep or words[:2] != ["creatio", "run"]:
        return None
    return [w for w in words[2:] if "=" in w and not w.startswith("-")
            and w.split("=", 1)[0] not in ("study", "analysis", "+study", "++study")
            and not w.lstrip("+~").startswith("hydra.")]  # Hydra's own: not the config


def run_case(datasets: Sequence[Path], ds: xr.Dataset) -> RunCase:
    """The config a report's datasets come from: study and hash from the dataset, overrides
    and changed keys from the run folder's record (none: the default, published case), the
    keys that matter to the published figures from the study registry."""
    from creatio.studies import registry

    study = str(ds.attrs.get("study", ""))
    sha = str(ds.attrs.get("config_sha256", ""))
    record = _record(datasets) or {}
    changes: Mapping[str, Any] = record.get("changes") or {}
    try:
        entry = registry.get(study)
    except KeyError:
        entry = None
    differs = ({k: list(changes[k]) for k in entry.published_keys(changes)} if entry
               else {k: list(v) for k, v in changes.items()})
    given = given_overrides(ds) if record else None
    overrides = given if given else [str(o) for o in record.get("overrides") or []]
    return RunCase(study, sha, overrides,
                   {k: list(v) for k, v in changes.items()}, differs,
                   bool(entry and entry.published), _leaves(ds))


def _leaves(ds: xr.Dataset) -> dict[str, int]:
    """How many set (non-null) leaf keys the dataset's resolved config has under each
    top-level group."""
    from creatio.store.yamlio import load_yaml

    def count(node: Any) -> int:
        if isinstance(node, dict):
            return sum(count(v) for v in node.values())
        return int(node is not None)

    try:
        config = load_yaml(str(ds.attrs.get("config_yaml", ""))) or {}
    except Exception:  # noqa: BLE001 - an unreadable config: no group is collapsed
        return {}
    return {k: count(v) for k, v in config.items()} if isinstance(config, dict) else {}


def config_title(ds: xr.Dataset, case: RunCase) -> str:
    """A report's title line: the study's title, and the overrides as given when any (a
    run of a changed config never carries the default run's title alone)."""
    title = str(ds.attrs.get("title", case.study))
    return f"# {title}" + (f", with {' '.join(case.overrides)}" if case.overrides else "")


def config_label(case: RunCase) -> str:
    """The config in a few words for an answer line: study, overrides, config hash."""
    ovs = " ".join(case.overrides)
    return (f"study {case.study}, " + (f"overrides {ovs}" if ovs else "default config")
            + f", config {case.sha256[:12]}")


def config_paragraph(ds: xr.Dataset, case: RunCase) -> list[str]:
    """The paragraph naming a report's config (study, overrides as given, config hash,
    code), then one line on whether the notebook's figures apply: compared below, none for
    this study, or none for this config, naming the keys that differ (default -> this run)."""
    ovs = " ".join(case.overrides)
    lines = [f"Study `{case.study}`, "
             + (f"overrides `{ovs}`" if ovs else "default config (no overrides)")
             + f", config sha256 `{case.sha256[:12]}`; creatio {ds.attrs.get('creatio_version')},"
             f" commit {str(ds.attrs.get('git_commit', ''))[:10]}.", ""]
    if not case.has_published:
        lines += ["The notebook publishes no figure of this study: the figures below are "
                  "computed alone.", ""]
    elif case.differs:
        lines += [f"**No published figure for this config**: the notebook's figures are for "
                  f"the default {case.study} config, and this run changes "
                  f"{case.differs_text()}. The figures below are computed alone.", ""]
    else:
        lines += ["The notebook publishes figures of this config: they are compared below.",
                  ""]
    return lines
