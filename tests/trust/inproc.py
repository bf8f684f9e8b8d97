"""The `creatio` command run inside the test's own process, for the tests that check what a
command says and returns rather than the process itself (a new python costs about 1.5 s of
imports; the quick tier ran dozens). The tests about the process (signals, a closed stderr,
shell completion, a fresh numba cache, snakemake) keep their subprocesses."""

from __future__ import annotations

import contextlib
import io
import logging
import os
import subprocess
import sys
from pathlib import Path


def run_cli(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None
            ) -> subprocess.CompletedProcess:
    """`python -m creatio.cli ARGS` in this process: the same main(argv), in cwd, with env
    added and CREATIO_DEBUG unset; its exit status, stdout and stderr as a subprocess's.
    The working directory, environment, sys.argv and the root logger are restored after."""
    from creatio import cli

    saved_env, saved_argv, saved_cwd = dict(os.environ), list(sys.argv), os.getcwd()
    root = logging.getLogger()
    saved_handlers, saved_level = list(root.handlers), root.level
    out, err = io.StringIO(), io.StringIO()
    os.environ.update({"CREATIO_DEBUG": "", **(env or {})})
    sys.argv = ["creatio", *args]
    # a fresh process's root logger has no handler: `logging.basicConfig` in cli._dispatch
    # then writes the commands' log lines to stderr, as it does in a process of its own
    root.handlers.clear()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = cli.main(list(args))
            except SystemExit as e:  # Hydra's and argparse's exits
                if e.code is None or isinstance(e.code, int):
                    code = e.code or 0
                else:
                    print(e.code, file=sys.stderr)
                    code = 1
    finally:
        os.chdir(saved_cwd)
        os.environ.clear()
        os.environ.update(saved_env)
        sys.argv = saved_argv
        for handler in root.handlers:
            if handler not in saved_handlers:
                handler.close()
        root.handlers[:] = saved_handlers
        root.setLevel(saved_level)
    return subprocess.CompletedProcess(["creatio", *args], code, out.getvalue(), err.getvalue())
