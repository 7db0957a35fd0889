"""How the core compiles its per-body functions (numba): the options, and the one rule they need.

``JIT``: cached on disk, IEEE semantics (x/0 is inf or NaN, caught by the step checks)
rather than Python's ZeroDivisionError, and the GIL released while it runs, so another
thread (the node's executor) can run, and cancel a long step (stepping.advance).

``INLINE``: the same, inlined at numba's IR level into the caller, for functions that take
the state, parameter or wrench rows (arrays): a compiled call with array arguments costs
reference-count updates per array, which the per-body loops cannot afford.

The rule (measured: derivative 38 ns → 7 ns per body, explicit Euler 76 ns → 15 ns, against
a plain loop's 12 ns). numba counts references to every array a function holds and drops
them after each variable's last use. When that last use is inside a branch, the drops land
on different paths and LLVM's reference-count pruning cannot pair them with the takes: two
atomic operations per array per body remain. So, in an ``INLINE`` function and in the loops
that call them:

* one ``return``, at the end;
* if an array parameter's last use can be in a branch (or a loop that may run no times),
  end the function by reading each such array once more, unconditionally::

      _pin = y[P], p[MASS], w[ACTIVE]   # keeps the arrays' last use out of the branches (jit.py)
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
from pathlib import Path
from typing import Callable, Iterator, TypeVar

__all__ = ["JIT", "INLINE", "LOOP", "named", "invalidate_stale_cache", "cache_lock", "cache_complete", "mark_cache_complete",
           "sources_unchanged"]

JIT = {"cache": True, "error_model": "numpy", "nogil": True}
INLINE = {**JIT, "inline": "always"}
#: For functions built at import (closures, stepping.py): compiled into a cached caller, not cached on their own.
LOOP = {"error_model": "numpy", "nogil": True}

F = TypeVar("F", bound=Callable)


def named(tag: str) -> Callable[[F], F]:
    """Decorator, under ``njit``: names a function a factory builds (a closure) ``<qualname>[tag]``.

    Every function a factory returns must get a ``tag`` no other of them gets. numba names a
    function's machine code after its module, its qualname, a number counted per process and its
    argument types, and a cached function carries the code of every function it calls under those
    names, as weak symbols. Closures of one factory share a qualname, so two of them compiled in
    different processes can get the same name; a process that loads both callers from the cache
    keeps one body for that name, and one caller then runs the other's closure: wrong results,
    no error. With a qualname of its own, a name stands for one body whichever process compiled it.
    """
    def rename(function: F) -> F:
        function.__qualname__ = f"{function.__qualname__}[{tag}]"
        return function
    return rename


#: The kernels' folder: the sources the cached machine code is built from (nothing outside it).
SOURCE_DIR = Path(__file__).resolve().parent
#: Where numba caches the kernels (next to their sources, when writable).
CACHE_DIR = SOURCE_DIR / "__pycache__"
STAMP_NAME = "numba-sources.sha256"
#: Written (the sources' hash) once every kernel was compiled into the cache under the lock.
COMPLETE_NAME = "numba-compiled.sha256"
LOCK_NAME = "numba-compile.lock"


def _digest(source_dir: Path) -> str:
    sources = sorted(p for p in source_dir.rglob("*.py") if "__pycache__" not in p.parts)
    return hashlib.sha256(b"".join(p.relative_to(source_dir).as_posix().encode() + p.read_bytes()
                                   for p in sources)).hexdigest()


#: The hash of the kernel sources this process imported (what its compiled code is built from).
SOURCE_DIGEST = _digest(SOURCE_DIR)


def _lock_dir() -> Path | None:
    """Where numba writes this process's kernel cache, if it can be locked there: NUMBA_CACHE_DIR
    when set, else next to the sources when writable, else None (a read-only install)."""
    user_dir = os.environ.get("NUMBA_CACHE_DIR")
    folder = Path(user_dir) if user_dir else CACHE_DIR
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return folder if os.access(folder, os.W_OK) else None


_held = False


@contextlib.contextmanager
def cache_lock() -> Iterator[None]:
    """Hold the kernel cache's lock (an exclusive ``flock``, across processes) while compiling.

    numba's cache is not safe for two processes compiling into it at once: each reads the
    function's index, numbers its new entry after the entries it saw, and writes the index
    back, so two processes adding different entries at once can both take number n, and the
    index of one then points at the other's machine code. Compiling under this lock makes
    the first process compile and the others wait, then load. Re-entrant within a process;
    a no-op where the cache is not writable.
    """
    global _held
    folder = _lock_dir()
    if _held or folder is None:
        yield
        return
    with open(folder / LOCK_NAME, "a+b") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        _held = True
        try:
            yield
        finally:
            _held = False
            fcntl.flock(handle, fcntl.LOCK_UN)


def sources_unchanged() -> bool:
    """True if the kernel sources on disk are still the ones this process imported."""
    return _digest(SOURCE_DIR) == SOURCE_DIGEST


def cache_complete() -> bool:
    """True if every kernel of this process's sources is in the cache (or the cache is not ours
    to fill: a read-only install)."""
    folder = _lock_dir()
    if folder is None:
        return True
    try:
        return (folder / COMPLETE_NAME).read_text() == SOURCE_DIGEST
    except OSError:
        return False


def mark_cache_complete() -> None:
    """Record (under :func:`cache_lock`) that every kernel of this process's sources is cached."""
    folder = _lock_dir()
    if folder is not None:
        partial = folder / f"{COMPLETE_NAME}.{os.getpid()}"
        partial.write_text(SOURCE_DIGEST)
        os.replace(partial, folder / COMPLETE_NAME)


def invalidate_stale_cache(source_dir: Path = SOURCE_DIR, cache_dir: Path = CACHE_DIR) -> bool:
    """Drop numba's cached machine code of the kernels if any source under ``source_dir`` changed since.

    numba checks a cached function against its own file only, but a compiled function here
    contains the functions it inlines from other modules (stepping.advance holds the
    integrators, the forces, the dynamics): editing integrators.py would leave advance's
    cache stale, silently. So the cache is kept only for the exact set of sources under
    ``source_dir`` (kernels/, subpackages included) it was compiled from (a hash, stamped in
    ``cache_dir``); sources outside it (scene.py, describe.py, ...) are never compiled, so
    editing them keeps the cache. Dropping clears ``cache_dir`` and the ``__pycache__`` of
    every subpackage. Returns True when
    it was dropped. Runs once, at import, before anything is compiled or loaded; a read-only
    install is left alone.
    """
    digest = _digest(source_dir)
    stamp = cache_dir / STAMP_NAME
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    try:
        caches = {cache_dir, *source_dir.rglob("__pycache__")}
        for stale in [path for folder in caches for pattern in ("*.nbi", "*.nbc") for path in folder.glob(pattern)]:
            stale.unlink(missing_ok=True)
        (cache_dir / COMPLETE_NAME).unlink(missing_ok=True)
        cache_dir.mkdir(exist_ok=True)
        partial = stamp.with_name(f"{STAMP_NAME}.{os.getpid()}")
        partial.write_text(digest)
        os.replace(partial, stamp)
    except OSError:  # not writable: numba caches elsewhere (NUMBA_CACHE_DIR), per file, as it does
        return False
    return True


with cache_lock():
    invalidate_stale_cache()
