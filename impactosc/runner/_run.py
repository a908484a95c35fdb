"""Run many independent points: the one entry point of the runner.

:func:`run_points` takes a module-level function ``fn(payload, *args) -> result`` and the
points ``[(key, payload), ...]``, runs them on an executor (see :mod:`._exec`) with a tqdm
progress bar, hands every result back through ``on_result(key, result)`` as it arrives (the
caller saves it to its store there), and raises if every point was lost.

Small jobs run here. With the default executor a caller may let the first points run in
this process (``try_here_first=True``): after each, if the points left, at the measured
cost of the last one, would take longer here than on the pool *including the pool's start*
(``n_left * s * (1 - 1/w) > POOL_START_SECONDS`` with ``w = min(workers, n_left)`` and
``POOL_START_SECONDS = 0`` when the pool is already running), the rest goes to the pool;
otherwise it runs here too. A single task (one continuation pass) therefore always runs
here, and so does a job on one CPU. ``sweep`` does not use this rule: its points can take
anything from a millisecond to minutes, and its default pool isolates a point that crashes.
"""

from __future__ import annotations

import time

from . import _pool
from ._exec import Runner, check_executor, execute

#: What starting the default pool costs before its first result (fresh interpreters, the
#: imports, a heyoka integrator compiled in every worker): about 2 s on a 2-core machine.
POOL_START_SECONDS = 2.0


def run_points(fn, todo: list, args: tuple = (), *, executor=None, on_result, on_lost, progress: bool = True,
               desc: str = "", unit: str = "point", initial: int = 0, what: str = "run", batch: bool = True,
               try_here_first: bool = False) -> None:
    """Run ``fn(payload, *args)`` for every ``(key, payload)`` of ``todo`` on ``executor``.

    Parameters
    ----------
    fn : callable
        A module-level function (it pickles by reference for a process pool or dask) that
        records the failure of its point in its result instead of raising.
    todo : list of (str, object)
        The points still to run; the keys are unique.
    args : tuple
        Further arguments of ``fn``, the same for every point.
    executor : None, "serial", "dask", concurrent.futures.Executor or dask.distributed.Client
        See :func:`check_executor`. None: the reusable local pool.
    on_result : callable
        ``on_result(key, result)``, called in this process for every finished point.
    on_lost : callable
        ``on_lost(key, message)`` for a point whose task was lost twice and again alone.
    progress, desc, unit, initial
        The tqdm bar: shown or not, its label, its unit, the points already done (a resumed
        store); its total is ``initial + len(todo)``.
    what : str
        The caller's name, for the error message.
    batch : bool
        Let cheap points share a task (False: one point per task).
    try_here_first : bool
        With the default executor, run the first points here while the job is small (see the
        module docstring).

    Raises
    ------
    RuntimeError
        Every point of ``todo`` was lost (the workers could not start or kept crashing).
    KeyboardInterrupt
        At once on Ctrl-C: the tasks in flight are cancelled, the default pool's workers
        killed; every result handed back before stays with the caller.
    """
    check_executor(executor)
    lost: list[str] = []

    def give_up(key, message):
        lost.append(message)
        on_lost(key, message)

    with _progress_bar(progress, total=initial + len(todo), initial=initial, desc=desc, unit=unit) as bar:
        rest = list(todo)
        if try_here_first and executor is None:
            rest = _run_here_while_small(fn, rest, args, on_result, bar)
        if rest:
            execute(Runner(executor), fn, rest, args, on_result, give_up, bar, batch=batch)
    if todo and len(lost) == len(todo):
        raise RuntimeError(f"{what}: all {len(todo)} points run were lost: their tasks failed as a whole (the "
                           f"worker processes crashed, were killed or could not start; or the executor is "
                           f"broken). First: {lost[0]}")


class _NoBar:
    """The progress bar when none is shown: tqdm is not even imported (in a notebook kernel without
    ipywidgets, importing ``tqdm.auto`` alone prints a ``TqdmWarning``)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None

    def update(self, n: int = 1) -> None:
        return None


def _progress_bar(progress: bool, **settings):
    """A tqdm bar with ``settings`` when ``progress``, else a bar that draws nothing."""
    if not progress:
        return _NoBar()
    from tqdm.auto import tqdm

    return tqdm(**settings)


def _run_here_while_small(fn, todo: list, args: tuple, on_result, bar) -> list:
    """Run points here while the rest is too small for the pool to pay for its start; return the rest."""
    start_cost = 0.0 if _pool.pool_alive() else POOL_START_SECONDS
    workers = _pool.pool_workers()
    for done, (key, payload) in enumerate(todo, start=1):
        start = time.perf_counter()
        result = fn(payload, *args)
        seconds = time.perf_counter() - start
        on_result(key, result)
        bar.update(1)
        n_left = len(todo) - done
        if n_left and n_left * seconds * (1 - 1 / min(workers, n_left)) > start_cost:
            return todo[done:]
    return []
