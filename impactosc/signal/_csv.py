"""Measured LTM records from CSV files: :func:`read_ltm_csv` and :func:`analyze_csv`.

Package-private: re-exported by :mod:`impactosc.signal`.
"""

from __future__ import annotations

import csv
import itertools
import re

import numpy as np
import pandas as pd

from .._util import validation as _v
from ._analysis import LTMAnalysis, analyze
from ._checks import check_signal

__all__ = ["TIME_UNITS", "LENGTH_UNITS", "read_ltm_csv", "analyze_csv"]

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9}


#: Delimiters the sniffer tries (a run of spaces counts as one).
DELIMITERS = ",;\t "


def _sniff(path, sep: str | None, encoding: str) -> tuple[str, bool]:
    """Delimiter (``sep`` if given) and whether a header line is present, from the first data lines.

    pandas' fast reader cannot guess either; a header is a first line with no number in it.

    Raises
    ------
    ValueError
        If the file cannot be decoded with ``encoding`` (the message names the file, the
        byte and the option to change), holds no data line, or has a single column.
    """
    try:
        with open(path, newline="", encoding=encoding) as fh:
            lines = [line for line in itertools.islice(fh, 200)
                     if line.strip() and not line.lstrip().startswith("#")]
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: cannot be decoded as {encoding!r} text (byte {exc.object[exc.start]:#04x} "
                         f"at offset {exc.start} is invalid: {exc.reason}); pass encoding= (e.g. 'latin-1') if it is "
                         "a CSV written in another encoding") from None
    if not lines:
        raise ValueError(f"{path}: cannot be read as a table of (time, displacement) columns: it holds no data line "
                         "(only blank or '#' comment lines)")
    if any("\0" in line for line in lines):
        raise ValueError(f"{path}: holds NUL bytes: a binary file, not a CSV table of (time, displacement)")
    if sep is None:
        sample = "".join(lines[:20])
        if not any(d in line.strip() for line in lines[:20] for d in DELIMITERS):
            raise ValueError(f"{path}: has a single column (no comma, semicolon, tab or space on its first data "
                             "lines); a record needs two columns, time and displacement")
        sep = csv.Sniffer().sniff(sample, delimiters=DELIMITERS).delimiter
        sep = r"\s+" if sep == " " else sep
    fields = re.split(sep, lines[0].strip()) if sep == r"\s+" else lines[0].strip().split(sep)
    numeric = pd.to_numeric(pd.Series(fields), errors="coerce").notna()
    return sep, not numeric.any()


def read_ltm_csv(path, *, time_column=0, x_column=1, time_unit: str = "s", x_unit: str = "m",
                 **read_csv_options) -> tuple[np.ndarray, np.ndarray]:
    """Read a measured LTM record ``(t, x)`` from a CSV file; returns SI arrays (s, m), checked.

    Parameters
    ----------
    path : str or path-like
        The file. The delimiter is detected from the first lines (comma, semicolon, tab,
        spaces); a header line is detected (a first row that is not numeric); lines
        starting with ``#`` are skipped.
    time_column, x_column : int or str
        Columns of time and displacement: positions, or names from the header.
    time_unit : {"s", "ms", "us"}
    x_unit : {"m", "mm", "um", "nm"}
        Units of the file's columns; the arrays returned are in s and m.
    **read_csv_options
        Passed to :func:`pandas.read_csv` (e.g. ``sep``, ``skiprows``, ``encoding``:
        default ``"utf-8"``, ``"latin-1"`` for files written by older instruments).

    Raises
    ------
    ValueError
        If the file is not text in ``encoding``, has a single column, a column is missing,
        holds a non-numeric or empty entry (the message gives the row), or the record fails
        :func:`check_signal` (non-uniform or non-monotonic time, NaN, too short).
    """
    _v.choice("time_unit", time_unit, tuple(TIME_UNITS))
    _v.choice("x_unit", x_unit, tuple(LENGTH_UNITS))
    options = {"comment": "#", "encoding": "utf-8", **read_csv_options}
    try:
        sep, has_header = _sniff(path, options.pop("sep", options.pop("delimiter", None)), options["encoding"])
        options["sep"] = sep
        options.setdefault("header", 0 if has_header else None)
        raw = pd.read_csv(path, **options)
    except (csv.Error, pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot be read as a table of (time, displacement) columns: {exc}") from None
    raw.columns = [c.strip() if isinstance(c, str) else c for c in raw.columns]
    t = _column(raw, "time_column", time_column, path) * TIME_UNITS[time_unit]
    x = _column(raw, "x_column", x_column, path) * LENGTH_UNITS[x_unit]
    t, x, _ = check_signal(t, x)
    return t, x


def _column(raw: pd.DataFrame, name: str, col, path) -> np.ndarray:
    """Column ``col`` (a header name or a position) of the table read from ``path``, as floats.

    ``name`` is the argument of :func:`read_ltm_csv` that chose it, for the messages.
    Every entry must be a number: an empty, NaN or non-numeric one is an error naming its row.
    """
    if isinstance(col, str):
        if col not in raw.columns:
            raise ValueError(f"{name}={col!r} is not a column of {path}; columns: {list(raw.columns)}")
        series = raw[col]
    else:
        col = _v.integer(name, col, minimum=0)
        if col >= raw.shape[1]:
            raise ValueError(f"{name}={col} but {path} has {raw.shape[1]} column(s)")
        series = raw.iloc[:, col]
    values = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(np.isnan(values))
    if bad.size:
        raise ValueError(f"{path}: {name} holds {bad.size} empty, NaN or non-numeric value(s), the first "
                         f"{series.iloc[bad[0]]!r} in data row {bad[0]}")
    return values


def analyze_csv(path, *, time_column=0, x_column=1, time_unit: str = "s", x_unit: str = "m",
                encoding: str = "utf-8", **analyze_options) -> LTMAnalysis:
    """Read a measured LTM CSV (:func:`read_ltm_csv`) and run :func:`analyze` on it: one call, then ``.plot()``."""
    t, x = read_ltm_csv(path, time_column=time_column, x_column=x_column, time_unit=time_unit, x_unit=x_unit,
                        encoding=encoding)
    return analyze(t, x, **analyze_options)
