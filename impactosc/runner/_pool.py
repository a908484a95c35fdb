"""The default executor: one local process pool (loky's), owned by this module and reused.

loky (https://github.com/joblib/loky) starts workers that do not re-import the caller's
``__main__``, so the pool works from a script without an ``if __name__ == "__main__":``
guard, from standard input, a REPL or a notebook alike. The pool is kept from run to run so
that its workers keep what they compiled (heyoka integrators, numba functions). Idle
workers exit after :data:`WORKER_IDLE_SECONDS`; every worker exits within
:data:`PARENT_CHECK_SECONDS` when the process that started it dies, even by SIGKILL.
"""

from __future__ import annotations

import os
import signal
import threading
import time

#: Idle workers of the default pool exit after this long (the next run starts new ones).
WORKER_IDLE_SECONDS = 300
#: How often a worker checks that the process that started it is still alive.
PARENT_CHECK_SECONDS = 0.5

_POOL = None  # the default loky pool, started on first use
_POOL_LOCK = threading.Lock()
_EXIT_HOOK_REGISTERED = False


def _worker_init(parent_pid: int) -> None:
    """Run first in every worker of the default pool.

    Ctrl-C in a terminal reaches the whole process group: the caller handles it (and kills
    the workers), so a worker ignores it instead of printing a traceback. A daemon thread
    ends the worker when its parent is gone: it is then re-parented and ``getppid`` changes
    (POSIX). Without it a worker outlives a killed parent, holding its memory for good.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch():
        while os.getppid() == parent_pid:
            time.sleep(PARENT_CHECK_SECONDS)
        os._exit(1)

    threading.Thread(target=watch, name="impactosc-parent-watch", daemon=True).start()


def default_pool():
    """The module's loky pool, started (or replaced, if broken or shut down) on demand."""
    global _POOL
    try:
        import loky
    except ImportError:  # a dependency of impactosc; only a broken install gets here
        raise ImportError("the default executor needs loky: pip install loky") from None
    with _POOL_LOCK:
        if not pool_alive():
            _POOL = loky.ProcessPoolExecutor(max_workers=loky.cpu_count(), timeout=WORKER_IDLE_SECONDS,
                                             initializer=_worker_init, initargs=(os.getpid(),))
        return _POOL


def pool_alive() -> bool:
    """Whether the default pool exists and can take work (then starting it costs nothing)."""
    return _POOL is not None and _POOL._flags.broken is None and not _POOL._flags.shutdown


def pool_workers() -> int:
    """How many workers the default pool has (or would have)."""
    if _POOL is not None:
        return _POOL._max_workers
    try:
        import loky
    except ImportError:
        return os.cpu_count() or 1
    return loky.cpu_count()


def register_exit_hook() -> None:
    """Kill the default pool's workers when the interpreter exits, instead of shutting them down.

    loky's own exit hook shuts its pools down politely, which takes seconds when workers are
    still starting (``python script.py`` would linger after its last line); idle workers have
    nothing to lose. Registered after loky's hook (which loky registers at the first submit),
    so it runs first: both run in reverse order of registration, before non-daemon threads
    are joined.
    """
    global _EXIT_HOOK_REGISTERED
    if not _EXIT_HOOK_REGISTERED:
        register = getattr(threading, "_register_atexit", None)
        if register is not None:
            register(kill_default_pool)
        _EXIT_HOOK_REGISTERED = True


def kill_default_pool() -> None:
    """Kill the default pool's workers at once (the running tasks die with them)."""
    global _POOL
    with _POOL_LOCK:
        pool, _POOL = _POOL, None
    if pool is not None:
        pool.shutdown(wait=False, kill_workers=True)
