"""``python -m impactosc``: the command line (:mod:`impactosc.cli`)."""

from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
