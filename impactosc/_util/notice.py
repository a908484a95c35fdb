"""One-line notices of a wait the user would not otherwise see coming (a compile).

The notices go to the ``impactosc`` logger at level WARNING, once per process and kind.
Why logging and WARNING: without any logging configuration Python's last-resort handler
prints WARNING records to stderr as the bare message, so a user on a fresh install sees
the line before the wait; a user who does not want it sets
``logging.getLogger("impactosc").setLevel(logging.ERROR)`` (or routes it with their own
handlers), and pytest captures it per test. :mod:`warnings` was the other candidate: it
prints two lines (a file position and the source line) and ``-W error`` would turn a
compile into an exception.

Two ways to decide that a wait is coming:

* :func:`notice` says it now: numba's compile event fires only on a cache miss
  (:mod:`impactosc._util.jit`), which is always a long wait.
* :func:`notice_if_slow` says it only if a block is still running after ``after`` seconds,
  from a timer thread (heyoka compiles with the GIL released; its usual integrators take
  0.1-1 s, a tight tolerance or a large member of the family tens of seconds).
"""

from __future__ import annotations

import logging
import threading
from contextlib import contextmanager

__all__ = ["LOGGER", "notice", "notice_if_slow"]

#: The logger of every notice: ``logging.getLogger("impactosc")``.
LOGGER = logging.getLogger("impactosc")

_given: set[str] = set()
_lock = threading.Lock()


def notice(kind: str, message: str) -> bool:
    """Log ``message`` (one line) at WARNING on :data:`LOGGER`, once per process and ``kind``.

    Returns True when it was logged now, False when ``kind`` was noticed before.
    """
    with _lock:
        if kind in _given:
            return False
        _given.add(kind)
    LOGGER.warning(message)
    return True


@contextmanager
def notice_if_slow(kind: str, message: str, after: float = 2.0):
    """Run the block; if it is still running after ``after`` seconds, :func:`notice` ``message``.

    The timer is a daemon thread cancelled when the block ends, so a fast block costs a
    thread start and says nothing. The block must release the GIL while it waits (a C
    extension's compile does) for the notice to appear during the wait.
    """
    timer = threading.Timer(after, notice, args=(kind, message))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
