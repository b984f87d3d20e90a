"""The one door to numba: how a module's plain Python loops become compiled ones.

Each concept keeps its compiled loops in a private loops module beside it (``_calibration_loops``,
``_strapdown_loops``, ``steps/_loops.py``, ``field/_loops.py``, ``_aided_kernel``,
``montecarlo/_batch_ins.py``), written as plain Python that numba can compile. Such a module ends
with ``compiled = loops(globals(), _FUNCTIONS)``: its :func:`loops` accessor compiles the named
functions on its first call, once per process, and hands them back by name.

- numba is imported here only, on a kernel's first call (:func:`jit_functions`), not with the
  package, and its machine code is cached on disk. numba's cache checks only the file a function is
  defined in, but a loop that calls another module's loop (the aided filter's pass calls the
  strapdown's Rodrigues formula, the steps' swing median calls calibration's sort) holds the callee's
  machine code too: :func:`loops` adds the callee files' stamps to the caller's, so editing a callee
  recompiles its callers.
- :data:`COMPILE_LOCK` is held while a module's functions are put through numba: threads that reach
  a kernel at once (a study's chunks on threads or Dask workers) wrap each function once.
- :func:`read_only` hands an input array to a compiled loop: numba compiles a loop once per argument
  type, and a read-only array is another type than a writeable one.

The loops run as plain Python too (slowly), loaded a second time without compiling: the tests compare
both, and hold them to the numpy or scipy forms they restate (``tests/oracles``).
"""
from __future__ import annotations

import os
import threading

import numpy as np

#: Held while a module's functions are put through numba: threads that reach a kernel at once (a study's
#: chunks on threads or Dask workers) wrap each function once, never a function already wrapped.
COMPILE_LOCK = threading.Lock()


def jit_functions(space: dict, names) -> dict:
    """Compile the functions `names` of a module's namespace `space` with numba (callees first), each put
    back in `space` so the later ones call the compiled forms; returns them by name. numba is imported
    here, and its machine code is cached on disk."""
    import numba

    out = {}
    for name in names:
        out[name] = space[name] = numba.njit(cache=True, nogil=True)(space[name])
    return out


def read_only(a, dtype=float) -> np.ndarray:
    """A read-only C-ordered view of `a` as `dtype` (a copy only where `a` is not already one).

    numba compiles a loop once per argument type, and a read-only array is another type than a
    writeable one: the callers hand every input array of a compiled loop through here, so a loop
    compiles once whether its caller's array is frozen or not (each compilation costs up to seconds on
    a fresh install)."""
    v = np.ascontiguousarray(a, dtype=dtype).view()
    v.flags.writeable = False
    return v


def _stamp_callees(dispatchers, borrowed) -> None:
    """Make the disk cache of `dispatchers` depend on the files of the loops they call (`borrowed`, the
    other modules' compiled loops by name) as well as on their own: numba keeps a cached index only while
    its source stamp (the file's time and size) is unchanged, and that stamp is here extended by the
    callee files' stamps. Without the attributes this relies on (another numba), nothing changes."""
    files = sorted({f.py_func.__code__.co_filename for other in borrowed for f in other.values()})
    if not files:
        return
    extra = tuple((os.stat(p).st_mtime, os.stat(p).st_size) for p in files)
    for d in dispatchers:
        index = getattr(getattr(d, "_cache", None), "_cache_file", None)
        if index is not None and hasattr(index, "_source_stamp"):
            index._source_stamp = (index._source_stamp, extra)


def loops(space: dict, names, uses=()):
    """The accessor of a loops module: a function that returns the functions `names` of the module's
    namespace `space` compiled by numba, by name, compiling them on its first call (once per process,
    under :data:`COMPILE_LOCK`, through :func:`jit_functions`).

    `uses` holds the accessors of the loops modules whose functions this module imports and calls: they
    are compiled first, and their compiled forms take the place of the plain functions `space` imported
    (numba finds a callee in its caller's namespace). Each accessor takes the lock in turn, never inside
    another's."""
    result = None

    def compiled() -> dict:
        nonlocal result
        if result is None:
            borrowed = [use() for use in uses]
            with COMPILE_LOCK:
                if result is None:
                    for other in borrowed:
                        for name, f in other.items():
                            if space.get(name) is f.py_func:
                                space[name] = f
                    result = jit_functions(space, names)
                    _stamp_callees(result.values(), borrowed)
        return result

    compiled.__doc__ = (f"The loops of ``{space['__name__']}`` compiled by numba, by name (once per process; "
                        "the machine code is cached on disk).")
    return compiled
