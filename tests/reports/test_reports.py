"""What a reader of the reports tripped over (issue 27), each with the input that showed it:
the published digits without a difference, a trajectory hidden under its markers, two
compared paths told apart by marker shape only, a slip speed flattened on a linear axis,
nan cells and whole messages in sweep tables, tables only downloadable from Snakemake's
report, a caption promising published values a study does not have."""

from __future__ import annotations

from pathlib import Path

import jinja2
import matplotlib.colors as mcolors
import numpy as np
import pytest
import xarray as xr

from creatio.pipeline.config import resolve
from creatio.reports.common import PUBLISHED_HEADER, markdown_html, plt, published_row, table
from creatio.reports.sphere import trajectory_figure, zoom_box
from creatio.reports.sweep import log_scale, status_cells, write_sweep_report
from creatio.studies.published import EN02, Published

REPO = Path(__file__).resolve().parents[2]


# ------------------------------------------------------------------------------ published
def test_a_published_figure_keeps_its_digits_and_reads_as_a_float():
    """1.110 was printed as 1.11 (a float drops the trailing zero): the notebook's digits
    are kept, and tests compare the value as before."""
    r = EN02["final_radius_m"]
    assert (r.text, float(r), r.kind) == ("1.110", 1.11, "value")
    assert round(1.11000000001707, 3) == r and r.half_unit == pytest.approx(5e-4)
    assert EN02["timestep_difference_m"].kind == "bound"


@pytest.mark.parametrize(("computed", "verdict"), [
    (1.11000000001707, "agrees to the printed digits"),   # EN-02's final radius
    (1.1104999, "agrees to the printed digits"),
    (1.1075207861573741, "differs by 2.48 units of the last digit"),   # EN-02V's
    (float("nan"), "not computed"),
])
def test_the_difference_and_the_verdict_against_the_printed_digits(computed, verdict):
    row = published_row("final centre radius (m)", computed, EN02["final_radius_m"])
    assert row[2] == "1.110" and row[4] == verdict
    if np.isfinite(computed):
        assert float(row[3]) == pytest.approx(computed - 1.110, rel=1e-3)
        assert len(row[1].split(".")[1]) == 6  # three decimals more than the notebook's


def test_a_bound_and_a_magnitude_are_judged_as_such():
    bound = Published("6.04e-11", "bound")
    assert published_row("dt", 7.1e-14, bound)[4] == "below the bound"
    assert published_row("dt", 7.1e-11, bound)[4] == "ABOVE the bound"
    noise = Published("3.33e-16", "magnitude")
    assert published_row("n", 5.55e-16, noise)[4] == "same order"
    assert published_row("n", 5.55e-14, noise)[4] == "other order of magnitude"
    lines = table(PUBLISHED_HEADER, [published_row("dt", 7.1e-14, bound)])
    assert lines[0] == "| figure | computed | published | computed - published | agreement |"


# ------------------------------------------------------------------------------ trajectories
def _path(cx: float, cy: float, r: float, t_end: float = 120.0, n: int = 241) -> xr.Dataset:
    t = np.linspace(0.0, t_end, n)
    a = np.linspace(0.0, 2 * np.pi, n)
    centre = np.stack([cx + r * np.cos(a), cy + r * np.sin(a), 0.1 + 0 * a], axis=-1)
    return xr.Dataset({"centre": (("time", "component"), centre)}, coords={"time": t})


def test_a_path_too_small_for_the_annulus_gets_a_magnified_inset():
    """EN-02V moves about 10 cm on an annulus 4.8 m across: at full scale its path is under
    the start marker. It gets an inset around the path; a whole cycle does not."""
    config = resolve("en02v").data
    small = [("en02v", _path(1.0, 0.5, 0.03, t_end=20.0))]
    box = zoom_box(small, 2.4)
    assert box is not None and box[1] - box[0] == pytest.approx(0.06 * 1.3)
    assert box[0] < 0.97 and box[1] > 1.03 and box[2] < 0.47 and box[3] > 0.53
    assert zoom_box([("en02", _path(0.0, 0.0, 1.11))], 2.4) is None
    fig = trajectory_figure(small, config)
    main_ax = fig.axes[0]
    insets = [a for a in main_ax.child_axes]
    assert len(insets) == 1 and insets[0].get_xlim() == pytest.approx(box[:2])
    assert "mm across" in insets[0].get_title()
    plt.close(fig)


def test_compared_paths_differ_by_colour_and_line_style_with_a_legend():
    """compare drew both paths in one viridis time scale, told apart by marker shape alone."""
    config = resolve("en02").data
    runs = [("en02", _path(0.0, 0.0, 1.11)), ("en02r", _path(0.1, 0.0, 1.5))]
    fig = trajectory_figure(runs, config)
    ax = fig.axes[0]
    lines = {ln.get_label(): ln for ln in ax.get_lines() if ln.get_label() in ("en02", "en02r")}
    assert set(lines) == {"en02", "en02r"}
    a, b = lines["en02"], lines["en02r"]
    assert not np.allclose(mcolors.to_rgba(a.get_color()), mcolors.to_rgba(b.get_color()))
    assert a.get_linestyle() != b.get_linestyle()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"en02", "en02r", "start", "end"} <= set(legend)
    marks = [t.get_text() for t in ax.texts]
    assert "30 s" in marks and "120 s" in marks  # the time along each path, labelled
    plt.close(fig)


# ------------------------------------------------------------------------------ layout
def _histories(scale: float, n: int = 601) -> xr.Dataset:
    """A sphere dataset's histories with tick labels as wide as a run gives: values of
    thousands, fractions near a constant, negatives, and the twin azimuth axis."""
    t = np.linspace(0.0, 120.0, n)
    s = np.sin(t / 19.0)
    one = ("time",)
    return xr.Dataset(
        {"centre_radius": (one, 1.11 + 4e-4 * s), "centre_azimuth": (one, -360.0 * t / 120.0),
         "speed": (one, 0.11 * s * s), "normal_reaction": (one, 9.81 + 0 * t),
         "slip_speed": (one, -2.2e-5 * s), "friction": (("time", "component"),
                                                       np.stack([s, -s, s], axis=-1)),
         "spin_rate": (one, scale * s), "cumulative_spin": (one, -scale * 3330.87 * t),
         "angular_lag": (one, -1.4e-3 * s), "energy": (one, -0.0861 * scale * s)},
        coords={"time": t}, attrs={"title": "EN-02 wide labels", "dt": 0.002, "status": "ok"})


@pytest.mark.parametrize("scale", [1.0, -1234.5])
def test_history_panels_keep_their_labels_apart(monkeypatch, tmp_path, scale):
    """The history figure is laid out by fixed margins (not tight_layout): every label stays
    inside the figure and clear of the neighbouring panels, for tick labels of up to eight
    characters and the twin azimuth axis of the first panel."""
    from creatio.reports import sphere

    drawn = []

    def keep(fig, path, **kwargs):
        fig.canvas.draw()
        drawn.append(fig)

    monkeypatch.setattr(sphere, "save_figure", keep)
    monkeypatch.setattr(sphere.plt, "close", lambda fig: None)
    sphere._history_figure(_histories(scale), tmp_path / "h.png")
    fig = drawn[0]
    renderer = fig.canvas.get_renderer()
    whole = fig.bbox
    panels = [ax for ax in fig.axes]
    for ax in panels:
        shown = [t for axis, i in ((ax.xaxis, 0), (ax.yaxis, 1)) for t in axis.get_ticklabels()
                 if min(axis.get_view_interval()) <= t.get_position()[i]
                 <= max(axis.get_view_interval())]  # labels of ticks in view are drawn
        texts = [ax.yaxis.label, ax.xaxis.label, *shown]
        boxes = [t.get_window_extent(renderer) for t in texts if t.get_visible() and t.get_text()]
        assert boxes
        for box in boxes:
            assert whole.x0 <= box.x0 and box.x1 <= whole.x1
            assert whole.y0 <= box.y0 and box.y1 <= whole.y1
            for other in panels:
                if other is ax or other.get_position().bounds == ax.get_position().bounds:
                    continue  # the twin shares its panel
                assert not box.overlaps(other.get_window_extent(renderer)), (
                    ax.get_ylabel(), other.get_ylabel())
    plt.close(fig)


# ------------------------------------------------------------------------------ sweeps
SLIP = np.array([0.109, 1.746e-4, 8.729e-5, 4.365e-5, 2.910e-5, 2.182e-5, 1.746e-5, 1.455e-5])


def test_the_slip_speed_of_the_worked_sweep_goes_on_a_log_axis():
    """From 0.109 m/s at mu = 0 to 1.5e-5 m/s: linearly, seven of eight points sit on 0."""
    assert log_scale(SLIP)
    assert not log_scale(np.full(8, 9.81)) and not log_scale(np.array([0.0, 1e-5, 0.1]))
    assert not log_scale(np.array([-360.0, -359.9]))


def test_sweep_tables_show_a_short_status_with_the_reason_in_a_footnote(tmp_path):
    """The worked sweep printed `nan` in every figure of a refused point and its whole
    validation message in the status cell."""
    reason = ("invalid config: solver.dt=0.002: beyond the RK4 stability limit of the "
              "regularised friction (sphere.mu = 0.35, sphere.eps = 0.01)")
    mu = np.array([0.0, 0.15, 0.35, 0.4])
    ds = xr.Dataset({
        "max_slip_speed_m_s": ("sphere__mu", [0.109, 2.9e-5, np.nan, np.nan]),
        "cumulative_spin_deg": ("sphere__mu", [0.0, 3331.0, np.nan, np.nan]),
        "stability_limit_dt_s": ("sphere__mu", [np.inf, 0.0043, 0.0019, 0.0016]),
        "dt_s": ("sphere__mu", [0.002] * 4),
        "status": ("sphere__mu", ["ok", "ok", "invalid", "invalid"]),
        "message": ("sphere__mu", ["", "", reason, reason]),
    }, coords={"sphere__mu": ("sphere__mu", mu, {"long_name": "sphere.mu"})},
        attrs={"title": "sweep", "points": 4, "points_run": 2, "base_overrides": "[]"})
    text = write_sweep_report(ds, tmp_path)["md"].read_text()
    assert "nan" not in text and text.count(reason) == 1  # once, as footnote [1]
    rows = [ln for ln in text.splitlines() if ln.startswith("| 0.35") or ln.startswith("| 0.4")]
    assert all("| invalid [1] | — | — |" in r for r in rows)
    assert f"[1] {reason}" in text and "| 0 | ok | 0 | 0.109 | none |" in text
    cells, notes = status_cells(["ok", "invalid", "invalid", "contact_lost"],
                                ["", "a", "b", ""])
    assert cells == ["ok", "invalid [1]", "invalid [2]", "contact_lost"]
    assert notes == ["[1] a", "[2] b"]


# ------------------------------------------------------------------------------ Snakemake report
def test_report_tables_are_shown_as_html_not_only_offered_as_downloads():
    """Snakemake's report shows HTML in place and offers markdown as a download: the
    report's tables go to <study>.html, pipes in labels kept, figures embedded with their alt
    text (issue 34: the page `creatio open` shows had none)."""
    md = "\n".join(["# EN-01", "", "## Regularity", "",
                    *table(PUBLISHED_HEADER, [published_row(
                        "max | |n| - 1 |", 5.55e-16, Published("3.33e-16", "magnitude"))]),
                    "", "![convergence](en01.png)", ""])
    page = markdown_html(md)
    assert "<th>computed - published</th>" in page
    assert "<td>max | |n| - 1 |</td><td>5.550e-16</td><td>3.33e-16</td>" in page
    assert '<img src="en01.png" alt="convergence">' in page
    assert "Figures of this report" not in page
    assert page.startswith("<!DOCTYPE html>") and "<title>EN-01</title>" in page


class _Job:
    def __init__(self, study: str, published: str) -> None:
        self.wildcards = {"study": study}
        self.params = {"published": published}
        self.input = ["data/studies/x/x.nc"]


def _caption(name: str, study: str, published: str) -> str:
    env = jinja2.Environment()
    job = _Job(study, published)
    ns = type("S", (), {"wildcards": type("W", (), job.wildcards)(),
                        "params": type("P", (), job.params)(), "input": job.input})()
    return env.from_string((REPO / "workflows" / "report" / name).read_text()).render(
        snakemake=ns)


@pytest.mark.parametrize("name", ["kinematic_figure.rst", "kinematic_table.rst",
                                  "study_markdown.rst"])
def test_captions_promise_published_values_only_where_the_notebook_gives_them(name):
    """The CT-02 caption said the published values are dashed; CT-02 has none."""
    ct02 = _caption(name, "ct02", "")
    en01 = _caption(name, "en01", "fd_error pattern regularity")
    assert "publishes no" in ct02 and "published values dashed" not in ct02
    assert "publishes no" not in en01 and "notebook" in en01
