"""The package's shape: a fast, lazy import and every public name where it was.

The layer contract itself (imports go one way, no cycles) is checked by import-linter in
``make lint`` (``pyproject.toml [tool.importlinter]``); these tests check what it cannot:
which modules an import loads, and that the public names survived the move into folders.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("numba", "heyoka", "xarray", "pandas", "matplotlib", "scipy.signal", "dask", "loky", "tqdm")


def _loaded_after(code: str) -> list[str]:
    probe = code + f"\nimport json, sys\nprint(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # fresh interpreters
def test_import_and_a_model_load_no_heavy_dependency():
    assert _loaded_after("import impactosc") == []
    model = "import impactosc as io; io.Oscillator(0.5, 1.1, 0.01, 1e4); io.TapeDrive().oscillator()"
    assert _loaded_after(model) == []


@pytest.mark.slow  # fresh interpreters
def test_a_run_loads_no_table_or_plot_library():
    # a Solution builds its pandas / xarray views on demand; a run itself needs neither
    run = "import impactosc as io; io.simulate(io.Oscillator(0.5, 1.1, 0.01, 1e4), 50.0, 0.95, 0.0, backend='scipy')"
    assert not {"pandas", "xarray", "matplotlib", "dask"} & set(_loaded_after(run))


@pytest.mark.slow  # fresh interpreters
def test_the_compiled_rule_is_loaded_by_the_first_run_not_by_the_model():
    # a force of the model is numpy (eq. 3's value); the compiled rule comes with the first run
    out = subprocess.run([sys.executable, "-c",
                          "import impactosc as io, sys\n"
                          "o = io.Oscillator(0.5, 1.1, 0.01, 1e4)\n"
                          "f = o.net_force(0.0, 1.1)\n"
                          "before = 'impactosc.model._rule' in sys.modules\n"
                          "io.simulate(o, 1.0, 0.95, 0.0, backend='scipy', record='stats')\n"
                          "print(before, 'impactosc.model._rule' in sys.modules, f)"],
                         capture_output=True, text=True, check=True)
    before, after, value = out.stdout.split()
    assert (before, after) == ("False", "True")
    assert float(value) == pytest.approx(0.5 - 1.1 - 1e4 * 0.1)


@pytest.mark.parametrize("module, names", [
    ("impactosc", ["Oscillator", "TapeDrive", "simulate", "sweep", "load_sweep", "Solution", "Mode", "EVENT_KINDS",
                   "dynamics", "signal", "__version__"]),
    ("impactosc.dynamics", ["periodic_orbit", "monodromy", "bifurcation_diagram", "contact_onset", "onset_chart",
                            "lyapunov_exponent", "stroboscopic_section", "den_hartog_onset"]),
    ("impactosc.signal", ["analyze", "analyze_csv", "spectrogram", "highpass", "from_solution"]),
])
def test_public_names_survive_the_move(module, names):
    import importlib

    mod = importlib.import_module(module)
    missing = [n for n in names if not hasattr(mod, n)]
    assert not missing, f"{module} lost {missing}"


def test_public_functions_are_not_shadowed_by_submodules():
    # importing every subpackage must leave impactosc.simulate / .sweep the functions
    import impactosc
    import impactosc.backends
    import impactosc.sweeps  # noqa: F401

    assert callable(impactosc.simulate) and callable(impactosc.sweep)
    assert impactosc.simulate.__module__ == "impactosc.backends._simulate"


def test_an_unknown_attribute_is_an_attribute_error():
    import impactosc

    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        impactosc.simulat  # noqa: B018
