"""The sparse LU of the local Newton matrices: SuperLU or the compiled left-looking LU.

The Newton matrix ``J = Dr + Du (W + alpha I)`` of a local problem keeps ``W``'s block
pattern through a solve (only its values change; a separated contact's rows lose their
off-diagonal entries).  :class:`NewtonLU` orders that pattern once per solve, symmetrically
(rows and columns alike, so the diagonal stays on the diagonal): the minimum-degree
ordering of ``A + Aᵀ`` (SuperLU's ``MMD_AT_PLUS_A`` with ``SymmetricMode`` and a preference
for diagonal pivots, SuperLU's documented setting for matrices of symmetric pattern), and
counts the floating-point operations of that factorization.  Where they are few per row
(contact networks of low connectivity: capsule and sphere piles, box stacks, 2D flows; not
the Kapla tower nor a dense 2D deposit, whose LU fills), every Newton step is factorized by
the compiled left-looking LU of :mod:`socp_cd.solvers.kernels.sparse_lu` in that order,
which has no per-call set-up and no supernode bookkeeping; elsewhere by SuperLU on the
matrix permuted into that order (``permc_spec="NATURAL"``: no ordering per step).
Measured in ``validation/sparse_lu_choice.py`` (the choice, session 38:
``validation/results/sparse_lu_choice.md``) and ``validation/splu_ordering.py`` (the
ordering, session 39: ``validation/results/splu_ordering.md``).
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
#: patterns of more stored entries per row go to SuperLU whatever the ordering's flop count
#: (the patterns the left-looking LU won on have 1-13 entries per row, the Kapla tower 68,
#: validation/results/sparse_lu_choice.md; until session 38 the ordering was not computed
#: for them, SuperLU ordering each matrix itself: with SPLU_ORDER_ONCE it is, once)
SPLU_ROW_ENTRIES = 40
#: its pivoting: the diagonal entry when at least this share of the column's largest
#: candidate (SuperLU's ``diag_pivot_thresh`` of ``newton.SPLU_OPTIONS``)
PIVOT_THRESHOLD = 0.1
#: SuperLU's ordering of the pattern, computed once per solve (``permc_spec``; session 39:
#: ``"MMD_AT_PLUS_A"``, the minimum degree of ``A + Aᵀ``, against session 38's ``"COLAMD"``
#: of ``AᵀA``: fill x0.56-0.67 on the 2D deposits' patterns, x0.94-0.95 on the capsule
#: piles', x0.77 on the Kapla tower's, validation/results/splu_ordering.md)
ORDERING = "MMD_AT_PLUS_A"
#: (a study knob) True: SuperLU factorizes each Newton matrix permuted into the solve's
#: ordering, with no ordering of its own; False: each matrix as it is, ordered by SuperLU on
#: each call with the caller's ``splu_options`` (session 38's path)
SPLU_ORDER_ONCE = True
#: ... and when one of those factorizations stores more than this many times what SuperLU
#: stored for the ordering's own factorization of the pattern (``SuperLU.nnz``), the later
#: steps of the solve go back to SuperLU ordering each matrix with COLAMD: pivots far off
#: the diagonal fill a minimum-degree order of ``A + Aᵀ``, which assumes diagonal pivots,
#: while COLAMD's order of ``AᵀA`` bounds the fill of any row pivoting (the Kapla tower's
#: last Newton matrix: 746 000 entries in MMD's order against 505 000 in COLAMD's; the
#: deposits stay within x1.1 of the pattern's, validation/results/splu_ordering.md)
SPLU_FILL_GROWTH = 1.5
#: the factors' room grows (doubling) up to this many times the ordering's fill, then the
#: solves go to SuperLU ordering each matrix with COLAMD (no huge allocation when pivoting
#: departs far from the diagonal)
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


def csc_without_zeros(data, indices, indptr, n):
    """The ``n x n`` CSC matrix ``(data, indices, indptr)`` with its stored zeros dropped
    (a separated contact's rows off the diagonal), on copies of the index arrays
    (``eliminate_zeros`` rewrites them in place)."""
    A = sp.csc_matrix((data, indices.copy(), indptr.copy()), shape=(n, n))
    A.eliminate_zeros()
    return A


def entry_positions(P):
    """Where scipy put the entries of a matrix: ``P`` holds ``1, 2, ..., nnz`` (the entries'
    numbers, from 1 so none is an explicit zero) after a conversion or a permutation;
    returns ``(positions, indices, indptr)`` of ``P`` as a sorted CSC matrix, entry ``p``
    of which is entry ``positions[p]`` of the numbered array."""
    P = P.tocsc()
    P.sort_indices()
    return P.data.astype(np.int64) - 1, P.indices, P.indptr


def column_order(indptr, indices, n, splu_options):
    """SuperLU's order of a CSC pattern, and the cost of factorizing in it.

    The pattern gets ones off the diagonal and ``n + 1`` on it (nonsingular: diagonally
    dominant, so the pivots stay on the diagonal and the order is symmetric).

    Parameters
    ----------
    indptr, indices : ndarray
        The CSC pattern (``n x n``).
    n : int
    splu_options : mapping
        SuperLU's settings; its ``permc_spec`` is replaced by :data:`ORDERING`.

    Returns
    -------
    q : ndarray of int64
        The order: column (and row) ``k`` of the ordered matrix is ``q[k]``.
    flops : int
        Multiply-adds of that factorization (:func:`factor_flops`).
    nnz_lu : int
        Entries of its ``L + U``.
    stored : int
        What SuperLU stored for it (``SuperLU.nnz``, its supernodes' storage: the
        measure :data:`SPLU_FILL_GROWTH` compares with).
    """
    data = np.ones(indices.shape[0])
    P = sp.csc_matrix((data, indices.copy(), indptr.copy()), shape=(n, n))
    P = (P + sp.identity(n, format="csc") * float(n + 1)).tocsc()
    lu = spla.splu(P, **dict(splu_options, permc_spec=ORDERING))
    q = np.argsort(lu.perm_c).astype(np.int64)
    return q, factor_flops(lu.L, lu.U), int(lu.L.nnz + lu.U.nnz), int(lu.nnz)


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
    on the pattern).  ``splu_options``: SuperLU's settings (its ``permc_spec`` is used
    only without :data:`SPLU_ORDER_ONCE`; the ordering is :data:`ORDERING`).  ``ordering``:
    a callable returning :func:`column_order` of this pattern with these settings (a caller
    that keeps it across systems of one pattern); None computes it here.
    """

    def __init__(self, indptr, indices, n, splu_options, choice="auto", block=1, ordering=None):
        self.n = n
        self.splu_options = splu_options
        #: the left-looking LU's factorizations with a pivot search, and refactorizations
        self.factorizations = self.refactorizations = 0
        #: whether the left-looking LU was used (also after a hand-over to SuperLU)
        self.used_left_looking = False
        self.Ap = np.ascontiguousarray(indptr, dtype=np.int64)
        self.Ai = np.ascontiguousarray(indices, dtype=np.int64)
        #: SuperLU's input in the solve's order (:meth:`_order_for_splu`), made on first use
        self._permuted = None
        #: set when an ordered SuperLU factorization outgrew SPLU_FILL_GROWTH: from then on
        #: SuperLU orders each matrix itself
        self.reorder_each = False
        self.q, self.flops, self.nnz_lu, self.stored = None, None, None, None
        # SuperLU chosen without the flop count: forced, or a pattern of more than
        # SPLU_ROW_ENTRIES entries per row (the left-looking LU would fill it)
        splu_now = choice == "splu" or (choice == "auto"
                                        and self.Ai.shape[0] > SPLU_ROW_ENTRIES * n)
        if splu_now and not SPLU_ORDER_ONCE:
            self.kind = "splu"
            return
        if block > 1 and _block_diagonal(self.Ap, self.Ai, n, block):
            # uncoupled contacts (no fill beyond each diagonal block): the natural order
            # (no fill test: pivoting stays within the diagonal blocks)
            q, flops, nnz_lu, stored = np.arange(n, dtype=np.int64), 0, self.Ai.shape[0], None
        else:
            q, flops, nnz_lu, stored = (column_order(self.Ap, self.Ai, n, splu_options)
                                        if ordering is None else ordering())
        self.q, self.flops, self.nnz_lu, self.stored = q, flops, nnz_lu, stored
        if splu_now or (choice == "auto" and flops > LEFT_LOOKING_MAX_FLOPS_PER_ROW * n):
            self.kind = "splu"
            return
        self.kind = "left_looking"
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

    def _order_for_splu(self, perm):
        """SuperLU's input in the order ``q``: the pattern of ``A[q][:, q]`` and, for each of
        its entries, the index into ``vals`` of the matrix's values (``perm`` composed with
        the permutation of the CSC entries), with SuperLU's settings for a matrix already
        ordered."""
        n, q = self.n, self.q
        ids = sp.csc_matrix((np.arange(1, self.Ai.shape[0] + 1, dtype=np.float64),
                             self.Ai, self.Ap), shape=(n, n))
        positions, indices, indptr = entry_positions(ids[q][:, q])
        gather = np.asarray(perm, dtype=np.int64)[positions]
        options = dict(self.splu_options, permc_spec="NATURAL")
        self._permuted = (perm, gather, indices, indptr, options)

    def _splu_ordered(self, vals, perm, b):
        """``J^{-1} b`` by SuperLU on ``J[q][:, q]``, its stored zeros dropped (the order,
        made for the full pattern, holds for any sub-pattern: a separated contact's rows are
        empty off the diagonal, and SuperLU then fills less)."""
        if self._permuted is None or self._permuted[0] is not perm:
            self._order_for_splu(perm)
        _, gather, indices, indptr, options = self._permuted
        n, q = self.n, self.q
        try:
            lu = spla.splu(csc_without_zeros(vals[gather], indices, indptr, n), **options)
        except RuntimeError as exc:
            raise SingularMatrix(str(exc)) from None
        if self.stored is not None and lu.nnz > SPLU_FILL_GROWTH * self.stored:
            self.reorder_each = True        # (this step's factors are used all the same)
        y = lu.solve(np.asarray(b, dtype=np.float64)[q])
        out = np.empty(n)
        out[q] = y
        return out

    def _allocate(self, capacity):
        self.Li = np.empty(capacity, np.int64)
        self.Lx = np.empty(capacity)
        self.Ui = np.empty(capacity, np.int64)
        self.Ux = np.empty(capacity)

    def solve(self, vals, perm, b):
        """``J^{-1} b``.

        Parameters
        ----------
        vals, perm : ndarray
            ``J``'s values: ``vals[perm]`` is its CSC data on the pattern (SuperLU, when it
            orders the matrix itself, gets it with its stored zeros dropped).
        b : ndarray

        Raises
        ------
        SingularMatrix
            When ``J`` has no LU (a zero pivot column).
        """
        if self.kind == "splu":
            if SPLU_ORDER_ONCE and self.q is not None and not self.reorder_each:
                return self._splu_ordered(vals, perm, b)
            J = csc_without_zeros(vals[perm], self.Ai, self.Ap, self.n)
            try:
                return spla.splu(J, **self.splu_options).solve(b)
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
                # (the ordering no longer fits these matrices, whose pivots left the
                # diagonal: SuperLU orders each one itself, as after SPLU_FILL_GROWTH)
                self.kind, self.reorder_each = "splu", True
                return self.solve(vals, perm, b)
            self._allocate(2 * self.Li.shape[0])    # FULL_L / FULL_U: more room, again


__all__ = ["NewtonLU", "SingularMatrix", "column_order", "factor_flops", "csc_without_zeros",
           "entry_positions",
           "LEFT_LOOKING_MAX_FLOPS_PER_ROW", "SPLU_ROW_ENTRIES", "PIVOT_THRESHOLD", "MAX_GROWTH",
           "ORDERING", "SPLU_ORDER_ONCE", "SPLU_FILL_GROWTH"]
