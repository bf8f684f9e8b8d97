"""Files read and written as data (issue 38): no read blocks on a FIFO, and an output path
that cannot hold a file is named for what it is. Every command runs in a subprocess with a
timeout, so that a hang fails the test instead of blocking the suite."""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from creatio.store.atomic import Unwritable, atomic_save, atomic_write, check_destination
from creatio.store.netcdf import read_dataset, write_dataset
from creatio.store.regular import (
    NotRegularFile,
    check_regular,
    open_regular,
    read_bytes,
    read_json,
    read_text,
)

REPO = Path(__file__).resolve().parents[2]
#: Seconds a command gets: each here takes about one; a blocked read never returns.
TIMEOUT = 60


def creatio(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """`creatio ARGS` in its own process (no warm worker), killed after TIMEOUT seconds."""
    return subprocess.run([sys.executable, "-m", "creatio.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=TIMEOUT,
                          env={**os.environ, "CREATIO_DEBUG": "", "CREATIO_WORKER": "off"})


def one_line(proc: subprocess.CompletedProcess, code: int, *words: str) -> str:
    """The process exited with code and one line of stderr holding every word; the line."""
    assert proc.returncode == code, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr[-2000:]
    assert all(w in lines[0] for w in words), lines[0]
    return lines[0]


def _copy_release(tmp_path: Path, version: str = "0.1.0") -> Path:
    """A writable copy of a committed release in tmp_path/data/releases (data/ untouched)."""
    release = tmp_path / "data" / "releases" / version
    shutil.copytree(REPO / "data" / "releases" / version, release)
    for path in release.rglob("*"):
        path.chmod(0o644 if path.is_file() else 0o755)
    return release


# ------------------------------------------------------------------- the helper itself
def test_a_fifo_or_a_device_is_refused_at_once_and_a_regular_file_read(tmp_path):
    """open_regular opens without blocking and checks the descriptor: a FIFO (no writer:
    open() would wait for ever), a device and a directory are refused by name and kind."""
    fifo = tmp_path / "overrides.json"
    os.mkfifo(fifo)
    for path, kind in ((fifo, "named pipe"), (Path("/dev/zero"), "character device"),
                       (tmp_path, "directory")):
        for read in (read_text, read_bytes, read_json, check_regular):
            with pytest.raises(NotRegularFile) as info:
                read(path)
            assert kind in str(info.value) and info.value.filename == str(path)
            assert str(info.value).count("\n") == 0
    link = tmp_path / "link.json"
    link.symlink_to(fifo)  # a symlink is followed, and what it names is checked
    with pytest.raises(NotRegularFile, match="named pipe"):
        read_json(link)
    with pytest.raises(FileNotFoundError):
        read_text(tmp_path / "absent.json")
    good = tmp_path / "good.json"
    good.write_text('{"a": [1, 2.5]}')
    assert read_json(good) == {"a": [1, 2.5]} and read_bytes(good) == b'{"a": [1, 2.5]}'
    with open_regular(good, "r", encoding="utf-8") as fh:  # blocking again once checked
        assert fh.read(4) == '{"a"' and os.get_blocking(fh.fileno())
    with pytest.raises(ValueError, match="reads only"):
        open_regular(good, "w")


def test_read_dataset_refuses_a_fifo_in_place_of_a_dataset(tmp_path):
    fifo = tmp_path / "en02.nc"
    os.mkfifo(fifo)
    with pytest.raises(NotRegularFile, match="named pipe"):
        read_dataset(fifo)
    with pytest.raises(FileNotFoundError, match="no dataset here"):
        read_dataset(tmp_path / "absent.nc")


# ------------------------------------------------------------------ 38.9: no read blocks
def test_creatio_ls_skips_a_fifo_record_with_one_note(tmp_path):
    """The issue's example: a FIFO at data/runs/<x>/overrides.json hung `creatio ls` (no
    output at 100 s). It lists everything else and says in one line what it skipped."""
    data = tmp_path / "data"
    t = np.arange(3.0)
    write_dataset(xr.Dataset({"x": ("time", t)}, coords={"time": t}, attrs={"status": "ok"}),
                  data / "runs" / "0123456789ab" / "studies" / "en02" / "en02_dt0.002.nc")
    fifo = data / "runs" / "0123456789ab" / "overrides.json"
    os.mkfifo(fifo)
    proc = creatio("ls", cwd=tmp_path)
    line = one_line(proc, 0, "note", "runs/0123456789ab/overrides.json", "named pipe",
                    "skipped")
    assert line.startswith("creatio ls: ")
    assert "runs/0123456789ab/en02" in proc.stdout and "1 result(s)" in proc.stdout
    os.mkfifo(data / "runs" / "0123456789ab" / "studies" / "en02" / "en02_dt0.001.nc")
    proc = creatio("open", "en02", cwd=tmp_path)  # a FIFO dataset beside it: skipped too
    assert proc.returncode == 0 and proc.stdout.strip().endswith("en02_dt0.002.nc")
    assert "en02_dt0.001.nc: not a regular file: skipped" in proc.stderr


@pytest.mark.parametrize("spec", ["0.1.0", "latest", "data/releases/0.1.0"])
def test_a_fifo_manifest_is_refused_by_verify_and_diff_in_one_line(tmp_path, spec):
    """A FIFO as a release's MANIFEST.json hung `creatio release verify` and `creatio diff`;
    by version, as latest or as a directory, both refuse it in one line, exit 2 (and the
    newest release is not passed over for an older one)."""
    release = _copy_release(tmp_path)
    (release / "MANIFEST.json").unlink()
    os.mkfifo(release / "MANIFEST.json")
    for args in (["release", "verify", spec], ["diff", spec, "data"]):
        one_line(creatio(*args, cwd=tmp_path), 2, "MANIFEST.json", "not a regular file")


def test_diff_refuses_a_fifo_named_as_a_side(tmp_path):
    (tmp_path / "data").mkdir()
    os.mkfifo(tmp_path / "a.nc")
    one_line(creatio("diff", "a.nc", "data", cwd=tmp_path), 2, "a.nc", "not a regular file")


# ------------------------------------------------------------------- 38.13a: /proc writes
@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs a /proc filesystem")
def test_a_write_to_proc_names_the_filesystem_not_a_full_disk(tmp_path):
    """Writing /proc/x.nc said "No space left on device"; every writer now says that /proc
    holds no files, in one line, and writes nothing."""
    ds = xr.Dataset({"x": ("n", np.arange(3.0))})
    for write in (lambda p: write_dataset(ds, p), check_destination,
                  lambda p: atomic_save(p, lambda tmp: tmp.write_bytes(b"x")),
                  lambda p: atomic_write(p).__enter__()):
        for target in (Path("/proc/x.nc"), Path("/proc/sub/x.nc")):
            with pytest.raises(Unwritable) as info:
                write(target)
            message = str(info.value)
            assert message.startswith(f"cannot write {target}: /proc is on a virtual "
                                      "filesystem") and "\n" not in message
            assert "space" not in message and info.value.errno == errno.ENOENT
            assert isinstance(info.value, OSError) and not target.exists()


def test_a_file_where_a_directory_should_be_is_named(tmp_path):
    blocker = tmp_path / "report.md"
    blocker.write_text("# a file\n")
    with pytest.raises(Unwritable, match=f"{blocker} is a file, not a directory"):
        write_dataset(xr.Dataset({"x": ("n", [1.0])}), blocker / "sub" / "x.nc")
    with pytest.raises(Unwritable, match="it is a directory"):
        check_destination(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.md"]
    assert check_destination(tmp_path / "new" / "x.nc") == tmp_path / "new" / "x.nc"
    assert list((tmp_path / "new").iterdir()) == []  # the probe is gone


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs a /proc filesystem")
def test_commands_writing_to_proc_exit_2_in_one_line(tmp_path):
    """`creatio diff --text-out /proc/x.txt` and `creatio task dataset ct02 /proc/x.nc`: one
    line naming the path and the cause, exit 2."""
    _copy_release(tmp_path)
    one_line(creatio("diff", "0.1.0", "0.1.0", "--text-out", "/proc/x.txt", cwd=tmp_path), 2,
             "cannot write /proc/x.txt", "virtual filesystem")
    one_line(creatio("task", "dataset", "ct02", "/proc/x.nc", cwd=tmp_path), 2,
             "cannot write /proc/x.nc", "virtual filesystem")


def test_a_release_json_report_must_be_a_json_object(tmp_path):
    """A whole-manifest check beyond datasets: a report rewritten to non-JSON, its entry
    rewritten to match, is a problem of verify."""
    import hashlib

    from creatio.pipeline.release import verify_release

    release = _copy_release(tmp_path)
    manifest = json.loads((release / "MANIFEST.json").read_text())
    entry = next(f for f in manifest["files"] if f["path"].endswith(".json"))
    body = b"not json"
    (release / entry["path"]).write_bytes(body)
    entry.update(size=len(body), sha256=hashlib.sha256(body).hexdigest())
    manifest["total_size"] = sum(f["size"] for f in manifest["files"])
    (release / "MANIFEST.json").write_text(json.dumps(manifest))
    assert verify_release(release) == [f"{entry['path']}: not a readable JSON report (a "
                                       "JSON object)"]


# --------------------------------------------- 38.9: config files, batches, cache entries
def test_a_fifo_config_file_is_refused_at_once_by_every_task(tmp_path):
    """--config-file naming a FIFO (no writer: a plain read waits for ever) is one line
    naming the path and what it is, for the dataset, scene and EN-05 steps; nothing
    written."""
    fifo = tmp_path / "config.yaml"
    os.mkfifo(fifo)
    for args in (["task", "dataset", "ct02", "out.nc", "--config-file", str(fifo)],
                 ["task", "scene", "dataset", "en02", "out.nc", "--config-file", str(fifo)],
                 ["task", "en05", "track", "--config-file", str(fifo)]):
        one_line(creatio(*args, cwd=tmp_path), 1, str(fifo), "named pipe (FIFO)",
                 "not a regular file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["config.yaml"]


def test_a_fifo_summary_is_refused_by_the_comparison(tmp_path):
    """`creatio task compare`: a FIFO planted at a study's summary JSON in the output
    directory is one line naming it."""
    datasets = [REPO / "data" / "studies" / s / f"{s}_dt0.002.nc" for s in ("en02", "en02r")]
    if not all(p.is_file() for p in datasets):
        pytest.skip("needs the EN-02 and EN-02R datasets (snakemake all)")
    os.mkfifo(tmp_path / "en02.json")
    one_line(creatio("task", "compare", str(tmp_path), *map(str, datasets), cwd=tmp_path), 1,
             str(tmp_path / "en02.json"), "named pipe (FIFO)")


SWEEP_READS = """
import os, sys
from pathlib import Path
from creatio.pipeline.sweep import _batch_code, _known_points, aggregate, plan_sweep
from creatio.store.regular import NotRegularFile

plan = plan_sweep("en02", ["sphere.mu=0,0.1"])
other = Path(plan.outdir).parent / "other" / "batches"
other.mkdir(parents=True)
os.mkfifo(other / "b1-00000.nc")
print(_batch_code(other / "b1-00000.nc"), _known_points(plan, "code"))
Path(plan.batches[0]).parent.mkdir(parents=True)
os.mkfifo(plan.batches[0])
print(plan.batches[0])
try:
    aggregate(plan)
except NotRegularFile as e:
    print(e)
"""


def test_a_fifo_batch_is_no_source_and_is_refused_by_the_aggregate(tmp_path):
    """A FIFO among a sweep's batches: not current (no code version), never a source of
    known points, and refused by name when the sweep is aggregated, all at once."""
    proc = subprocess.run([sys.executable, "-c", SWEEP_READS], capture_output=True, text=True,
                          cwd=tmp_path, timeout=TIMEOUT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    known, batch, refusal = proc.stdout.strip().splitlines()
    assert known == "None {}"
    assert refusal == (f"{batch}: is a named pipe (FIFO), not a regular file (creatio reads "
                       "data only from regular files)"), refusal


RESOLVE = """
import sys
from creatio.pipeline.config import resolve
print(resolve("ct02", ["study.n_radii=41"]).sha256)
"""


def test_a_fifo_config_cache_entry_is_removed_and_the_config_composed(tmp_path):
    """A FIFO planted at a resolved config's cache entry (JSON) is not read: the entry is
    dropped and the config composed anew, giving the same config."""
    env = {**os.environ, "CREATIO_CONFIG_CACHE": str(tmp_path / "cache")}

    def run() -> str:
        proc = subprocess.run([sys.executable, "-c", RESOLVE], capture_output=True, text=True,
                              cwd=tmp_path, env=env, timeout=TIMEOUT)
        assert proc.returncode == 0, proc.stderr[-2000:]
        return proc.stdout.strip()

    first = run()
    (entry,) = (tmp_path / "cache").glob("*.json")
    entry.unlink()
    os.mkfifo(entry)
    assert run() == first
    assert entry.is_file()  # the FIFO removed, the entry stored anew
