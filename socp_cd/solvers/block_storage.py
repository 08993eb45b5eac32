"""Block-sparse row storage of the Delassus operator ``W`` for contact-wise sweeps.

NSGS visits one contact ``i`` at a time and needs, for that contact, the
``dim x dim`` diagonal block ``W_ii`` and the *local free velocity*
``b_i = q_i + sum_{j != i} W_ij r_j`` (the velocity contact ``i`` would see if
its own impulse were zero).  Both come from the block row ``i`` of ``W``; this
module stores ``W`` as a CSR matrix of ``dim x dim`` blocks (BSR), built from
the scipy CSR arrays by a compiled two-pass kernel (no Python loop over contacts).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit


@dataclass(frozen=True)
class BlockCSR:
    """``W`` as a CSR matrix of ``dim x dim`` blocks.

    Attributes
    ----------
    dim : int
        Block size (contact dimension, 2 or 3).
    n_contacts : int
        Number of block rows (= block columns).
    indptr : ndarray of int64, shape (n_contacts + 1,)
        Block row ``i`` holds the blocks ``indptr[i]:indptr[i+1]``.
    indices : ndarray of int64, shape (n_blocks,)
        Block column of each stored block.
    blocks : ndarray of float64, shape (n_blocks, dim, dim)
        The block values, C-contiguous.
    diag_pos : ndarray of int64, shape (n_contacts,)
        Position of ``W_ii`` in ``blocks``, ``-1`` when the diagonal block is
        not stored (structurally zero).
    diag : ndarray of float64, shape (n_contacts, dim, dim)
        The diagonal blocks (zeros where not stored).
    """

    dim: int
    n_contacts: int
    indptr: np.ndarray
    indices: np.ndarray
    blocks: np.ndarray
    diag_pos: np.ndarray
    diag: np.ndarray

    @property
    def n_blocks(self) -> int:
        """Number of stored blocks."""
        return int(self.indices.shape[0])


@njit(cache=True)
def csr_to_bsr(indptr, indices, data, dim, nc):
    """The arrays of :class:`BlockCSR` (``indptr, indices, blocks, diag_pos, diag``) from CSR.

    Two passes over the CSR entries; a marker per block column, no sort.  The block column
    of an entry is looked up (``block_of``), not divided out: an integer division by a
    run-time ``dim`` costs more than the rest of the entry's work.
    """
    # the integer arrays in one allocation (block_of, marker, pos, and the outputs bptr,
    # diag_pos as views of it): a one-contact call of the compiled route runs this, and each
    # allocation costs ~20 ns of its few microseconds
    m = nc * dim
    ints = np.empty(m + 4 * nc + 1, dtype=np.int64)
    block_of = ints[:m]
    marker = ints[m:m + nc]
    pos = ints[m + nc:m + 2 * nc]
    diag_pos = ints[m + 2 * nc:m + 3 * nc]
    bptr = ints[m + 3 * nc:]
    for J in range(nc):
        for a in range(dim):
            block_of[J * dim + a] = J
    marker[:] = -1
    bptr[0] = 0
    for I in range(nc):                       # pass 1: count blocks per block row
        cnt = 0
        for a in range(dim):
            row = I * dim + a
            for p in range(indptr[row], indptr[row + 1]):
                J = block_of[indices[p]]
                if marker[J] != I:
                    marker[J] = I
                    cnt += 1
        bptr[I + 1] = bptr[I] + cnt
    nb = bptr[nc]
    bcol = np.empty(nb, dtype=np.int64)
    blocks = np.zeros((nb, dim, dim))
    diag = np.zeros((nc, dim, dim))
    diag_pos[:] = -1
    pos[:] = -1
    marker[:] = -1
    for I in range(nc):                       # pass 2: fill
        nxt = bptr[I]
        for a in range(dim):
            row = I * dim + a
            for p in range(indptr[row], indptr[row + 1]):
                col = indices[p]
                J = block_of[col]
                if marker[J] != I:
                    marker[J] = I
                    pos[J] = nxt
                    bcol[nxt] = J
                    if J == I:
                        diag_pos[I] = nxt
                    nxt += 1
                blocks[pos[J], a, col - J * dim] += data[p]
        k = diag_pos[I]
        if k >= 0:
            for a in range(dim):           # element by element: no array view per contact
                for c in range(dim):
                    diag[I, a, c] = blocks[k, a, c]
    return bptr, bcol, blocks, diag_pos, diag


def block_csr(W, dim: int) -> BlockCSR:
    """Convert a square sparse (or dense) matrix into :class:`BlockCSR`.

    Parameters
    ----------
    W : scipy.sparse matrix or array_like, shape (m, m)
        Delassus operator, ``m = dim * n_contacts``.
    dim : int
        Block size.

    Returns
    -------
    BlockCSR
        Duplicate entries are summed; block columns keep their order of first
        appearance in the CSR rows (unsorted, which the sweeps do not need).
    """
    Wc = W if sp.isspmatrix_csr(W) else sp.csr_matrix(W, dtype=np.float64)
    return block_csr_arrays(Wc.indptr, Wc.indices, Wc.data, dim)


def block_csr_arrays(indptr, indices, data, dim: int) -> BlockCSR:
    """:func:`block_csr` of a square matrix given by its CSR arrays (no scipy matrix needed).

    The index arrays go to the kernel as they are: a problem's are int32 (as the compiled
    route passes them), and a cast to int64 here compiled the kernel a second time on a
    fresh install."""
    nc = (indptr.shape[0] - 1) // dim
    out = csr_to_bsr(indptr, indices, data.astype(np.float64, copy=False), dim, nc)
    return BlockCSR(dim, nc, *out)


def _compute(problem) -> BlockCSR:
    indptr, indices, data = problem.csr_parts
    return block_csr_arrays(indptr, indices, data, problem.dim)


def problem_blocks(problem) -> BlockCSR:
    """:class:`BlockCSR` of ``problem.W``, computed once per problem object.

    Kept on the problem (:meth:`~socp_cd.problem.FrictionContactProblem.derived`),
    read from its CSR arrays (:attr:`~socp_cd.problem.FrictionContactProblem.csr_parts`),
    so a problem derived from arrays never builds a scipy matrix for NSGS.
    """
    return problem.derived("solvers.block_storage", _compute)


__all__ = ["BlockCSR", "block_csr", "block_csr_arrays", "csr_to_bsr", "problem_blocks"]
