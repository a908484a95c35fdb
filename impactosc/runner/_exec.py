"""Where the tasks of a many-point run go, and the loop that feeds them there.

One small interface (:class:`Runner`) over four kinds of executor:

- ``"pool"`` (the default): the reusable local process pool of :mod:`._pool`;
- ``"serial"``: in this process;
- ``"dask"``: a ``dask.distributed`` client (the client itself, or ``"dask"`` for the
  current client or a new local cluster). Its futures are waited on with
  ``distributed.wait``: ``concurrent.futures.wait`` does not know them;
- ``"executor"``: anything with ``submit(fn, *args)`` returning futures (not shut down).

:func:`execute` submits batches of points, a few per worker at a time, sized from the
measured cost of a point so that a task takes about :data:`TASK_SECONDS`: many cheap points
share one task, while every finished batch is handed back (and saved) soon after it
finishes and an interruption loses at most the batches in flight. On an interrupt (Ctrl-C)
the batches in flight are cancelled and the workers of the owned pool are killed at once.
"""

from __future__ import annotations

import concurrent.futures as cf
import os
import time
from collections import deque
from typing import Any

from . import _pool
from ._store import interrupt_deferred

#: Target wall time of one task: large enough that the per-task overhead of a process pool
#: (about a millisecond) is negligible, small enough that an interruption loses little.
TASK_SECONDS = 0.25
#: Tasks kept submitted per worker: one running and one queued, so no worker waits on the caller.
TASKS_IN_FLIGHT_PER_WORKER = 2

_ACCEPTED = ("None (the default local process pool), 'serial', 'dask', a concurrent.futures.Executor "
             "or a dask.distributed.Client")


def check_executor(executor) -> None:
    """Raise for an executor that cannot work, before a store is touched or anything runs."""
    if executor is None or (isinstance(executor, str) and executor in ("serial", "dask")):
        return
    if isinstance(executor, str):
        raise ValueError(f"executor must be {_ACCEPTED}, got {executor!r}")
    if not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor must have a submit() method ({_ACCEPTED}), got {type(executor).__name__}")
    if _is_dask_client(executor) and executor.status not in ("running", "connecting", "newly-created"):
        raise ValueError(f"executor is a dask.distributed.Client that is {executor.status}: pass a running Client, "
                         f"or executor='dask' to use the current client or start a local cluster")


def run_batch(fn, points: list, *args) -> list:
    """Run ``fn(payload, *args)`` for ``points = [(key, payload), ...]``: ``[(key, result, seconds), ...]``.

    ``seconds`` is the wall time of the point in the worker, from which the caller sizes its
    next batches. ``fn`` records a point's own failure in its result; what escapes (a crash
    of the process, an exception) loses the task, which the caller handles.
    """
    out = []
    for key, payload in points:
        start = time.perf_counter()
        result = fn(payload, *args)
        out.append((key, result, time.perf_counter() - start))
    return out


class Runner:
    """Submits tasks to one kind of executor: "serial", "pool" (owned), "dask" or any "executor".

    An owned dask cluster (``executor="dask"`` without a current client) is shut down at the
    end; the default pool is kept for the next run; a user's executor is left as it is.
    """

    def __init__(self, executor):
        self.kind, self._executor, self._owned_dask = "executor", executor, False
        if executor is None:
            self.kind = "pool"
            self._executor = _pool.default_pool()
            self.n_workers = _pool.pool_workers()
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

    def submit(self, fn, task: list, args: tuple):
        if self.kind == "serial":
            fut: cf.Future = cf.Future()
            fut.set_result(run_batch(fn, task, *args))  # a KeyboardInterrupt propagates from here
            return fut
        with interrupt_deferred():  # not inside the executor's locks
            if self.kind == "dask":
                return self._executor.submit(run_batch, fn, task, *args, pure=False)
            return self._executor.submit(run_batch, fn, task, *args)

    def wait_first(self, futures) -> set:
        """The futures that are done, waiting until at least one is."""
        if self.kind == "dask":
            import distributed

            return set(distributed.wait(list(futures), return_when="FIRST_COMPLETED").done)
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def recover(self, exc: BaseException) -> None:
        """After a task lost to ``exc``: replace the default pool if it broke (a user's executor is theirs)."""
        if self.kind == "pool":
            self._executor = _pool.replace_if_broken(self._executor, exc)

    def abort(self, futures) -> None:
        """On an interrupt or error: cancel the tasks in flight; kill the workers we own."""
        if self.kind == "pool":
            _pool.kill_default_pool()  # the running tasks die with their workers; nothing waits for them
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


class _BatchSizer:
    """Points per task, from a running mean of the measured seconds per point.

    The first tasks hold one point each (the cost is unknown); after that about
    :data:`TASK_SECONDS` of work, but never so many points that fewer than two tasks per
    worker remain (the tail of the run must still spread over all workers).
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


def execute(runner: Runner, fn, todo: list, args: tuple, on_result, on_lost, bar, *, batch: bool = True) -> None:
    """Run ``fn`` on ``todo = [(key, payload), ...]``; call ``on_result(key, result)`` for each point.

    A task that raises as a whole (its worker process died, dask gave up on it, the pool
    broke) does not say which of its points was guilty: its points are retried one per
    task; a point lost twice is run once more alone, with nothing else running, so that only
    a point that crashes its worker by itself is given up: ``on_lost(key, message)``.
    ``batch=False`` keeps one point per task (points that are long by nature: a
    continuation pass).
    """
    fresh, retry, suspects = deque(todo), deque[Any](), list[Any]()
    attempts: dict[str, int] = {}
    in_flight: dict = {}
    sizer = _BatchSizer(runner.n_workers)

    def lost(task, exc):
        runner.recover(exc)
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
                    # Serially, nothing amortises a batch: one point per task, each handed back at once.
                    n = 1 if runner.kind == "serial" or not batch else min(sizer.size(len(fresh)), len(fresh))
                    task = [fresh.popleft() for _ in range(n)]
                try:
                    in_flight[runner.submit(fn, task, args)] = task
                except Exception as exc:  # noqa: BLE001 - e.g. a broken pool: its points are retried
                    lost(task, exc)
            if not in_flight:
                continue
            for fut in runner.wait_first(in_flight):
                task = in_flight.pop(fut)
                try:
                    results = fut.result()
                except Exception as exc:  # noqa: BLE001 - the whole task failed: retried
                    lost(task, exc)
                    continue
                deliver(results)
        # The suspects, each alone: a crash now is that point's own.
        for point in suspects:
            try:
                results = runner.submit(fn, [point], args).result()
            except Exception as exc:  # noqa: BLE001
                runner.recover(exc)
                on_lost(point[0], f"task lost ({type(exc).__name__}: {exc})")
                bar.update(1)
                continue
            deliver(results)
    except BaseException:
        runner.abort(in_flight)
        raise
    runner.close()
