"""The sparse LU of the local Newton matrices: SuperLU or the compiled left-looking LU.

The Newton matrix ``J = Dr + Du (W + alpha I)`` of a local problem keeps ``W``'s block
pattern through a solve (only its values change; a separated contact's rows lose their
off-diagonal entries).  :class:`NewtonLU` orders the columns once per solve on that pattern
(SuperLU's COLAMD, ``SymmetricMode``, on the pattern with a dominant diagonal) and counts the
floating-point operations of that factorization.  Where they are few per row (contact
networks of low connectivity: capsule and sphere piles, box stacks, 2D flows; not the
Kapla tower nor a dense 2D deposit, whose LU fills), every Newton step is factorized by the
compiled left-looking LU of :mod:`socp_cd.solvers.kernels.sparse_lu` in that order, which has
no per-call set-up and no supernode bookkeeping; elsewhere by SuperLU, ordering each matrix
afresh, as before.  Measured in ``validation/sparse_lu_choice.py``
(``validation/results/sparse_lu_choice.md``).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .kernels import sparse_lu as kernel

#: the compiled left-looking LU factorizes the Newton matrices when the ordering's
#: factorization of the full pattern costs at most this many multiply-adds per row
#: (measured: validation/results/sparse_lu_choice.md)
LEFT_LOOKING_MAX_FLOPS_PER_ROW = 200.0
#: patterns of more stored entries per row go to SuperLU without computing the ordering
#: (the choice's own cost: SuperLU on the full pattern of the Kapla tower, 68 entries per
#: row, took a third of a whole Newton solve; the patterns the left-looking LU won on have
#: 1-13 entries per row, validation/results/sparse_lu_choice.md)
SPLU_ROW_ENTRIES = 40
#: its pivoting: the diagonal entry when at least this share of the column's largest
#: candidate (SuperLU's ``diag_pivot_thresh`` of ``newton.SPLU_OPTIONS``)
PIVOT_THRESHOLD = 0.1
#: the factors' room grows (doubling) up to this many times the ordering's fill, then the
#: solves go to SuperLU (no huge allocation when pivoting departs far from the diagonal)
MAX_GROWTH = 16


class SingularMatrix(Exception):
    """No nonzero pivot: the matrix is singular (as SuperLU's RuntimeError)."""


def factor_flops(L, U) -> int:
    """Multiply-adds of a left-looking LU with factors ``L``, ``U`` (CSC, one column order):
    for every entry ``U[j, k]``, ``j < k``, the update of column ``k`` by column ``j`` of
    ``L`` below its diagonal."""
    L, U = sp.csc_matrix(L), sp.csc_matrix(U)
    below = np.diff(L.indptr) - 1
    cols = np.repeat(np.arange(U.shape[1]), np.diff(U.indptr))
    above = U.indices < cols
    return int(below[U.indices[above]].sum())


def column_order(indptr, indices, n, splu_options):
    """``(q, flops, nnz_lu)``: SuperLU's column order of the CSC pattern ``(indptr, indices)``
    with ones off the diagonal and ``n + 1`` on it (nonsingular: diagonally dominant), the
    multiply-adds and the stored entries of that factorization."""
    data = np.ones(indices.shape[0])
    P = sp.csc_matrix((data, indices.copy(), indptr.copy()), shape=(n, n))
    P = (P + sp.identity(n, format="csc") * float(n + 1)).tocsc()
    lu = spla.splu(P, **splu_options)
    q = np.argsort(lu.perm_c).astype(np.int64)
    return q, factor_flops(lu.L, lu.U), int(lu.L.nnz + lu.U.nnz)


def _block_diagonal(indptr, indices, n, block) -> bool:
    """Whether the CSC pattern has entries in its diagonal ``block x block`` blocks only."""
    cols = np.repeat(np.arange(n), np.diff(indptr))
    return bool(np.all(indices // block == cols // block))


class NewtonLU:
    """Direction solves ``J dr = b`` on one block pattern (CSC ``indptr``, ``indices``, ``n``;
    ``block``: the size of its blocks, ``d``, a block-diagonal pattern taken in its natural
    order without computing an ordering).

    ``kind`` is ``"left_looking"`` or ``"splu"`` (chosen at construction, see the module
    docstring); :meth:`solve` takes the matrix as its values (``vals[perm]`` is the CSC data
    on the pattern) and, for SuperLU, the matrix itself from ``matrix()``.
    """

    def __init__(self, indptr, indices, n, splu_options, choice="auto", block=1):
        self.n = n
        self.splu_options = splu_options
        #: the left-looking LU's factorizations with a pivot search, and refactorizations
        self.factorizations = self.refactorizations = 0
        #: whether the left-looking LU was used (also after a hand-over to SuperLU)
        self.used_left_looking = False
        self.Ap = np.ascontiguousarray(indptr, dtype=np.int64)
        self.Ai = np.ascontiguousarray(indices, dtype=np.int64)
        if choice == "splu":
            self.kind, self.flops = "splu", None
            return
        if choice == "auto" and self.Ai.shape[0] > SPLU_ROW_ENTRIES * n:
            self.kind, self.flops = "splu", None    # (no ordering computed: see the constant)
            return
        if block > 1 and _block_diagonal(self.Ap, self.Ai, n, block):
            # uncoupled contacts (no fill beyond each diagonal block): the natural order
            q, flops, nnz_lu = np.arange(n, dtype=np.int64), 0, self.Ai.shape[0]
        else:
            q, flops, nnz_lu = column_order(self.Ap, self.Ai, n, splu_options)
        self.flops = flops
        if choice == "auto" and flops > LEFT_LOOKING_MAX_FLOPS_PER_ROW * n:
            self.kind = "splu"
            return
        self.kind = "left_looking"
        self.q = q
        nnz = self.Ai.shape[0]
        self.Bx = np.empty(nnz)
        #: whether the factors hold a factorization of the pattern (refactorizations try
        #: its pivots first)
        self.valid = False
        self.Lp = np.empty(n + 1, np.int64)
        self.Up = np.empty(n + 1, np.int64)
        self._allocate(2 * nnz_lu + 2 * n)
        #: beyond this capacity (pivots far off the diagonal filled the factors): SuperLU
        self.max_capacity = MAX_GROWTH * (nnz_lu + n)
        self.pinv = np.empty(n, np.int64)
        self.xi = np.empty(n, np.int64)
        self.pstack = np.empty(n, np.int64)
        self.x = np.zeros(n)
        self.mark = np.empty(n, np.int64)
        self.work = np.empty(n)

    def _allocate(self, capacity):
        self.Li = np.empty(capacity, np.int64)
        self.Lx = np.empty(capacity)
        self.Ui = np.empty(capacity, np.int64)
        self.Ux = np.empty(capacity)

    def solve(self, vals, perm, b, matrix=None):
        """``J^{-1} b``; ``matrix()`` builds ``J`` for SuperLU.  Raises
        :class:`SingularMatrix` when ``J`` has no LU (a zero pivot column)."""
        if self.kind == "splu":
            try:
                return spla.splu(matrix(), **self.splu_options).solve(b)
            except RuntimeError as exc:
                raise SingularMatrix(str(exc)) from None
        out = np.empty(self.n)
        b = np.ascontiguousarray(b, dtype=np.float64)
        while True:
            refactor, self.valid = self.valid, False    # (False until the kernel returns)
            status, again = kernel.factor_solve(
                self.n, self.Ap, self.Ai, vals, perm, self.q, PIVOT_THRESHOLD, refactor, b,
                self.Bx, self.Lp, self.Li, self.Lx, self.Up, self.Ui, self.Ux,
                self.pinv, self.xi, self.pstack, self.x, self.mark, self.work, out)
            self.valid = status == kernel.OK
            self.used_left_looking = True
            if status == kernel.OK:
                if again:
                    self.refactorizations += 1
                else:
                    self.factorizations += 1
                return out
            if status == kernel.SINGULAR:
                raise SingularMatrix("singular Newton matrix (no nonzero pivot)")
            if 2 * self.Li.shape[0] > self.max_capacity:
                self.kind = "splu"      # (the ordering no longer fits these matrices)
                return self.solve(vals, perm, b, matrix)
            self._allocate(2 * self.Li.shape[0])    # FULL_L / FULL_U: more room, again


__all__ = ["NewtonLU", "SingularMatrix", "column_order", "factor_flops",
           "LEFT_LOOKING_MAX_FLOPS_PER_ROW", "SPLU_ROW_ENTRIES", "PIVOT_THRESHOLD", "MAX_GROWTH"]
