"""Provenance (creatio.pipeline.provenance): what a dataset says about the command that made it."""

from __future__ import annotations


def test_history_records_the_command_not_the_path_of_cli_py(monkeypatch, tmp_path):
    """The Snakefile runs `python -m creatio.cli`, whose argv[0] is the clone's absolute
    path of cli.py (what `history` held): it now records the command as typed, `creatio
    task dataset ...` with every argument, paths relative to the working directory."""
    import creatio.cli
    from creatio.pipeline.provenance import provenance

    monkeypatch.chdir(tmp_path)
    argv = [creatio.cli.__file__, "task", "dataset", "en02",
            str(tmp_path / "data" / "studies" / "en02" / "en02_dt0.002.nc"), "--part",
            "en02_dt0.002", "--config-file", "data/configs/en02.yaml"]
    monkeypatch.setattr("sys.argv", argv)
    history = provenance("en02", "", "", "t")["history"]
    assert history.endswith(": creatio task dataset en02 data/studies/en02/en02_dt0.002.nc "
                            "--part en02_dt0.002 --config-file data/configs/en02.yaml")
    assert "cli.py" not in history and str(tmp_path) not in history
    monkeypatch.setattr("sys.argv", ["creatio run", "study=en02", "sphere.mu=0.3"])
    assert provenance("en02", "", "", "t")["history"].endswith(
        ": creatio run study=en02 sphere.mu=0.3")
