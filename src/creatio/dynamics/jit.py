"""The compiler of the dynamics layer: numba, with a cache keyed by the source it compiles.

numba's on-disk cache checks only the timestamp of the file that defines a cached function,
not of the functions it calls, so an edited formula in creatio.model could be served from a
stale cache. Every compiled loop here is therefore cached under a directory named by a hash
of the model and dynamics sources: new code, new cache. ``CREATIO_NUMBA_CACHE`` (or numba's
own ``NUMBA_CACHE_DIR``) moves its root; the default is ``$XDG_CACHE_HOME/creatio/numba``.

The cache is verified as it is used (:func:`_guard_cache`): a cache file that cannot be
loaded (truncated, garbled) is removed with one warning naming it and the function is
compiled anew, which rebuilds the entry; a cache that cannot be written (a full or read-only
filesystem) leaves the run uncached, with one warning.

Importing this module also lets compiled code call the scalar formulas of creatio.model
(their SCALAR_KERNELS) as they are: numba compiles them where they are called.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["INLINED", "cache_dir", "inlined", "njit", "source_hash"]

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


_WARNED: set[str] = set()


def _warn_once(kind: str, message: str) -> None:
    """One line on stderr per kind of cache trouble and process (the run goes on)."""
    import sys

    if kind not in _WARNED:
        _WARNED.add(kind)
        sys.stderr.write(f"creatio: warning: {message}\n")


def _guard_cache() -> None:
    """Make numba's on-disk cache repair itself and never fail a run.

    numba loads a cache entry by unpickling its index (.nbi) and data (.nbc) files and lets
    any error through: a truncated file failed every sphere run (UnpicklingError, naming no
    file) and stayed damaged. Here a load that fails for any reason but a missing file
    removes that function's index and data files and compiles anew (numba then writes a
    fresh entry); a save that fails with an OSError (no space, read-only, no permission)
    leaves the compiled function in memory, uncached."""
    import glob
    import os as _os

    from numba.core import caching

    if getattr(caching.Cache, "_creatio_guarded", False):
        return
    load, save = caching.Cache.load_overload, caching.Cache.save_overload

    def load_overload(self, sig, target_context):  # type: ignore[no-untyped-def]
        try:
            return load(self, sig, target_context)
        except Exception as e:  # noqa: BLE001 - any unreadable entry is rebuilt
            index = self._cache_file._index_path
            damaged = [index, *glob.glob(glob.escape(index[:-len(".nbi")]) + ".*.nbc")]
            for path in damaged:
                try:
                    _os.unlink(path)
                except OSError:
                    pass
            _warn_once("damaged", f"numba cache entry {index} could not be loaded "
                       f"({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}): "
                       "removed; compiling anew, which rebuilds it")
            return None

    def save_overload(self, sig, data):  # type: ignore[no-untyped-def]
        try:
            save(self, sig, data)
        except OSError as e:
            where = e.filename or self._cache_path
            _warn_once("unwritable", f"numba cache {where} cannot be written "
                       f"({e.strerror or e}): running uncached (compiled code is not kept "
                       "for the next run)")

    caching.Cache.load_overload = load_overload
    caching.Cache.save_overload = save_overload
    caching.Cache._creatio_guarded = True


_configure()
_guard_cache()

from numba import njit  # noqa: E402
from numba.extending import register_jitable  # noqa: E402

from creatio.model import cavity, control, flight, laws, offset, sphere, structure  # noqa: E402

# How a compiled formula reaches its callers. numba's own inlining (inline="always") copies the
# callee's IR into every caller and types it again there, at every level: the right-hand side
# took 10-12 s of type inference per specialisation, mostly deep copies of the offset jets'
# IR. A formula that must not stay a call is instead compiled once and marked for LLVM to
# inline (forceinline: LLVM's alwaysinline), at a fraction of the compile time. offset_jets is
# one: as a call it returns its 53 numbers through memory and the right-hand side runs ~7%
# slower (bench_against); law_eval another (LLVM keeps it an out-of-line call, three per
# right-hand side, once the loop holds more than one step kind). Every other formula says
# forceinline=False explicitly, so LLVM weighs it as before: numba otherwise lets a callee
# inherit the flag from whichever caller compiles it first.

#: The options of a compiled function LLVM always inlines into its callers; without reference
#: counting (nor inheriting it from a first caller that counts), as the loops it joins.
INLINED = {"forceinline": True, "_nrt": False}


def inlined(fn):  # type: ignore[no-untyped-def]
    """Register the plain function fn for compiled callers, compiled once per signature and
    inlined by LLVM into each (:data:`INLINED`). Registered rather than jitted: no wrapper for
    Python callers is built (fn itself stays plain Python there) and no cache file written."""
    return register_jitable(inline="never", **INLINED)(fn)


for _fn in (laws.law_eval, laws.trapezoid_scalar, *offset.SCALAR_KERNELS, *sphere.SCALAR_KERNELS,
            *cavity.SCALAR_KERNELS, *structure.SCALAR_KERNELS, *flight.SCALAR_KERNELS,
            *control.SCALAR_KERNELS):
    if _fn is offset.offset_jets or _fn is laws.law_eval:
        inlined(_fn)
    else:
        register_jitable(inline="never", forceinline=False)(_fn)
