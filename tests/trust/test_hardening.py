"""Failure paths a user meets: killed or failing writers, unreadable files, damaged release
manifests, and the one-line messages (never a traceback) of the command line."""

from __future__ import annotations

import ast
import errno
import json
import math
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr
from inproc import run_cli

from creatio.errors import ConfigError
from creatio.pipeline.release import (
    FORMAT,
    Layout,
    ReleaseError,
    StudyFiles,
    make_release,
    read_manifest,
)
from creatio.pipeline.sweep import parse_axes
from creatio.store import netcdf
from creatio.store.atomic import atomic_save, atomic_write, clean_stale
from creatio.store.netcdf import read_dataset


def _dead_pid() -> int:
    """The pid of a process that has finished (a killed writer's)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_failing_writer_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "report.json"
    target.write_text('{"old": 1}')
    with pytest.raises(ValueError), atomic_write(target) as fh:
        fh.write('{"new": ')
        raise ValueError("the writer failed half way")
    assert target.read_text() == '{"old": 1}'
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]
    with atomic_write(target) as fh:
        json.dump({"new": 2}, fh)
    assert json.loads(target.read_text()) == {"new": 2}


def test_a_save_that_writes_nothing_is_refused(tmp_path):
    """atomic_save refuses an empty result (a figure that was never drawn) and keeps none."""
    with pytest.raises(OSError, match="nothing was written"):
        atomic_save(tmp_path / "fig.png", lambda p: Path(p).write_bytes(b""))
    assert list(tmp_path.iterdir()) == []
    atomic_save(tmp_path / "fig.png", lambda p: Path(p).write_bytes(b"\x89PNG"))
    assert (tmp_path / "fig.png").read_bytes() == b"\x89PNG"


def test_temporaries_of_killed_writers_are_cleaned_live_ones_kept(tmp_path):
    target = tmp_path / "en02.nc"
    dead = tmp_path / f".en02.nc.tmp-{_dead_pid()}"
    live = tmp_path / f".en02.nc.tmp-{os.getppid()}"  # a running process (pytest's parent)
    other = tmp_path / f".ct02.nc.tmp-{_dead_pid()}"  # another file's: not ours to clean
    for p in (dead, live, other):
        p.write_bytes(b"partial")
    clean_stale(target)
    assert not dead.exists() and live.exists() and other.exists()


def test_a_truncated_dataset_is_named_with_what_to_do(tmp_path):
    path = tmp_path / "en02.nc"
    netcdf.write_dataset(xr.Dataset({"x": ("n", np.arange(1000.0))}), path)
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(OSError, match="not a readable creatio dataset") as info:
        read_dataset(path)
    assert info.value.filename == str(path) and "rerun" in str(info.value)


def test_a_full_disk_is_named_as_such(tmp_path, monkeypatch):
    """netCDF4 reports ENOSPC as 'NetCDF: HDF error'; the write names the full disk and keeps
    no partial file."""
    def full(self, *args, **kwargs):
        Path(args[0]).write_bytes(b"half")
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full)
    monkeypatch.setattr(netcdf.shutil, "disk_usage", lambda p: SimpleNamespace(free=0))
    with pytest.raises(OSError) as info:
        netcdf.write_dataset(xr.Dataset({"x": ("n", np.arange(3.0))}), tmp_path / "a.nc")
    assert info.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []


def test_a_range_with_zero_step_is_refused():
    with pytest.raises(ConfigError, match="cannot be expanded"):
        parse_axes(["sphere.mu=range(0,1,0)"])


def test_a_damaged_manifest_is_refused(tmp_path):
    release = tmp_path / "releases" / "0.2.0"
    release.mkdir(parents=True)
    manifest = {"format": FORMAT, "version": "0.2.0",
                "files": [{"path": "studies/ct02/ct02.nc", "sha256": None}]}
    (release / "MANIFEST.json").write_text(json.dumps(manifest))
    with pytest.raises(ReleaseError, match="damaged manifest"):
        read_manifest(release)
    manifest["files"][0]["sha256"] = "0" * 64
    manifest["version"] = "0.1.0"
    (release / "MANIFEST.json").write_text(json.dumps(manifest))
    with pytest.raises(ReleaseError, match="says version '0.1.0' but lies in 0.2.0/"):
        read_manifest(release)


def test_an_empty_output_is_not_released(tmp_path):
    """A zero-byte file (a killed writer of an older version) is refused by name."""
    data = tmp_path / "data"
    (data / "studies" / "ct02").mkdir(parents=True)
    (data / "studies" / "ct02" / "ct02.nc").write_bytes(b"")
    layout = Layout((StudyFiles("ct02", "0" * 64, ("studies/ct02/ct02.nc",), ()),), ())
    with pytest.raises(ReleaseError, match=r"empty files .*ct02\.nc"):
        make_release("0.2.0", data, layout=layout)


def creatio(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """The command in this process (inproc.py): what it says and returns is the test."""
    return run_cli(*args, cwd=cwd)


@pytest.mark.parametrize(("args", "code", "words"), [
    (["run", "en02"], 2, "pick it with study=en02"),
    (["run", "study=en02", "sphere.mu=nan"], 2, "sphere.mu=nan: must be a finite number"),
    (["run", "study=en02", "sphere.muu=0.3"], 2, "did you mean sphere.mu?"),
    (["run", "study=en02", "+sphere.colour=red"], 2, "unknown key"),
    (["run", "study=nope"], 2, "must be one of ct02"),
    (["diff", "/no/such/a", "/no/such/b"], 2, "no such file or directory"),
    (["release", "verify", "9.9.9", "--data-dir", "/no/such/dir"], 2, "no release 9.9.9"),
    (["frobnicate"], 2, "unknown command 'frobnicate'"),
])
def test_the_command_line_fails_in_one_line(args, code, words):
    proc = creatio(*args)
    assert proc.returncode == code, proc.stderr
    assert words in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_version_is_printed():
    from creatio import __version__

    proc = creatio("--version")
    assert proc.returncode == 0 and proc.stdout.strip() == f"creatio {__version__}"


def test_run_help_presents_creatio_and_only_the_groups_a_user_picks():
    out = creatio("run", "--help").stdout
    assert out.startswith("creatio run:") and "powered by Hydra" not in out
    groups = out.split("== Configuration groups ==")[1].split("==")[0]
    assert "solver: dop853, dopri5, radau, radau13, radau5, radau9, rk4, rodas4" in groups
    assert "schema:" not in groups and "scene:" not in groups and "sweeps:" not in groups
    probe = creatio("probe", "--help").stdout
    assert probe.startswith("creatio probe:") and "solver:" not in probe


def test_info_prints_once():
    """In a process of its own: Hydra's logging set-up is what printed it twice."""
    out = subprocess.run([sys.executable, "-m", "creatio.cli", "run", "--info", "defaults"],
                         capture_output=True, text=True,
                         env={**os.environ, "CREATIO_DEBUG": ""}).stdout
    assert out.count("Defaults List") == 1, out


@pytest.mark.parametrize(("line", "expected"), [
    ("creatio r", {"run", "release"}),
    ("creatio run solver=", {"solver=dop853", "solver=dopri5", "solver=radau", "solver=radau13",
                             "solver=radau5", "solver=radau9", "solver=rk4", "solver=rodas4"}),
    ("creatio run study=en02 sphere.m", {"sphere.m=", "sphere.mu="}),
    ("creatio probe geometry.K", {"geometry.Ka=", "geometry.Kr="}),
])
def test_shell_completion_completes_commands_groups_and_keys(line, expected):
    proc = run_cli("-sc", "query=bash", env={"COMP_LINE": line})
    assert proc.returncode == 0, proc.stderr
    assert set(proc.stdout.split()) == expected


WRITERS = {"write_text", "write_bytes", "savefig", "to_netcdf", "to_csv"}


def _writes(tree: ast.AST):
    """(line, call) of every call that writes a file: Path.write_*, savefig, to_netcdf,
    to_csv, and open / Path.open with a write, append or exclusive mode."""
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
        if name in WRITERS and isinstance(func, ast.Attribute):
            yield node
        elif name == "open":
            modes = [a for a in node.args if isinstance(a, ast.Constant)]
            modes += [k.value for k in node.keywords if k.arg == "mode"]
            if any(isinstance(m, ast.Constant) and isinstance(m.value, str)
                   and set(m.value) & set("wax") for m in modes):
                yield node


def test_every_file_the_package_writes_goes_through_a_temporary_and_a_rename():
    """A write straight to its final path leaves a partial file when the job is killed; the
    package writes to temporaries (names containing tmp) and renames, or through
    creatio.store's helpers."""
    src = Path(netcdf.__file__).parents[1]
    direct = []
    for path in sorted(src.rglob("*.py")):
        if path.relative_to(src).as_posix() in ("store/atomic.py", "store/netcdf.py"):
            continue
        tree = ast.parse(path.read_text())
        for call in _writes(tree):
            target = call.func.value if isinstance(call.func, ast.Attribute) else call.args[0]
            text = ast.unparse(target) + " " + ast.unparse(call)
            if "tmp" not in text:
                direct.append(f"{path.relative_to(src)}:{call.lineno}: {ast.unparse(call)[:70]}")
    assert direct == []


def test_an_overflow_past_validation_is_one_line_naming_where(monkeypatch, capsys):
    """The safety net behind the range rule: an ArithmeticError inside a run is one line with
    the file and line where it happened, status 1, no traceback."""
    from creatio import cli

    def overflow(argv):
        return math.exp(1e4)

    monkeypatch.setattr(cli, "_dispatch", overflow)
    monkeypatch.delenv("CREATIO_DEBUG", raising=False)
    assert cli.main(["run", "study=en02"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "OverflowError" in err and "test_hardening.py:" in err and "numeric range" in err


@pytest.mark.parametrize("study, override, key", [
    ("ct02", "geometry.dR=1e-300", "geometry.dR"),
    ("ct02", "study.h=[0.01,1e300]", "study.h[1]"),
    ("en02", "phases.r.omega=-1e300", "phases.r.omega"),
    ("en02", "sphere.b=1e300", "sphere.b"),
    ("en02", "sphere.b=1e-300", "sphere.b"),
])
def test_magnitudes_that_overflow_the_model_are_refused(study, override, key):
    """Found by running every numeric key at 0, -1, nan, +-inf, 1e300, 1e-300 and 'abc':
    these were accepted and then overflowed (k = 2 pi Kr / dR squared, h**2, omega**2, the
    sphere's inertia 2/5 m b^2 in the friction's stability estimate)."""
    from creatio.pipeline.config import resolve

    with pytest.raises(ConfigError, match="in magnitude") as err:
        resolve(study, [override])
    assert str(err.value).startswith(f"invalid config: {key}=")


@pytest.mark.parametrize("override, rule", [
    ("flight.restitution=-1", "must be in [0, 1]"),
    ("flight.impact_cap=0", "between 1 and"),
    ("flight.impact_cap=1e12", "between 1 and"),
    ("study.cycles_s=[]", "needs at least 1 value"),
    ("study.restitutions=[]", "needs at least 1 value"),
])
def test_en02f_settings_are_refused_as_config_errors(override, rule):
    """EN-02F's flight settings are refused with key, value and rule: they reached the
    problem's ValueError first (the stability rule builds problems), and a cap of 1e12
    impacts per second sized a 1.9 PiB event table (MemoryError), and an empty list of
    cycles or restitutions reached min() of nothing. Found by the fuzz."""
    from creatio.pipeline.config import resolve

    with pytest.raises(ConfigError) as err:
        resolve("en02f", [override])
    assert str(err.value).startswith(f"invalid config: {override.split('=')[0]}=")
    assert rule in str(err.value)


def test_an_empty_feature_list_is_refused_and_a_failing_run_is_one_line(tmp_path):
    """CT-02 with no feature times ran, then its report failed inside `creatio run` (a Hydra
    app), where Hydra printed a traceback of 20 lines; now the value is refused, and a failure
    inside a run is one line."""
    from creatio import cli
    from creatio.pipeline.config import resolve

    with pytest.raises(ConfigError, match="feature_times"):
        resolve("ct02", ["study.feature_times=[]"])
    message, code = cli.describe(ValueError("zero-size array\nsecond line"))
    assert code == 1 and "\n" not in message and message.startswith("ValueError: zero-size")


@pytest.mark.parametrize("argv, words", [
    (["task", "scene", "dataset", "xx", "out.nc"], "invalid choice: 'xx'"),
    (["task", "dataset"], "required: study, out"),
    (["diff"], "required: A, B"),
    (["ls", "--bogus"], "unrecognized arguments: --bogus"),
    (["task", "en05"], "required: step"),
])
def test_a_command_line_argparse_refuses_is_one_line(tmp_path, argv, words):
    """A wrong subcommand argument is one line naming the problem and --help, exit 2, not
    argparse's usage block (and nothing is written)."""
    proc = subprocess.run([sys.executable, "-m", "creatio.cli", *argv], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert words in lines[0] and lines[0].endswith("--help)") and "usage" not in lines[0]
    assert list(tmp_path.iterdir()) == []
