"""Running many independent points: one machinery for sweeps, bifurcation diagrams and charts.

- :func:`run_points`: a module-level function over ``[(key, payload), ...]`` on an executor
  (the reusable local process pool by default, ``"serial"``, any
  :class:`concurrent.futures.Executor`, a ``dask.distributed.Client`` or ``"dask"``), in
  batches sized from the measured cost of a point, with a tqdm progress bar; Ctrl-C stops at
  once and keeps every point handed back; a run that loses every point raises.
- :class:`PointStore`: the resumable store, one verified file per point (key, inputs,
  settings and checksum checked on load; an unusable file is quarantined with a warning
  naming it and computed again). Each caller brings its own file format (a :class:`Codec`)
  and store format version.

The pool's workers do not re-import the caller's ``__main__`` (a script without an
``if __name__ == "__main__":`` guard works) and exit when the process that started them
dies, even by SIGKILL.
"""

from ._exec import check_executor
from ._pool import kill_default_pool
from ._run import POOL_START_SECONDS, run_points
from ._store import (
    Codec,
    OtherFormat,
    PointStore,
    atomic_write,
    check_store_path,
    checksum,
    interrupt_deferred,
    point_key,
)

__all__ = ["run_points", "check_executor", "kill_default_pool", "POOL_START_SECONDS", "PointStore", "Codec",
           "OtherFormat", "point_key", "checksum", "check_store_path", "interrupt_deferred", "atomic_write"]
