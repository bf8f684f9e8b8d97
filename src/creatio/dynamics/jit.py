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

A run that must compile says so first (:func:`ensure_compiled`): one line to stderr naming
the specialisation and about how long its compile takes, from the time its last compile took
on this machine (recorded in ``compile_times.json`` at the cache's root, so it outlives a
source edit) or else from :data:`COMPILE_SECONDS`.

Importing this module also lets compiled code call the scalar formulas of creatio.model
(their SCALAR_KERNELS) as they are: numba compiles them where they are called.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["COMPILE_SECONDS", "INLINED", "cache_dir", "compile_estimate", "ensure_compiled",
           "inlined", "load_cached", "njit", "source_hash"]

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


def _times_path() -> Path:
    """The file of measured compile times: at the cache's root, beside the per-source
    directories (in the directory itself when NUMBA_CACHE_DIR names it)."""
    here = cache_dir()
    return (here if here.name != source_hash() else here.parent) / "compile_times.json"


def _recorded() -> dict[str, float]:
    """The compile times recorded on this machine, by specialisation ({} when none or
    unreadable)."""
    import json

    try:
        data = json.loads(_times_path().read_text())
    except (OSError, ValueError):
        return {}
    return {str(k): float(v) for k, v in data.items()} if isinstance(data, dict) else {}


def _record(name: str, seconds: float) -> None:
    """Record how long the compile of `name` took (written atomically; a cache that cannot
    be written keeps no record, silently: _guard_cache warns about it already)."""
    import json
    import tempfile

    path = _times_path()
    times = {**_recorded(), name: round(seconds, 1)}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".compile_times.")
        with os.fdopen(fd, "w") as f:
            json.dump(times, f, indent=1, sort_keys=True)
        os.replace(tmp, path)
    except OSError:
        pass


#: Compile times (s) of the driver's entry points by stepper kind, and of the hybrid loop, for
#: a machine that has recorded none: measured on the development machine (2 cores shared with
#: other jobs, load average 6.5) through creatio.dynamics.simulate of EN-02's specialisation
#: (rotation and energy: rk4, radau5, rodas4, radau9) and EN-02F's drop (hybrid), as
#: ensure_compiled records them (Dispatcher.compile), rounded up. explicit, radau5 and
#: rosenbrock with an empty cache (CREATIO_NUMBA_CACHE=$(mktemp -d)): 42.8, 54.4, 54.3 s;
#: radau_high_order and hybrid with the shared formulas already cached by the others: 94.8, 74.2 s.
COMPILE_SECONDS = {"explicit": 45.0, "radau5": 55.0, "rosenbrock": 55.0, "radau_high_order": 95.0,
                   "hybrid": 75.0}


def compile_estimate(name: str) -> tuple[float, str]:
    """(seconds, where the figure comes from) of compiling the entry point `name` (its
    dispatcher's name: _radau5_rot_en): its last compile here, else COMPILE_SECONDS for its
    kind (the longest kind whose name starts the entry's)."""
    recorded = _recorded().get(name)
    if recorded is not None:
        return recorded, "its last compile here"
    kinds = [k for k in COMPILE_SECONDS if name.lstrip("_").startswith(k)]
    kind = max(kinds, key=len) if kinds else max(COMPILE_SECONDS, key=COMPILE_SECONDS.get)
    return COMPILE_SECONDS[kind], f"measured for the {kind} kind, creatio.dynamics.jit"


def _duration(seconds: float) -> str:
    """A rough duration: 40 s, 3 min."""
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


def load_cached(disp, sig) -> bool:  # type: ignore[no-untyped-def]
    """Add the specialisation sig of a dispatcher from memory or numba's on-disk cache, as
    Dispatcher.compile does on a cache hit; False when neither holds it."""
    from numba.core.compiler_lock import global_compiler_lock

    sig = tuple(sig)
    with global_compiler_lock:
        if sig in disp.overloads:
            return True
        cres = disp._cache.load_overload(sig, disp.targetctx)
        if cres is None:
            return False
        disp._cache_hits[sig] += 1
        if not cres.objectmode:
            disp.targetctx.insert_user_function(cres.entry_point, cres.fndesc, [cres.library])
        disp.add_overload(cres)
        return True


#: (dispatcher, argument layout) pairs whose specialisation is known loaded in this process:
#: numba's typing of a sample's 18 arguments took 1 ms of a 7 ms run (EN-05). A layout that
#: maps two signatures to one key would only skip the announcement: the call still compiles.
_READY: set = set()


def _layout(a):  # type: ignore[no-untyped-def]
    """What numba's type of a depends on, cheaply: an array's dtype, rank and flags, a
    tuple's items, a number's or flag's Python type, any other value itself."""
    import numpy as np

    if isinstance(a, np.ndarray):
        f = a.flags
        return (a.dtype.str, a.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    if isinstance(a, tuple):
        return (type(a), tuple(_layout(x) for x in a))
    if isinstance(a, bool | int | float | complex | str | np.generic):
        return type(a)
    try:
        hash(a)
    except TypeError:
        return (type(a), id(a))
    return (type(a), a)


def ensure_compiled(disp, args: tuple, what: str) -> None:  # type: ignore[no-untyped-def]
    """Make the specialisation of dispatcher disp for args ready before it is called: loaded
    from memory or numba's on-disk cache as a call would, else compiled here after one line
    on stderr naming it (`what`: the run it serves) and about how long that takes; the time
    it took is recorded for the next estimate. A call then finds it and compiles nothing."""
    import sys
    import time

    layout = (disp, _layout(args))
    if layout in _READY:
        return
    sig = tuple(disp.typeof_pyval(a) for a in args)
    if sig in disp.overloads or load_cached(disp, sig):
        _READY.add(layout)
        return
    name = disp.py_func.__name__
    seconds, source = compile_estimate(name)
    sys.stderr.write(f"creatio: compiling {what} ({name}, not in the cache {cache_dir()}): "
                     f"about {_duration(seconds)} ({source})\n")
    sys.stderr.flush()
    t0 = time.perf_counter()
    disp.compile(sig)
    _record(name, time.perf_counter() - t0)


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
    if _fn in offset.INLINED_KERNELS or _fn is laws.law_eval:
        inlined(_fn)
    else:
        register_jitable(inline="never", forceinline=False)(_fn)
