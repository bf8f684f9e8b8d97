"""The compiler of the dynamics layer: numba, with a cache keyed by the source it compiles.

numba's on-disk cache checks only the timestamp of the file that defines a cached function,
not of the functions it calls, so an edited formula in creatio.model could be served from a
stale cache. Every compiled loop here is therefore cached under a directory named by a hash
of the model and dynamics sources: new code, new cache. ``CREATIO_NUMBA_CACHE`` (or numba's
own ``NUMBA_CACHE_DIR``) moves its root; the default is ``$XDG_CACHE_HOME/creatio/numba``.

Importing this module also lets compiled code call the scalar formulas of creatio.model
(their SCALAR_KERNELS) as they are: numba compiles them where they are called.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["cache_dir", "njit", "source_hash"]

_PACKAGE = Path(__file__).resolve().parents[1]


def source_hash() -> str:
    """sha256 (12 hex) over the sources of creatio.model and creatio.dynamics."""
    h = hashlib.sha256()
    for folder in ("model", "dynamics"):
        for path in sorted((_PACKAGE / folder).rglob("*.py")):
            h.update(path.relative_to(_PACKAGE).as_posix().encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:12]


def cache_dir() -> Path:
    """Where the compiled loops of this source tree are cached (an empty variable counts as
    unset: numba would otherwise cache into the working directory)."""
    if os.environ.get("NUMBA_CACHE_DIR") and not os.environ.get("CREATIO_NUMBA_CACHE"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    root = os.environ.get("CREATIO_NUMBA_CACHE") or Path(
        os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "creatio" / "numba"
    return Path(root) / source_hash()


def _configure() -> None:
    target = str(cache_dir())
    if os.environ.get("NUMBA_CACHE_DIR") != target:
        os.environ["NUMBA_CACHE_DIR"] = target
        import sys

        if "numba" in sys.modules:  # imported before us: make it read the variable again
            from numba.core import config

            config.reload_config()


_configure()

from numba import njit  # noqa: E402
from numba.extending import register_jitable  # noqa: E402

from creatio.model import cavity, flight, laws, offset, sphere, structure  # noqa: E402

# offset_jets is inlined into its callers by numba: LLVM would keep it a call that returns
# its 53 numbers through memory, and the right-hand side runs ~7% slower (bench_against)
_INLINED = {offset.offset_jets: "always"}
for _fn in (laws.law_eval, *offset.SCALAR_KERNELS, *sphere.SCALAR_KERNELS,
            *cavity.SCALAR_KERNELS, *structure.SCALAR_KERNELS, *flight.SCALAR_KERNELS):
    register_jitable(inline=_INLINED.get(_fn, "never"))(_fn)
