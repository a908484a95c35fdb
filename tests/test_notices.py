"""Hidden waits get a one-line notice; optional dependencies get one install hint (issue 22 items 2 and 6)."""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import threading

import pytest

from impactosc._util import notice as notice_module
from impactosc._util.jit import INSTALL_HINT
from impactosc._util.notice import notice_if_slow

# A fresh interpreter's first run on the default backend: numba compiles the transition rule
# (or loads it from its cache); the notice goes to stderr through logging's last-resort handler.
FIRST_RUN = "import impactosc as io; io.simulate(io.Oscillator(0.5, 1.1, 0.01, 1e4), 10.0)"


@pytest.fixture()
def fresh_notices(monkeypatch):
    monkeypatch.setattr(notice_module, "_given", set())


def test_a_slow_block_gets_its_notice_while_it_runs(fresh_notices):
    said = threading.Event()
    messages = []

    class Catch(logging.Handler):
        def emit(self, record):
            messages.append(record.getMessage())
            said.set()

    catch = Catch(level=logging.WARNING)
    notice_module.LOGGER.addHandler(catch)
    try:
        with notice_if_slow("test-slow", "still compiling", after=0.01):
            assert said.wait(timeout=30.0)  # the block is still running when the notice comes
    finally:
        notice_module.LOGGER.removeHandler(catch)
    assert messages == ["still compiling"]


def test_a_fast_block_says_nothing_and_a_notice_comes_once(caplog, fresh_notices):
    with caplog.at_level(logging.WARNING, logger="impactosc"):
        with notice_if_slow("test-fast", "never said", after=60.0):
            pass
        assert notice_module.notice("test-once", "said once")
        assert not notice_module.notice("test-once", "said once")
    said = [r.getMessage() for r in caplog.records]
    assert "never said" not in said and said.count("said once") == 1


def _first_run(cache_dir) -> str:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir))
    proc = subprocess.run([sys.executable, "-c", FIRST_RUN], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc.stderr


@pytest.mark.slow
def test_numba_compile_notice_on_a_cold_cache_only(tmp_path):
    pytest.importorskip("numba")
    cold = _first_run(tmp_path)
    assert "impactosc: numba is compiling" in cold and "cache" in cold
    assert len([line for line in cold.splitlines() if "numba is compiling" in line]) == 1  # once per process
    warm = _first_run(tmp_path)  # same cache directory: numba loads, compiles nothing, says nothing
    assert "numba is compiling" not in warm, warm


def test_the_numba_hints_quote_one_install_command(monkeypatch):
    from impactosc import Oscillator
    from impactosc.backends import exact, rk4

    monkeypatch.setattr(rk4, "_HAVE_NUMBA", False)
    monkeypatch.setattr(rk4, "_warned_slow", False)
    with pytest.warns(RuntimeWarning) as caught:
        rk4._warn_if_slow()
    assert INSTALL_HINT in str(caught[0].message)
    monkeypatch.setattr(exact, "HAVE_NUMBA", False)
    with pytest.raises(ValueError, match="compiled=True needs numba") as err:
        exact.run(Oscillator(0.5, 1.1, 0.01, 1e4), 1.0, 0.95, 0.0, record="stats", max_events=100, compiled=True)
    assert INSTALL_HINT in str(err.value)




def test_dynamics_plots_without_matplotlib_give_the_install_hint(monkeypatch):
    from impactosc.dynamics import LyapunovResult, PeriodicOrbit, Section, plot_bifurcation, plot_onset_chart

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib... raises ImportError
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)
    # matplotlib is the first thing each of them needs: no result object has to be built
    for plot in (PeriodicOrbit.plot, Section.plot, LyapunovResult.plot, plot_bifurcation, plot_onset_chart):
        with pytest.raises(ImportError, match=r"plotting needs matplotlib: pip install 'impactosc\[plot\]'"):
            plot(None)


def test_a_heyoka_compile_gets_its_notice_once(fresh_notices):
    """The built-in backend's integrator is the hybrid loop's: its compile is said once, with the tolerance."""
    import impactosc as io
    from impactosc.backends.heyoka import compiled_integrator

    messages = []

    class Catch(logging.Handler):
        def emit(self, record):
            messages.append(record.getMessage())

    catch = Catch(level=logging.WARNING)
    notice_module.LOGGER.addHandler(catch)
    tol = 1.2345e-13  # a tolerance nothing else compiles: not in the cache
    try:
        first = compiled_integrator(io.Oscillator(0.5, 1.1, 0.01, 1e4), tol)
        again = compiled_integrator(io.Oscillator(0.3, 0.7, 0.02, 1e3), tol)  # the same structure: no compile
    finally:
        notice_module.LOGGER.removeHandler(catch)
    assert again is first
    assert len(messages) == 1 and "heyoka is compiling" in messages[0] and "1.2345e-13" in messages[0]
