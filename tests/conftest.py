import os
import signal

import pytest
from hypothesis import HealthCheck, settings

# "ci" keeps `make test` within a few minutes; "dev" digs deeper when run by hand.
settings.register_profile("ci", max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("dev", max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture()
def sigint_raises():
    """SIGINT raises KeyboardInterrupt in this process and in the processes it starts, for one test.

    A test about Ctrl-C must not depend on how pytest was started: a background job of a
    non-interactive shell, ``nohup`` and some CI runners start it with SIGINT ignored; then
    ``_thread.interrupt_main`` and ``pthread_kill(SIGINT)`` do nothing, and a child
    process inherits the ignored signal (a handled one is reset to the default on exec,
    which Python turns into ``KeyboardInterrupt``). The previous disposition comes back after.
    """
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


#: Whole test modules in the ``slow`` group (``make test-fast`` leaves them out; ``make test``
#: runs them), with why. Single slow tests elsewhere carry ``@pytest.mark.slow`` themselves.
SLOW_MODULES = {
    "test_docs.py": "builds the docs site, executing every notebook",
    "test_notebooks.py": "executes the notebooks",
    "test_sweep_processes.py": "process pools in subprocesses, interrupted and killed",
    "test_runner_processes.py": "process pools in subprocesses, killed",
    "test_benchmarks_smoke.py": "runs the benchmark scripts",
    "test_dynamics_benchmark.py": "runs the dynamics benchmark script",
    "test_packaging.py": "builds the wheel and sdist, installs into a fresh venv, runs mypy",
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.path.name in SLOW_MODULES:
            item.add_marker(pytest.mark.slow)
