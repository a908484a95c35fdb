"""Where the points of :func:`impactosc.sweep` run, and the loop that feeds them there.

One small interface (:class:`Runner`) over four kinds of executor:

- ``"pool"`` (the default): a process pool of loky (https://github.com/joblib/loky) owned by
  this module and reused from sweep to sweep, so that its workers keep their compiled
  heyoka integrators. loky starts workers that do not re-import the caller's ``__main__``,
  so a sweep runs from a script without a ``__main__`` guard, from standard input, a REPL
  or a notebook alike. Idle workers exit after :data:`WORKER_IDLE_SECONDS`; every worker
  exits within about a second when the process that started it dies (even by SIGKILL).
- ``"serial"``: in this process.
- ``"dask"``: a ``dask.distributed`` client.
- ``"executor"``: anything with ``submit(fn, *args)`` returning futures (not shut down).

:func:`execute` submits batches of points, a few per worker at a time, sized from the
measured cost of a point so that a task takes about :data:`TASK_SECONDS`: many cheap points
share one task, while every finished batch is saved soon after it finishes and an
interruption loses at most the batches in flight. On an interrupt (Ctrl-C) the batches in
flight are cancelled and the workers of the owned pool are killed at once.
"""

from __future__ import annotations

import concurrent.futures as cf
import os
import signal
import threading
import time
from collections import deque
from typing import Any

from ._point import STATUS_LOST, failure, run_batch
from ._store import interrupt_deferred

#: Target wall time of one task: large enough that the per-task overhead of a process pool
#: (about a millisecond) is negligible, small enough that an interruption loses little.
TASK_SECONDS = 0.25
#: Tasks kept submitted per worker: one running and one queued, so no worker waits on the caller.
TASKS_IN_FLIGHT_PER_WORKER = 2
#: Idle workers of the default pool exit after this long (the next sweep starts new ones).
WORKER_IDLE_SECONDS = 300
#: How often a worker checks that the process that started it is still alive.
PARENT_CHECK_SECONDS = 0.5

_POOL = None  # the default loky pool, started on first use
_POOL_LOCK = threading.Lock()
_EXIT_HOOK_REGISTERED = False


def check_executor(executor) -> None:
    """Raise for an executor that cannot work, before the store is touched or anything runs."""
    if executor is None or (isinstance(executor, str) and executor in ("serial", "dask")):
        return
    if isinstance(executor, str):
        raise ValueError(f"executor must be None, 'serial', 'dask', a concurrent.futures.Executor or a "
                         f"dask.distributed.Client, got {executor!r}")
    if not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor must have a submit() method (concurrent.futures.Executor or "
                        f"dask.distributed.Client), got {type(executor).__name__}")
    if _is_dask_client(executor) and executor.status not in ("running", "connecting", "newly-created"):
        raise ValueError(f"executor is a dask.distributed.Client that is {executor.status}: pass a running Client, "
                         f"or executor='dask' to use the current client or start a local cluster")


# ---------------------------------------------------------------------------------------
# The default pool
# ---------------------------------------------------------------------------------------
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


def _default_pool():
    """The module's loky pool, started (or replaced, if broken or shut down) on demand."""
    global _POOL
    try:
        import loky
    except ImportError:  # a dependency of impactosc; only a broken install gets here
        raise ImportError("the default sweep executor needs loky: pip install loky") from None
    with _POOL_LOCK:
        if _POOL is None or _POOL._flags.broken is not None or _POOL._flags.shutdown:
            _POOL = loky.ProcessPoolExecutor(max_workers=loky.cpu_count(), timeout=WORKER_IDLE_SECONDS,
                                             initializer=_worker_init, initargs=(os.getpid(),))
        return _POOL


def _register_exit_hook() -> None:
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
            register(_kill_default_pool)
        _EXIT_HOOK_REGISTERED = True


def _kill_default_pool() -> None:
    global _POOL
    with _POOL_LOCK:
        pool, _POOL = _POOL, None
    if pool is not None:
        pool.shutdown(wait=False, kill_workers=True)


# ---------------------------------------------------------------------------------------
# Runner
# ---------------------------------------------------------------------------------------
class Runner:
    """Submits tasks to one kind of executor: "serial", "pool" (owned), "dask" or any "executor".

    An owned dask cluster (``executor="dask"`` without a current client) is shut down at the
    end; the default pool is kept for the next sweep; a user's executor is left as it is.
    """

    def __init__(self, executor):
        self.kind, self._executor, self._owned_dask = "executor", executor, False
        if executor is None:
            self.kind = "pool"
            self._executor = _default_pool()
            self.n_workers = self._executor._max_workers
        elif isinstance(executor, str) and executor == "serial":
            self.kind, self.n_workers = "serial", 1
        elif isinstance(executor, str) and executor == "dask":
            self.kind = "dask"
            self._executor, self._owned_dask = _dask_client()
        elif _is_dask_client(executor):
            self.kind = "dask"
        if self.kind == "dask":
            self.n_workers = max(1, sum(self._executor.nthreads().values()))
        elif self.kind == "executor":
            self.n_workers = getattr(executor, "_max_workers", None) or os.cpu_count() or 1
        self.max_in_flight = 1 if self.kind == "serial" else TASKS_IN_FLIGHT_PER_WORKER * self.n_workers

    def submit(self, task: list, args: tuple):
        if self.kind == "serial":
            fut: cf.Future = cf.Future()
            fut.set_result(run_batch(task, *args))  # a KeyboardInterrupt propagates from here
            return fut
        with interrupt_deferred():  # not inside the executor's locks
            if self.kind == "dask":
                return self._executor.submit(run_batch, task, *args, pure=False)
            fut = self._executor.submit(run_batch, task, *args)
            if self.kind == "pool":
                _register_exit_hook()
            return fut

    def wait_first(self, futures) -> set:
        """The futures that are done, waiting until at least one is."""
        if self.kind == "dask":
            import distributed

            return set(distributed.wait(list(futures), return_when="FIRST_COMPLETED").done)
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def recover(self) -> None:
        """After a lost task: replace the default pool if it broke (a user's executor is theirs)."""
        if self.kind == "pool" and (self._executor._flags.broken is not None or self._executor._flags.shutdown):
            self._executor.shutdown(wait=False, kill_workers=True)
            self._executor = _default_pool()

    def abort(self, futures) -> None:
        """On an interrupt or error: cancel the tasks in flight; kill the workers we own."""
        if self.kind == "pool":
            _kill_default_pool()  # the running tasks die with their workers; nothing waits for them
        elif self.kind == "dask":
            try:
                self._executor.cancel(list(futures))
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass
        else:
            for fut in futures:
                fut.cancel()
        self.close()

    def close(self) -> None:
        if self._owned_dask:
            self._owned_dask = False
            cluster = self._executor.cluster
            self._executor.close()
            if cluster is not None:
                cluster.close()


def _is_dask_client(obj) -> bool:
    try:
        import distributed
    except ImportError:
        return False
    return isinstance(obj, distributed.Client)


def _dask_client():
    try:
        import distributed
    except ImportError:
        raise ImportError("executor='dask' needs dask.distributed: pip install impactosc[dask]") from None
    try:
        return distributed.get_client(), False  # a client the user already started: theirs to close
    except ValueError:
        n = os.cpu_count() or 1
        return distributed.Client(n_workers=n, threads_per_worker=1, processes=True), True


# ---------------------------------------------------------------------------------------
# The loop
# ---------------------------------------------------------------------------------------
class _BatchSizer:
    """Points per task, from a running mean of the measured seconds per point.

    The first tasks hold one point each (the cost is unknown); after that about
    :data:`TASK_SECONDS` of work, but never so many points that fewer than two tasks per
    worker remain (the tail of the sweep must still spread over all workers).
    """

    def __init__(self, n_workers: int):
        self.n_workers = n_workers
        self.seconds_per_point: float | None = None

    def add(self, seconds: float) -> None:
        s = self.seconds_per_point
        self.seconds_per_point = seconds if s is None else 0.7 * s + 0.3 * seconds

    def size(self, n_left: int) -> int:
        if self.seconds_per_point is None:
            return 1
        by_time = int(TASK_SECONDS / max(self.seconds_per_point, 1e-9))
        by_balance = -(-n_left // (TASKS_IN_FLIGHT_PER_WORKER * self.n_workers))
        return max(1, min(by_time, by_balance))


def execute(runner: Runner, todo: list, args: tuple, on_result, bar) -> None:
    """Run ``todo = [(key, fields), ...]`` and call ``on_result(key, result)`` for each point.

    A task that raises as a whole (its worker process died, dask gave up on it, the pool
    broke) does not say which of its points was guilty: its points are retried one per
    task; a point lost twice is run once more alone, with nothing else running, so that only
    a point that crashes its worker by itself is recorded as lost (status -3).
    """
    fresh, retry, suspects = deque(todo), deque[Any](), list[Any]()
    attempts: dict[str, int] = {}
    in_flight: dict = {}
    sizer = _BatchSizer(runner.n_workers)

    def lost(task):
        runner.recover()
        for point in task:
            attempts[point[0]] = attempts.get(point[0], 0) + 1
            (retry if attempts[point[0]] < 2 else suspects).append(point)

    def deliver(results):
        for key, result, seconds in results:
            on_result(key, result)
            sizer.add(seconds)
        bar.update(len(results))

    try:
        while fresh or retry or in_flight:
            while (fresh or retry) and len(in_flight) < runner.max_in_flight:
                if retry:
                    task = [retry.popleft()]
                else:
                    # Serially, nothing amortises a batch: one point per task, each saved at once.
                    n = 1 if runner.kind == "serial" else min(sizer.size(len(fresh)), len(fresh))
                    task = [fresh.popleft() for _ in range(n)]
                try:
                    in_flight[runner.submit(task, args)] = task
                except Exception:  # noqa: BLE001 - e.g. a broken pool: its points are retried
                    lost(task)
            if not in_flight:
                continue
            for fut in runner.wait_first(in_flight):
                task = in_flight.pop(fut)
                try:
                    results = fut.result()
                except Exception:  # noqa: BLE001 - the whole task failed: retried
                    lost(task)
                    continue
                deliver(results)
        # The suspects, each alone: a crash now is that point's own.
        for point in suspects:
            try:
                results = runner.submit([point], args).result()
            except Exception as exc:  # noqa: BLE001
                runner.recover()
                on_result(point[0], failure(STATUS_LOST, f"task lost ({type(exc).__name__}: {exc})"))
                bar.update(1)
                continue
            deliver(results)
    except BaseException:
        runner.abort(in_flight)
        raise
    runner.close()
