"""`creatio release`: manifest, refusals, verification, and diffs against a release."""

from __future__ import annotations

import hashlib
import json
import stat
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

from creatio.diff import diff
from creatio.diff import main as diff_main
from creatio.pipeline import release
from creatio.pipeline.provenance import provenance
from creatio.pipeline.release import (
    Layout,
    ReleaseError,
    StudyFiles,
    find_release,
    list_releases,
    make_release,
    parse_version,
    verify_release,
)
from creatio.store.netcdf import write_dataset
from creatio.studies import registry


def config_for(study: str) -> tuple[str, str]:
    text = yaml.safe_dump({"study": {"id": study}, "geometry": {"A": 0.18}}, sort_keys=True)
    return text, hashlib.sha256(text.encode()).hexdigest()


def dataset(study: str, dt: float | None = None) -> xr.Dataset:
    """A small study-like dataset with provenance (dt recorded for dynamic ones)."""
    text, sha = config_for(study)
    t = np.arange(6) * 0.1
    attrs = provenance(study, text, sha, f"{study} synthetic")
    if dt is not None:
        attrs["dt"] = dt
    return xr.Dataset({"energy": ("time", np.cos(t) * (1 + (dt or 0)), {"units": "J"})},
                      coords={"time": t}, attrs=attrs)


@pytest.fixture
def data_dir(tmp_path) -> Path:
    """A data directory as `snakemake all` leaves it, for one kinematic and one dynamic study."""
    root = tmp_path / "data"
    write_dataset(dataset("ct02"), root / "studies" / "ct02" / "ct02.nc")
    for dt in (0.002, 0.001):
        write_dataset(dataset("en02", dt), root / "studies" / "en02" / f"en02_dt{dt:g}.nc")
    reports = root / "reports"
    reports.mkdir()
    for study in ("ct02", "en02"):
        sha = config_for(study)[1]
        (reports / f"{study}.json").write_text(json.dumps(
            {"study": study, "figure": 1.5, "config_sha256": sha}))
        (reports / f"{study}.md").write_text(f"# {study}\n")
        (reports / f"{study}.png").write_bytes(b"\x89PNG figure")
    (reports / "compare_en02_ct02.md").write_text("# compare\n")
    return root


@pytest.fixture
def layout() -> Layout:
    """The files of the data_dir fixture, as default_layout() describes the real studies."""
    return Layout(
        (StudyFiles("ct02", config_for("ct02")[1], ("studies/ct02/ct02.nc",),
                    ("reports/ct02.json", "reports/ct02.md", "reports/ct02.png")),
         StudyFiles("en02", config_for("en02")[1],
                    ("studies/en02/en02_dt0.002.nc", "studies/en02/en02_dt0.001.nc"),
                    ("reports/en02.json", "reports/en02.md", "reports/en02.png"))),
        ("reports/compare_en02_ct02.md",),
    )


def test_release_copies_defaults_and_writes_a_manifest(data_dir, layout):
    """Datasets at the configured dt, JSON and markdown reports; the rest fingerprinted."""
    dest, manifest, _ = make_release("0.2.0", data_dir, layout=layout)
    assert dest == data_dir / "releases" / "0.2.0"
    paths = {f["path"] for f in manifest["files"]}
    assert paths == {"studies/ct02/ct02.nc", "studies/en02/en02_dt0.002.nc",
                     "reports/ct02.json", "reports/ct02.md", "reports/en02.json",
                     "reports/en02.md", "reports/compare_en02_ct02.md"}
    omitted = {o["path"]: o for o in manifest["omitted"]}
    assert set(omitted) == {"studies/en02/en02_dt0.001.nc", "reports/ct02.png",
                            "reports/en02.png"}
    assert "partner" in omitted["studies/en02/en02_dt0.001.nc"]["reason"]
    saved = json.loads((dest / "MANIFEST.json").read_text())
    assert saved == manifest and saved["version"] == "0.2.0" and saved["created"]
    for f in manifest["files"]:
        body = (dest / f["path"]).read_bytes()
        assert hashlib.sha256(body).hexdigest() == f["sha256"] and len(body) == f["size"]
        assert body == (data_dir / f["path"]).read_bytes()
        assert stat.S_IMODE((dest / f["path"]).stat().st_mode) == 0o444
    ds = next(f for f in manifest["files"] if f["path"] == "studies/ct02/ct02.nc")
    assert ds["study"] == "ct02" and ds["config_sha256"] == config_for("ct02")[1]
    assert ds["creatio_version"] and ds["git_commit"] and "numpy" in ds["libraries"]
    assert manifest["total_size"] == sum(f["size"] for f in manifest["files"])
    assert manifest["studies"]["en02"]["datasets"] == ["studies/en02/en02_dt0.002.nc"]
    with_partners = make_release("0.2.1", data_dir, layout=layout, with_partners=True)[1]
    assert "studies/en02/en02_dt0.001.nc" in {f["path"] for f in with_partners["files"]}


def test_an_existing_release_is_never_overwritten(data_dir, layout, capsys):
    """Second release of a version: exit 2, a clear message, the first one untouched."""
    dest, manifest, _ = make_release("0.2.0", data_dir, layout=layout)
    before = (dest / "MANIFEST.json").read_bytes()
    assert release.main(["0.2.0", "--data-dir", str(data_dir)]) == 2
    err = capsys.readouterr().err
    assert "release 0.2.0 already exists" in err and "never overwritten" in err
    assert (dest / "MANIFEST.json").read_bytes() == before


@pytest.mark.parametrize("bad", ["0.2", "v0.2.0", "0.2.0-beta", "01.2.3", "latest", "../x"])
def test_invalid_versions_are_refused(data_dir, bad, capsys):
    """Only MAJOR.MINOR.PATCH[a|b|rcN]: exit 2 before anything is read or written."""
    assert release.main([bad, "--data-dir", str(data_dir)]) == 2
    assert "invalid release version" in capsys.readouterr().err
    assert not (data_dir / "releases").exists()


def test_versions_sort_as_versions(tmp_path):
    """0.10.0 is newer than 0.9.0, a final release newer than its candidates; latest follows."""
    assert parse_version("0.10.0") > parse_version("0.9.0")
    assert parse_version("1.0.0") > parse_version("1.0.0rc2") > parse_version("1.0.0b1")
    for v in ("0.9.0", "0.10.0", "0.10.0rc1"):
        (tmp_path / "releases" / v).mkdir(parents=True)
        (tmp_path / "releases" / v / "MANIFEST.json").write_text("{}")
    (tmp_path / "releases" / "notes").mkdir()
    assert [p.name for p in list_releases(tmp_path)] == ["0.9.0", "0.10.0rc1", "0.10.0"]
    assert find_release("latest", tmp_path).name == "0.10.0"
    with pytest.raises(ReleaseError, match=r"no release 1\.0\.0 .*available: 0\.9\.0"):
        find_release("1.0.0", tmp_path)


def test_missing_default_dataset_is_named(data_dir, layout):
    """A study's default dataset missing: refused, naming it and `snakemake all`."""
    (data_dir / "studies" / "en02" / "en02_dt0.002.nc").unlink()
    with pytest.raises(ReleaseError, match=r"(?s)en02_dt0\.002\.nc.*snakemake all"):
        make_release("0.2.0", data_dir, layout=layout)
    assert not (data_dir / "releases" / "0.2.0").exists()


def test_missing_data_through_the_cli_uses_the_real_layout(tmp_path, capsys):
    """`creatio release` on an empty data dir names the real default datasets (exit 2)."""
    assert release.main(["0.2.0", "--data-dir", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "studies/ct02/ct02.nc" in err and "snakemake all" in err
    layout = release.default_layout()
    assert {s.study for s in layout.studies} == {s.id for s in registry.select(in_all=True)}
    assert {"ct02", "en01", "en02", "en02r"} <= {s.study for s in layout.studies}
    en02 = next(s for s in layout.studies if s.study == "en02")
    assert len(en02.datasets) == 2 and en02.datasets[0].endswith("_dt0.002.nc")


def test_stale_datasets_are_refused(data_dir, layout):
    """A dataset made from another config than the default one is out of date: refused."""
    stale = Layout((replace(layout.studies[0], config_sha256="0" * 64), *layout.studies[1:]),
                   layout.shared)
    with pytest.raises(ReleaseError, match=r"(?s)out of date.*ct02\.nc.*snakemake all"):
        make_release("0.2.0", data_dir, layout=stale)


def test_verify_detects_a_corrupted_file(data_dir, layout, capsys):
    """verify: 0 when intact, 1 naming a changed, missing or unexpected file, 2 if absent."""
    dest, _, _ = make_release("0.2.0", data_dir, layout=layout)
    assert verify_release(dest) == []
    assert release.main(["verify", "0.2.0", "--data-dir", str(data_dir)]) == 0
    target = dest / "studies" / "ct02" / "ct02.nc"
    target.chmod(0o644)
    body = bytearray(target.read_bytes())
    body[len(body) // 2] ^= 0x01
    target.write_bytes(bytes(body))
    assert release.main(["verify", "latest", "--data-dir", str(data_dir)]) == 1
    err = capsys.readouterr().err
    assert "studies/ct02/ct02.nc: sha256" in err
    (dest / "reports" / "extra.json").write_text("{}")
    (dest / "reports" / "en02.md").chmod(0o644)
    (dest / "reports" / "en02.md").unlink()
    problems = verify_release(dest)
    assert any("extra.json: not in the manifest" in p for p in problems)
    assert any("en02.md: missing" in p for p in problems)
    assert release.main(["verify", "9.9.9", "--data-dir", str(data_dir)]) == 2
    assert "no release 9.9.9" in capsys.readouterr().err


def test_list_shows_the_releases(data_dir, layout, capsys):
    """`creatio release list`: one line per release, oldest first."""
    make_release("0.2.0", data_dir, layout=layout)
    make_release("0.10.0", data_dir, layout=layout)
    assert release.main(["list", "--data-dir", str(data_dir)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == ["0.2.0", "0.10.0"]


def test_diff_release_against_data_leaves_out_the_omitted_partner(data_dir, layout,
                                                                  monkeypatch, capsys):
    """`creatio diff latest data`: same data, partner not 'added'; a changed figure is caught."""
    make_release("0.1.0", data_dir, layout=layout)
    monkeypatch.chdir(data_dir.parent)
    result = diff("latest", "data")
    assert result["files"]["omitted"] == ["studies/en02/en02_dt0.001.nc"]
    assert result["files"]["added"] == [] and result["exit_code"] == 0
    assert len(result["files"]["identical"]) == 4
    report = data_dir / "reports" / "en02.json"
    figures = json.loads(report.read_text())
    report.write_text(json.dumps({**figures, "figure": 1.5 * (1 + 1e-6)}))
    ds = dataset("ct02")
    ds["energy"].values[-1] *= 1 + 1e-15
    ds.attrs["git_commit"] = "0" * 40
    write_dataset(ds, data_dir / "studies" / "ct02" / "ct02.nc")
    assert diff_main(["0.1.0", "data", "--rtol", "1e-9", "--atol", "1e-12"]) == 1
    out = capsys.readouterr().out
    assert "reports/en02.json: 1 figure(s) beyond tolerance" in out
    assert "studies/ct02/ct02.nc" not in out.split("provenance")[0]
    assert diff_main(["0.1.0", "data", "--rtol", "1e-5"]) == 0
    capsys.readouterr()
    assert diff_main(["0.1.0", "0.1.0"]) == 0


def test_diff_refuses_a_release_file_that_no_longer_matches(data_dir, layout):
    """A release file edited after the fact is not compared (it was a warning, exit 0 or a
    difference): the release is refused as damaged, naming the file."""
    from creatio.diff.core import DamagedRelease

    dest, _, _ = make_release("0.1.0", data_dir, layout=layout)
    target = dest / "reports" / "ct02.json"
    target.chmod(0o644)
    target.write_text(json.dumps({"study": "ct02", "figure": 2.0}))
    with pytest.raises(DamagedRelease, match=r"reports/ct02\.json: sha256 .* != manifest"):
        diff(str(dest), str(data_dir))


def _rewrite(dest: Path, edit) -> dict:
    """Apply edit(manifest) to a release's MANIFEST.json (made writable) and return it."""
    path = dest / "MANIFEST.json"
    path.chmod(0o644)
    manifest = json.loads(path.read_text())
    edit(manifest)
    path.write_text(json.dumps(manifest, indent=2))
    return manifest


def _replace_file(dest: Path, rel: str, body: bytes, manifest: dict) -> None:
    """Put body at rel and rewrite its entry (size, sha256, total) to match, as a forger
    would: the digests alone then pass."""
    target = dest / rel
    target.chmod(0o644)
    target.write_bytes(body)
    entry = next(f for f in manifest["files"] if f["path"] == rel)
    entry.update(size=len(body), sha256=hashlib.sha256(body).hexdigest())
    manifest["total_size"] = sum(f["size"] for f in manifest["files"])
    (dest / "MANIFEST.json").write_text(json.dumps(manifest, indent=2))


def test_a_duplicated_manifest_entry_is_refused(data_dir, layout, capsys):
    """Issue 38.10: an entry listed twice passed verify; the manifest is damaged (exit 2)."""
    dest, _, _ = make_release("0.2.0", data_dir, layout=layout)
    _rewrite(dest, lambda m: m["files"].append(dict(m["files"][0])))
    assert release.main(["verify", "0.2.0", "--data-dir", str(data_dir)]) == 2
    err = capsys.readouterr().err
    assert "'studies/ct02/ct02.nc' is listed twice" in err and len(err.splitlines()) == 1
    _rewrite(dest, lambda m: (m["files"].pop(), m["omitted"].append(
        {"path": m["files"][1]["path"]})))  # kept and omitted at once: twice too
    with pytest.raises(ReleaseError, match="listed twice"):
        verify_release(dest)


@pytest.mark.parametrize(("body", "problem"), [
    (b"", "empty (a release never holds an empty file)"),
    (b"CDF\x01 not really", "not a readable NetCDF dataset"),
])
def test_a_dataset_that_is_not_netcdf_is_refused_whatever_the_manifest_says(
        data_dir, layout, body, problem, capsys):
    """Issue 38.10: a 0-byte dataset whose entry was rewritten to size 0 and the matching
    sha256 passed verify; a dataset must be a readable NetCDF file (exit 1, one line)."""
    dest, manifest, _ = make_release("0.2.0", data_dir, layout=layout)
    assert verify_release(dest) == []
    (dest / "MANIFEST.json").chmod(0o644)
    _replace_file(dest, "studies/ct02/ct02.nc", body, manifest)
    problems = verify_release(dest)
    assert len(problems) == 1 and problems[0].startswith(f"studies/ct02/ct02.nc: {problem}")
    assert release.main(["verify", "0.2.0", "--data-dir", str(data_dir)]) == 1
    err = capsys.readouterr().err
    assert problem in err and len(err.splitlines()) == 1
    from creatio.diff.core import DamagedRelease

    with pytest.raises(DamagedRelease, match=problem.split(" (")[0]):
        diff(str(dest), str(data_dir))


def test_a_dataset_of_another_study_is_refused(data_dir, layout):
    """A dataset swapped for another study's, its entry rewritten to the new digest: the
    file's own study and config hash are not the entry's."""
    dest, manifest, _ = make_release("0.2.0", data_dir, layout=layout)
    (dest / "MANIFEST.json").chmod(0o644)
    other = (dest / "studies" / "en02" / "en02_dt0.002.nc").read_bytes()
    _replace_file(dest, "studies/ct02/ct02.nc", other, manifest)
    assert verify_release(dest) == ["studies/ct02/ct02.nc: a dataset of study 'en02', "
                                    "listed as 'ct02'",
                                    "studies/ct02/ct02.nc: a dataset of config_sha256 "
                                    f"{config_for('en02')[1][:12]!r}, listed as "
                                    f"{config_for('ct02')[1][:12]!r}"]


def test_a_size_or_total_that_is_not_the_files_is_refused(data_dir, layout):
    """A listed size other than the file's, and a total other than the sum, are problems
    even where the sha256 matches."""
    dest, _, _ = make_release("0.2.0", data_dir, layout=layout)
    real = (dest / "reports" / "ct02.md").stat().st_size
    total = sum(p.stat().st_size for p in dest.rglob("*")
                if p.is_file() and p.name != "MANIFEST.json")  # measured, not read back

    def resize(m: dict) -> None:
        next(f for f in m["files"] if f["path"] == "reports/ct02.md")["size"] = real + 1
    _rewrite(dest, resize)
    assert verify_release(dest) == [f"reports/ct02.md: size {real} != manifest {real + 1}"]
    _rewrite(dest, lambda m: m.update(total_size=total + 7))
    assert verify_release(dest)[1:] == [f"MANIFEST.json: total_size {total + 7} != {total}, "
                                        "the sum of the listed sizes"]
