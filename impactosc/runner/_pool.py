"""The default executor: one local process pool (loky's), owned by this module and reused.

loky (https://github.com/joblib/loky) starts workers that do not re-import the caller's
``__main__``, so the pool works from a script without an ``if __name__ == "__main__":``
guard, from standard input, a REPL or a notebook alike. The pool is kept from run to run so
that its workers keep what they compiled (heyoka integrators, numba functions). Idle
workers exit after :data:`WORKER_IDLE_SECONDS`; every worker exits within
:data:`PARENT_CHECK_SECONDS` when the process that started it dies, even by SIGKILL.

Only loky's public API is used: the pool is a ``loky.ProcessPoolExecutor``; a pool that
broke (a worker died) is known by the ``loky.BrokenProcessPool`` its tasks raise
(:func:`replace_if_broken`), and at the interpreter's exit loky's own exit handler shuts it
down (idle workers exit at once; killing them instead left their semaphores to loky's
resource tracker, which warned of leaks under load).
"""

from __future__ import annotations

import atexit
import os
import signal
import sys
import threading
import time
import weakref

#: Idle workers of the default pool exit after this long (the next run starts new ones).
WORKER_IDLE_SECONDS = 300
#: How often a worker checks that the process that started it is still alive.
PARENT_CHECK_SECONDS = 0.5

_POOL = None  # the default loky pool, started on first use
_WORKERS: int | None = None  # its number of workers
_POOL_LOCK = threading.Lock()


def _worker_init(parent_pid: int) -> None:
    """Run first in every worker of the default pool.

    Ctrl-C in a terminal reaches the whole process group: the caller handles it (and kills
    the workers), so a worker ignores it instead of printing a traceback. A daemon thread
    ends the worker when its parent is gone: it is then re-parented and ``getppid`` changes
    (POSIX). Without it a worker outlives a killed parent, holding its memory for good.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # A worker told to stop has run multiprocessing's finalizers (its locks unregistered) by
    # the time the interpreter's exit handlers run; this one, registered first, runs last and
    # skips the teardown of heyoka's and numba's compiled code, seconds under load that the
    # parent's exit would wait for.
    atexit.register(_exit_now)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(PARENT_CHECK_SECONDS)
        os._exit(1)

    threading.Thread(target=watch, name="impactosc-parent-watch", daemon=True).start()


def _exit_now() -> None:
    """End the worker at once, its output flushed: the last exit handler of a worker."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    os._exit(0)


def _loky():
    try:
        import loky
    except ImportError:  # a dependency of impactosc; only a broken install gets here
        raise ImportError("the default executor needs loky: pip install loky") from None
    return loky


def default_pool():
    """The module's loky pool, started on demand (again after :func:`kill_default_pool`)."""
    global _POOL, _WORKERS
    loky = _loky()
    with _POOL_LOCK:
        if _POOL is None:
            _WORKERS = loky.cpu_count()
            _POOL = loky.ProcessPoolExecutor(max_workers=_WORKERS, timeout=WORKER_IDLE_SECONDS,
                                             initializer=_worker_init, initargs=(os.getpid(),))
            atexit.register(_forget_pool, weakref.ref(_POOL))
        return _POOL


def _forget_pool(pool_ref) -> None:
    """At exit, after loky's own handler has shut the pool down: let it go while the interpreter is whole.

    loky's manager thread watches the executor through a weak reference whose callback logs
    through ``multiprocessing.util``; collected during the interpreter's teardown (the module
    global still holding it), that callback found the module half gone and printed "Exception
    ignored in ... weakref_cb". Dropping the last references here collects it now.
    """
    global _POOL
    with _POOL_LOCK:
        if _POOL is not None and _POOL is pool_ref():
            _POOL = None


def pool_alive() -> bool:
    """Whether the default pool has been started and not killed (then using it costs no start)."""
    return _POOL is not None


def pool_workers() -> int:
    """How many workers the default pool has (or would have)."""
    if _WORKERS is not None:
        return _WORKERS
    try:
        return _loky().cpu_count()
    except ImportError:
        return os.cpu_count() or 1


def is_broken(exc: BaseException) -> bool:
    """Whether ``exc`` (raised by a task or a submit) says that the default pool broke."""
    try:
        return isinstance(exc, _loky().BrokenProcessPool)
    except ImportError:
        return False


def replace_if_broken(pool, exc: BaseException):
    """The pool to use after ``exc``: a new default pool if ``exc`` says ``pool`` broke, else ``pool``."""
    if not is_broken(exc):
        return pool
    global _POOL
    with _POOL_LOCK:
        if _POOL is pool:
            _POOL = None
    pool.shutdown(wait=False, kill_workers=True)  # what is left of it: its dead or stuck workers
    return default_pool()


def kill_default_pool() -> None:
    """Kill the default pool's workers at once (the running tasks die with them): on an interrupt."""
    global _POOL
    with _POOL_LOCK:
        pool, _POOL = _POOL, None
    if pool is not None:
        pool.shutdown(wait=False, kill_workers=True)
