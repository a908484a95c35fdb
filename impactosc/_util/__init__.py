"""Helpers every layer may use: argument checks, the numba shim, root finding, optional imports."""
