"""Sphinx extension: drop the few listed warnings that come from known docstring defects.

The build runs with ``-W``: any warning fails it. A defect in a docstring of a module that
is being edited elsewhere is listed in ``conf.py`` as ``known_warnings``, a list of
``(location regex, message regex)`` pairs, each with a comment; a warning is dropped only
when both match, so nothing broader is hidden. Entries that matched nothing are reported
at the end of the build (as information, not a warning), so that a fixed docstring's entry
can be removed.
"""

from __future__ import annotations

import logging
import re

from sphinx.application import Sphinx
from sphinx.util import logging as sphinx_logging


def _location(app: Sphinx, record: logging.LogRecord) -> str:
    """The warning's location as Sphinx prints it: ``path:line`` (a document's source path)."""
    location = getattr(record, "location", None)
    if location is None:
        return ""
    if isinstance(location, str):
        return location
    if isinstance(location, tuple):
        docname, line = (location + (None,))[:2]
        try:
            path = str(app.env.doc2path(docname))
        except Exception:  # no environment yet, or not a document name
            path = str(docname)
        return f"{path}:{line}" if line is not None else path
    return sphinx_logging.get_node_location(location) or ""


class KnownWarningFilter(logging.Filter):
    def __init__(self, app: Sphinx) -> None:
        super().__init__()
        self.app = app
        self.used: set[int] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING:
            return True
        try:
            message = record.getMessage()
        except (TypeError, ValueError):
            message = str(record.msg)
        location = _location(self.app, record)
        for i, (where, what) in enumerate(self.app.config.known_warnings):
            if re.search(where, location) and re.search(what, message):
                self.used.add(i)
                return False
        return True


def _report_unused(app: Sphinx, exception: Exception | None) -> None:
    if exception is not None:
        return
    used = app._known_warning_filter.used  # type: ignore[attr-defined]
    for i, entry in enumerate(app.config.known_warnings):
        if i not in used:
            sphinx_logging.getLogger(__name__).info(f"known_warnings entry matched nothing (remove it?): {entry!r}")


def setup(app: Sphinx) -> dict:
    app.add_config_value("known_warnings", [], "env", types=[list])
    known = KnownWarningFilter(app)
    app._known_warning_filter = known  # type: ignore[attr-defined]
    for handler in logging.getLogger(sphinx_logging.NAMESPACE).handlers:
        if isinstance(handler, sphinx_logging.WarningStreamHandler):
            handler.filters.insert(0, known)  # before the filters that count warnings or raise
    app.connect("build-finished", _report_unused)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
