"""The topics of the API reference (read by ``conf.py`` and by tests/test_docs.py).

Every public module of ``impactosc`` (no part of its dotted name starts with ``_``) is in
exactly one topic's ``modules`` or in ``INTERNAL``, or below one that is: a new module of a
documented subpackage takes its parent's topic. A new subpackage of ``impactosc`` itself in
neither stops the build (``_ext/apipages.py``), so it cannot be left out of the reference
silently.
``pending`` lists ``fnmatch`` patterns of modules that are documented once they exist. A
``blurb`` is reStructuredText.
"""

from __future__ import annotations

TOPICS = [
    {"title": "Simulation",
     "blurb": "A member of the model family (:class:`~impactosc.Oscillator`, or :class:`~impactosc.TapeDrive` "
              "in SI units), one run of it (:func:`~impactosc.simulate`) and what the run found "
              "(:class:`~impactosc.Solution`: events, impacts, averages, dense output); your own piecewise-smooth "
              "system of any dimension (:class:`~impactosc.HybridSystem`: modes, guards, resets, "
              ":func:`~impactosc.stick_slip`), run by the same :func:`~impactosc.simulate`.",
     "modules": ["impactosc", "impactosc.model", "impactosc.results"]},
    {"title": "Backends",
     "blurb": "How a run is integrated: ``backend=`` of :func:`~impactosc.simulate`. heyoka (the default), scipy (the "
              "cross-check), the closed form (ground truth, compiled) and the paper's fixed-step RK4.",
     "modules": ["impactosc.backends", "impactosc.backends.heyoka", "impactosc.backends.scipy",
                 "impactosc.backends.exact", "impactosc.backends.rk4"]},
    {"title": "Sweeps",
     "blurb": ":func:`~impactosc.sweep`: one run per point of a parameter grid of the tape drive, on a "
              "process pool, any executor or a dask cluster, into an xarray Dataset; stored and resumable "
              "(:func:`~impactosc.load_sweep`).",
     "modules": ["impactosc.sweeps"]},
    {"title": "Dynamics toolkit",
     "blurb": "Poincare sections, periodic orbits by shooting with their Floquet multipliers, saltation "
              "matrices, Lyapunov exponents, the contact-onset boundary and design charts, and the closed "
              "forms they are checked against; the map of your own system and its periodic orbits "
              "(:class:`~impactosc.dynamics.HybridMap`, :func:`~impactosc.dynamics.periodic_orbit_of`).",
     "modules": ["impactosc.dynamics", "impactosc.dynamics.poincare", "impactosc.dynamics.shooting",
                 "impactosc.dynamics.saltation", "impactosc.dynamics.flow", "impactosc.dynamics.lyapunov",
                 "impactosc.dynamics.onset", "impactosc.dynamics.chart", "impactosc.dynamics.closed_form"]},
    {"title": "Continuation and bifurcations",
     "blurb": "Brute-force bifurcation diagrams (the stroboscopic section over one parameter, forward and "
              "backward) and the continuation of periodic orbits along a parameter with their special points.",
     "modules": ["impactosc.dynamics.bifurcation"],
     "pending": ["impactosc.dynamics.continuation", "impactosc.dynamics.continuation.*"]},
    {"title": "Signal analysis",
     "blurb": "Lateral tape motion as the paper's Fig. 3 measures it: filters, spectra, bursts and their "
              "correlation with the simulated impacts.",
     "modules": ["impactosc.signal"]},
    {"title": "Paper reproduction",
     "blurb": "The paper's Fig. 6-8 recomputed with located events, its RK4 baseline beside them, and the "
              "report (`impactosc paper`).",
     "modules": ["impactosc.paper"]},
    {"title": "Command line",
     "blurb": "``impactosc <subcommand>`` (also ``python -m impactosc``): every subcommand and its options "
              "are on the :doc:`command-line page <cli>`.",
     "modules": ["impactosc.cli"],
     "pages": ["cli"]},
]
# Internals (architecture.md describes them): the driver loop and its constants, the runner
# behind every many-point tool, the tangent recorder of the dynamics toolkit.
INTERNAL = ["impactosc.engine", "impactosc.runner", "impactosc.dynamics.tangent"]
