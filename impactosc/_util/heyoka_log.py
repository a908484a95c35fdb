"""heyoka's log on ``stderr``: its warnings must not corrupt tables and piped output on ``stdout``.

heyoka logs through spdlog to a sink on C's ``stdout``. The sink takes the ``FILE *`` that
``stdout`` holds when heyoka creates its logger, on the first integrator built in the
process: :func:`log_on_stderr` makes that build with ``stdout`` holding ``stderr``.
"""

from __future__ import annotations

import threading
from contextlib import contextmanager

__all__ = ["log_on_stderr", "root_finding_muted"]


def _log_to_stderr(build):
    """Call ``build()`` with C's ``stdout`` pointing at ``stderr``, so heyoka's logger goes there.

    Python's own ``sys.stdout`` is not a C ``FILE *`` and is unaffected. If heyoka's logger
    already exists (created by an earlier heyoka call outside impactosc), it keeps stdout.
    """
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        for out_name, err_name in (("stdout", "stderr"), ("__stdoutp", "__stderrp")):  # glibc/musl, macOS
            try:
                out = ctypes.c_void_p.in_dll(libc, out_name)
                err = ctypes.c_void_p.in_dll(libc, err_name)
                break
            except ValueError:
                continue
        else:
            return build()
    except (OSError, TypeError, AttributeError):  # no C library to reach (e.g. Windows): leave it
        return build()
    saved = out.value
    out.value = err.value
    try:
        return build()
    finally:
        out.value = saved


_first_build = threading.Lock()
_logger_routed = False


def log_on_stderr(build):
    """``build()``, with heyoka's logger created on ``stderr`` first if this process has none yet.

    heyoka creates its logger at its first use (any compile logs at debug level), so whatever
    impactosc compiles first (an integrator, a compiled function of a user system's guards)
    goes through here. The logger is created by setting its level (to heyoka's default,
    warning) with C's ``stdout`` on ``stderr`` (:func:`_log_to_stderr`); later calls cost a
    flag check.
    """
    global _logger_routed
    if not _logger_routed:
        with _first_build:
            if not _logger_routed:
                try:
                    import heyoka

                    _log_to_stderr(heyoka.set_logger_level_warning)
                finally:
                    _logger_routed = True
    return build()


_muted = 0
_muted_lock = threading.Lock()


@contextmanager
def root_finding_muted():
    """heyoka's log at level error while the block runs (in any thread), then at warning again.

    For the hybrid loop's integration only. heyoka warns "polynomial root finding during event
    detection failed due to too many iterations" when it gives up isolating an event's roots on a
    step, and then skips that event on that step. The loop checks at every event and at the run's
    end for a guard that crossed zero without its event and applies it at its first root (the
    lost-crossing check of ``backends/_hybrid_heyoka``), so the warning is handled and says nothing
    a user can act on; a tape drive's creep printed 45 of them in the demo. The level is the
    process's (heyoka has one logger), set back to heyoka's default when the last block ends.
    """
    global _muted
    import heyoka

    with _muted_lock:
        if _muted == 0:
            heyoka.set_logger_level_error()
        _muted += 1
    try:
        yield
    finally:
        with _muted_lock:
            _muted -= 1
            if _muted == 0:
                heyoka.set_logger_level_warning()
