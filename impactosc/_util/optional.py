"""Optional dependencies, imported where they are first needed, with an install hint."""

from __future__ import annotations

__all__ = ["require_matplotlib"]


def require_matplotlib():
    """Import pyplot, or fail with an install hint.

    The backend is left alone: headless, matplotlib falls back to Agg by itself, and forcing
    Agg here turned off inline figures in every later notebook cell.
    """
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("plotting needs matplotlib: pip install 'impactosc[plot]'") from exc
    return plt
