"""The command line: ``impactosc demo | simulate | sweep | reproduce ...`` (``python -m impactosc``)."""

from ._main import main

__all__ = ["main"]
