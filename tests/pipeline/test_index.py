"""Finding results: the run records, the index page, `creatio ls` and `creatio open`.

Before, runs and sweeps sat in hash-named folders that nothing described, and nothing
listed what was built: these build a data directory of every kind of result and check that
each is listed with what made it, its status and files that exist."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.cli import main as cli
from creatio.pipeline.config import resolve
from creatio.pipeline.index import (
    changes,
    record_calibration,
    record_run,
    record_sweep,
    refresh_index,
    scan,
    write_index,
)
from creatio.store.netcdf import write_dataset


def _dataset(status: str = "ok") -> xr.Dataset:
    t = np.arange(3) * 0.5
    return xr.Dataset({"x": ("time", t, {"units": "m"})},
                      coords={"time": ("time", t, {"units": "s"})}, attrs={"status": status})


@pytest.fixture
def data(tmp_path) -> Path:
    """A data directory with a default study, a run with overrides, an older run without a
    record, a sweep, a scene and a benchmark."""
    d = tmp_path / "data"
    write_dataset(_dataset(), d / "studies" / "en02" / "en02_dt0.002.nc")
    (d / "reports").mkdir(parents=True)
    for suffix, text in ((".json", json.dumps({"status": "ok"})), (".md", "# EN-02\n"),
                         (".html", "<p>EN-02</p>"), (".png", "png")):
        (d / "reports" / f"en02{suffix}").write_text(text)
    mu = resolve("en02", ["sphere.mu=0.3"])
    run = d / "runs" / mu.key
    write_dataset(_dataset("contact_lost"), run / "studies" / "en02" / "en02_dt0.002.nc")
    (run / "reports").mkdir(parents=True)
    (run / "reports" / "en02.json").write_text(json.dumps({"status": "contact_lost"}))
    record_run(run, "study", "en02", mu.data, resolve("en02").data, ["sphere.mu=0.3"],
               mu.sha256, d)
    old = resolve("en02r", ["sphere.mu=0.2"])  # made before records existed: configs only
    (d / "runs" / old.key / "configs").mkdir(parents=True)
    (d / "runs" / old.key / "configs" / "en02r.yaml").write_text(old.yaml)
    write_dataset(_dataset(), d / "runs" / old.key / "studies" / "en02r" / "en02r_dt0.002.nc")
    sweep = d / "sweeps" / "en02-0123456789ab"
    write_dataset(_dataset(), sweep / "sweep.nc")
    (sweep / "sweep.md").write_text("| mu |\n")
    record_sweep(sweep, "en02", [("sphere.mu", ["0", "0.15", "0.4"])], ["phases.T=60"], 3, 2)
    scene = d / "scenes" / "compare"
    write_dataset(xr.Dataset({"status": ("run", ["ok", "ok"])}), scene / "scene.nc")
    (scene / "index.html").write_text("<html></html>")
    (d / "benchmarks").mkdir()
    (d / "benchmarks" / "stability_map.json").write_text("{}")
    (d / "benchmarks" / "stability_map.md").write_text("# map\n")
    return d


def test_every_kind_of_result_is_listed_with_what_made_it(data):
    entries = {e.name: e for e in scan(data)}
    mu = resolve("en02", ["sphere.mu=0.3"]).key
    old = resolve("en02r", ["sphere.mu=0.2"]).key
    assert set(entries) == {"en02", f"runs/{mu}/en02", f"runs/{old}/en02r",
                            "sweeps/en02-0123456789ab", "scenes/compare",
                            "stability_map"}
    assert entries["en02"].overrides == [] and entries["en02"].status == "ok"
    assert entries["en02"].main == "reports/en02.html"
    run = entries[f"runs/{mu}/en02"]
    assert (run.kind, run.overrides, run.status) == ("run", ["sphere.mu=0.3"], "contact_lost")
    assert run.links["dataset"] == f"runs/{mu}/studies/en02/en02_dt0.002.nc"
    # an older run folder without its record: the keys its config changes
    assert entries[f"runs/{old}/en02r"].overrides == ["sphere.mu=0.2"]
    assert entries[f"runs/{old}/en02r"].status == "ok; report not built"
    sweep = entries["sweeps/en02-0123456789ab"]
    assert sweep.overrides == ["sweep sphere.mu=0,0.15,0.4", "phases.T=60"]
    assert sweep.status == "2 of 3 points ran" and sweep.main.endswith("sweep.md")
    assert entries["scenes/compare"].status == "ok"
    assert entries["scenes/compare"].main == "scenes/compare/index.html"
    assert entries["stability_map"].kind == "benchmark"
    for e in entries.values():  # every link is a file of the data directory
        assert all((data / p).is_file() for p in e.links.values()), e


def test_the_index_page_links_every_result_relative_and_offline(data):
    page = write_index(data)
    text = page.read_text()
    for e in scan(data):
        assert e.name in text
        for link in e.links.values():
            assert f"href='{link}'" in text and (page.parent / link).is_file()
    assert "http" not in text.replace("http-equiv", "")  # nothing fetched: offline
    assert "sphere.mu=0.3" in text and "contact_lost" in text
    before = page.stat().st_mtime_ns
    assert refresh_index(data) == page and page.stat().st_mtime_ns == before  # unchanged
    (data / "scenes" / "compare" / "index.html").unlink()
    refresh_index(data)
    assert "page not built" in page.read_text()


def test_record_run_gives_the_overrides_and_the_keys_they_change(tmp_path):
    default = resolve("en02").data
    mu = resolve("en02", ["sphere.mu=0.3", "phases.T=60"])
    path = record_run(tmp_path / "runs" / mu.key, "study", "en02", mu.data, default,
                      ["sphere.mu=0.3", "phases.T=60"], mu.sha256, tmp_path)
    record = json.loads(path.read_text())
    assert record["overrides"] == ["sphere.mu=0.3", "phases.T=60"]
    # what the resolved config changes: study.duration follows phases.T (an interpolation)
    assert record["changes"] == {"phases.T": [120.0, 60.0], "sphere.mu": [0.15, 0.3],
                                 "study.duration": [120.0, 60.0]}
    assert record_run(tmp_path, "study", "en02", default, default, [], "x", tmp_path) is None
    assert changes({"a": {"b": 1}}, {"a": {"b": 1, "c": 2}}) == {"a.c": [None, 2]}


def test_creatio_ls_and_open(data, capsys, monkeypatch):
    monkeypatch.chdir(data.parent)
    assert cli(["ls"]) == 0
    out = capsys.readouterr().out
    assert "en02" in out and "sphere.mu=0.3" in out and "2 of 3 points ran" in out
    assert out.splitlines()[-1] == "6 result(s); index page: data/index.html"
    assert cli(["ls", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert {e["kind"] for e in listed} == {"study", "run", "sweep", "scene", "benchmark"}
    assert cli(["open", "en02"]) == 0  # the exact name wins over runs/.../en02
    assert capsys.readouterr().out.strip() == str((data / "reports" / "en02.html").resolve())
    assert cli(["open", "0123456789"]) == 0  # a unique part of a name
    assert capsys.readouterr().out.strip().endswith("sweeps/en02-0123456789ab/sweep.md")
    assert cli(["open", "en0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("creatio open: 'en0' matches ") and len(err.splitlines()) == 1
    assert cli(["open", "en09"]) == 2
    assert "no result named 'en09'" in capsys.readouterr().err


def test_ls_on_an_empty_directory_says_how_to_build(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli(["ls"]) == 0
    assert "nothing built under data yet" in capsys.readouterr().out


def test_a_sweep_writes_its_record(tmp_path):
    """The aggregate of a sweep writes overrides.json beside sweep.nc."""
    from creatio.pipeline.sweep import plan_sweep, write_sweep

    plan = plan_sweep("ct02", ["geometry.A=0.1,0.18"], ["study.inclinations_deg=[0,90]"],
                      data_dir=str(tmp_path / "data"))
    paths = write_sweep(plan, compute_missing=True)
    record = json.loads(paths["record"].read_text())
    assert record == {"kind": "sweep", "name": Path(plan.outdir).name, "study": "ct02",
                      "sweep": ["geometry.A=0.1,0.18"],
                      "overrides": ["study.inclinations_deg=[0,90]"], "points": 2,
                      "points_run": 2}
    assert (tmp_path / "data" / "index.html").is_file()  # outside Snakemake: listed too


def test_the_attributes_read_of_results_are_kept_until_a_file_changes(data, monkeypatch):
    """A second scan lists the same results without opening a NetCDF file (their attributes
    kept in data/.index-attrs.json by file identity); a result written again, or a damaged
    cache, is read anew."""
    from creatio.pipeline import index

    opened: list[str] = []
    read = index._nc_all_attrs

    def counting(path):
        opened.append(Path(path).name)
        return read(path)

    monkeypatch.setattr(index, "_nc_all_attrs", counting)
    first = scan(data)
    assert opened and (data / index.ATTR_CACHE).is_file()
    opened.clear()
    assert scan(data) == first and opened == []
    scene = data / "scenes" / "compare" / "scene.nc"
    write_dataset(xr.Dataset({"status": ("run", ["ok", "contact_lost"])}), scene)
    entries = {e.name: e for e in scan(data)}
    assert opened == ["scene.nc"] and entries["scenes/compare"].status == "contact_lost"
    (data / index.ATTR_CACHE).write_text("{not json")
    opened.clear()
    assert {e.name: e for e in scan(data)} == entries and len(opened) >= 2


def _calibration(data: Path, name: str) -> Path:
    """A calibration folder as `creatio calibrate` leaves it (dataset, JSON report, markdown,
    figure)."""
    folder = data / "calibration" / name
    ds = _dataset("ok")
    ds.attrs.update(study="en02", track_file="tracks/lab.csv")
    write_dataset(ds, folder / "calibration.nc")
    (folder / "calibration.json").write_text(json.dumps(
        {"study": "en02", "track": "tracks/lab.csv", "status": "ok",
         "estimate": {"sphere.mu": 0.21, "sphere.eps": 0.01}}))
    (folder / "calibration.md").write_text("# Calibration of en02 to lab.csv\n")
    (folder / "calibration.png").write_bytes(b"png")
    return folder


def test_calibrations_are_listed_and_opened(data, capsys, monkeypatch):
    """Issue 34.6: a calibration is a result: in `creatio ls`, on the index page, found by
    `creatio open`; what made it from its record when there is one, else its report."""
    _calibration(data, "lab-0123456789ab")
    example = _calibration(data, "en02_example")
    record = record_calibration(example, "en02r", "examples/tracks/en02_synthetic.csv",
                                ["sphere.mu"], ["phases.T=10.0"], "ab" * 32)
    assert json.loads(record.read_text()) == {
        "kind": "calibration", "name": "en02_example", "study": "en02r",
        "track": "examples/tracks/en02_synthetic.csv", "fit": ["sphere.mu"],
        "overrides": ["phases.T=10.0"], "config_sha256": "ab" * 32}
    entries = {e.name: e for e in scan(data)}
    lab = entries["calibration/lab-0123456789ab"]
    assert (lab.kind, lab.study, lab.status) == ("calibration", "en02", "ok")
    assert lab.overrides == ["track=lab.csv", "fit=[sphere.mu,sphere.eps]"]
    assert lab.main == "calibration/lab-0123456789ab/calibration.md"
    assert set(lab.links) == {"report", "figure", "summary", "dataset"}
    example = entries["calibration/en02_example"]
    assert example.study == "en02r"  # the record wins over the report
    assert example.overrides == ["track=en02_synthetic.csv", "fit=[sphere.mu]",
                                 "phases.T=10.0"]
    monkeypatch.chdir(data.parent)
    assert cli(["ls"]) == 0
    out = capsys.readouterr().out
    assert "calibration/lab-0123456789ab" in out and "8 result(s)" in out
    row = next(line for line in out.splitlines() if "lab-0123456789ab" in line)
    assert row.split()[0] == "calibration"
    assert cli(["open", "lab-0123"]) == 0
    assert capsys.readouterr().out.strip() == str(
        (data / "calibration" / "lab-0123456789ab" / "calibration.md").resolve())
    page = write_index(data).read_text()
    assert "Calibrations (data/calibration/)" in page
    assert "href='calibration/en02_example/calibration.png'" in page


def test_the_index_says_what_is_not_built_and_how(data):
    """Issue 34.7: the page names the targets with no result yet and the command for each;
    a target once built leaves the list."""
    from creatio.pipeline.index import unbuilt
    from creatio.studies import registry

    todo = {t: (what, command) for t, what, command in unbuilt(scan(data), data)}
    beyond = [s.id for s in registry.beyond()]
    assert todo["beyond"] == (f"the studies beyond the notebook: {', '.join(beyond)}",
                              "snakemake beyond -c 2")
    assert todo["en05"][1] == "snakemake en05 -c 2"
    assert todo["calibrate_example"][1] == "snakemake calibrate_example -c 1"
    analyses = [s.id for s in registry.select(kind="analysis")]
    assert todo["benchmarks"][0].endswith(", ".join(a for a in analyses
                                                    if a != "stability_map"))
    assert "compare" not in todo["scenes"][0] and "en02r" in todo["scenes"][0]
    missing = {s.id for s in registry.select(in_all=True)} - {"en02"}
    assert set(todo["all"][0].split(": ")[1].split(", ")) == missing
    assert "sweep_en02_mu" not in todo  # a sweep is built
    page = write_index(data).read_text()
    assert "<h2>Not built yet</h2>" in page
    for target, (_, command) in todo.items():
        assert f"<td class=name>{target}</td>" in page and f"<code>{command}</code>" in page
    _calibration(data, "en02_example")
    assert "calibrate_example" not in {t for t, _, _ in unbuilt(scan(data), data)}
