"""The command line: ``impactosc demo | simulate | sweep | bifurcation | orbit | onset | chart | paper``.

Also ``python -m impactosc``. One private module per subcommand; ``impactosc/cli/_main.py`` lists them
and says how to add one.
"""

from ._main import build_parser, main

__all__ = ["main", "build_parser"]
