"""Sparsity-pattern features of ``W`` for ``solver="auto"``'s stage order (numba, ``cache=True``).

:func:`pattern_redundancy` is the compiled twin of the NumPy reference in
:func:`socp_cd.solvers.auto.contact_redundancy` (the same keys, the same share;
``tests/test_auto.py`` holds the two equal).  On a 300-contact problem the reference costs
~50 µs of small-array calls, this kernel a few: the feature is read on every call of
``auto`` on a large 3D local problem, some of which are solved in 0.1 ms.
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: the odd multiplier that mixes a contact's four signature numbers into one key (mod 2^64)
KEY_MULTIPLIER = 0x9E3779B97F4A7C15


@njit(cache=True)
def pattern_redundancy(indptr, indices, nc, dim):
    """Share of the ``nc`` contacts whose coupling signature equals another contact's.

    Parameters
    ----------
    indptr, indices : ndarray
        ``W`` in CSR form (``m = nc * dim`` rows; int32 or int64).
    nc : int
        Number of contacts.
    dim : int
        Unknowns per contact (2 or 3).

    Returns
    -------
    float
        The share in ``[0, 1]``: a contact's signature is the number of stored entries of its
        first row and that row's first, middle and last column, mixed into one key; a
        contact whose row is full (coupled to every contact) is not counted; 0 when
        ``nc < 2`` or a contact's first row is empty.
    """
    if nc < 2:
        return 0.0
    full = nc * dim
    mult = np.uint64(KEY_MULTIPLIER)
    keys = np.empty(nc, dtype=np.uint64)
    n = 0
    for i in range(nc):
        s = indptr[i * dim]
        e = indptr[i * dim + 1]
        length = e - s
        if length <= 0:
            return 0.0
        if length >= full:
            continue                    # a full row: not a pattern of its bodies
        k = np.uint64(length)
        k = k * mult + np.uint64(indices[s])
        k = k * mult + np.uint64(indices[(s + e) // 2])
        k = k * mult + np.uint64(indices[e - 1])
        keys[n] = k
        n += 1
    if n < 2:
        return 0.0
    keys = np.sort(keys[:n])
    repeated = 0
    run = 1
    for j in range(1, n + 1):
        if j < n and keys[j] == keys[j - 1]:
            run += 1
            continue
        if run > 1:
            repeated += run
        run = 1
    return repeated / nc


__all__ = ["pattern_redundancy", "KEY_MULTIPLIER"]
