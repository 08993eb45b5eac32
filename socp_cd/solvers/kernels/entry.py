"""Calling a compiled kernel without numba's per-call type dispatch.

A numba dispatcher finds the types of its arguments on every call and picks
the compiled version that matches (~15 ns an argument: 0.4 µs of a
24-argument kernel, 5 % of a one-contact :func:`socp_cd.solve`).  A caller
whose arguments always have the same types can call that version's entry
point instead, which only converts the arguments (numba's "unboxing").

The entry point checks nothing: an array of another dtype, number of
dimensions or layout than the signature's is read as if it were of the
signature's.  Use it only where the types are guaranteed (arrays the problem
classes validate, scalars the caller makes), and keep the dispatcher for
everything else.
"""
from __future__ import annotations

from numba import from_dtype, types

#: numba's type of a C-contiguous float64 vector
F64_VECTOR = types.Array(types.float64, 1, "C")


def index_vector(dtype):
    """numba's type of a C-contiguous integer vector of NumPy ``dtype`` (CSR ``indptr``/``indices``)."""
    return types.Array(from_dtype(dtype), 1, "C")


def entry_point(dispatcher, signature):
    """The entry point of ``dispatcher`` compiled for ``signature`` (a sequence of numba types),
    loaded from numba's cache or compiled on first use (``Dispatcher.compile``)."""
    return dispatcher.compile(tuple(signature))


__all__ = ["entry_point", "index_vector", "F64_VECTOR"]
