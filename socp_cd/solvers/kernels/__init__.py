"""Numba kernels of the solvers (one module per method)."""
