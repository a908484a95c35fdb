"""Command line: ``impactosc demo | simulate | sweep | path | bifurcation | orbit | continue | onset | chart | paper``.

Also ``python -m impactosc``. Errors are reported as one line (``impactosc: error: ...``)
with exit status 2; output paths (and matplotlib, for a figure) are checked before anything
is computed. Exit status 1: the run finished but failed (a simulation's status, a sweep's
failed points, an orbit that did not converge, no onset found) or its output went to a
closed pipe (``impactosc demo | head``: the rest is dropped quietly); 130: interrupted (Ctrl-C).

Adding a subcommand (as ``continue`` was, on :mod:`impactosc.dynamics.continuation`): write a
private module ``impactosc/cli/_<name>.py`` with ``add_parser(sub)``, which adds its parser
to the subparsers ``sub`` (:func:`._common.add_model_options` gives it the model options)
and calls ``set_defaults(handler=run)`` with ``run(args) -> int`` the exit status; then add
the module to :data:`SUBCOMMANDS`. ``run`` raises ``ValueError`` for bad input (one line,
status 2) and checks its output paths before computing.
"""

from __future__ import annotations

import os
import sys

from . import _bifurcation, _chart, _continue, _demo, _onset, _orbit, _paper, _path, _simulate, _sweep
from ._common import Parser, check_output_dir, check_output_file

__all__ = ["main", "build_parser", "SUBCOMMANDS", "check_output_file", "check_output_dir"]

#: The subcommand modules, in the order of ``impactosc --help``.
SUBCOMMANDS = (_demo, _simulate, _sweep, _path, _bifurcation, _orbit, _continue, _onset, _chart, _paper)


def build_parser() -> Parser:
    """The ``argparse`` parser of ``impactosc`` and of every subcommand in ``SUBCOMMANDS``."""
    from .._version import __version__

    parser = Parser(prog="impactosc", description="Event-driven tape-edge / flange impact oscillator.")
    parser.add_argument("--version", action="version", version=f"impactosc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in SUBCOMMANDS:
        module.add_parser(sub)
    return parser


def _drop_stdout() -> None:
    """After a broken pipe: point stdout at devnull, so the interpreter's last flush does not fail too.

    The standard recipe of https://docs.python.org/3/library/signal.html#note-on-sigpipe.
    """
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # no file descriptor behind sys.stdout (captured)
        pass


def main(argv=None) -> int:
    """Run ``impactosc`` with the arguments ``argv`` (default: the command line's); the exit status."""
    args = build_parser().parse_args(argv)
    try:
        status = args.handler(args)
        sys.stdout.flush()  # a closed pipe is found here, not in the interpreter's exit
        return status
    except BrokenPipeError:  # the reader (head, less) has gone: not an error of ours
        _drop_stdout()
        return 1
    except (ValueError, TypeError, ImportError, OSError) as exc:
        print(f"impactosc: error: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # a run that lost every point: the run itself failed
        print(f"impactosc: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        kept = " (the points finished so far are in --store)" if getattr(args, "store", None) else ""
        print(f"impactosc: interrupted{kept}", file=sys.stderr)
        return 130
