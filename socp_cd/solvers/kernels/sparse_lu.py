"""Sparse LU with threshold partial pivoting, left-looking (Gilbert–Peierls), compiled.

The Newton matrices of the local problem (``J = Dr + Du (W + alpha I)``) of a few hundred
to a few thousand contacts have little fill once their columns are ordered (an ordering
computed once per solve, e.g. SuperLU's minimum degree of ``A + Aᵀ``): ``nnz(L + U)`` is
1–2 ``nnz(J)``.  At that fill SuperLU's supernodal machinery and its per-call set-up
dominate (1 ms for an 888-unknown matrix of 9 000 entries), where the left-looking method
does the same factorization with the work proportional to its floating-point operations
(Gilbert & Peierls 1988; the algorithm of Davis' CSparse ``cs_lu``, the factorization KLU
uses for circuit matrices of this kind):

for each column ``k`` of ``A Q``: the sparse triangular solve ``x = L \\ A[:, q_k]`` on the
columns of ``L`` reached from the column's pattern (a depth-first search, in topological
order), then the pivot: the diagonal entry (row ``q_k``) when its magnitude is at least
``tol`` times the largest entry of the rows not yet pivotal (SuperLU's ``diag_pivot_thresh``
with ``SymmetricMode``), else the largest; ``U[:, k]`` takes the pivotal rows, ``L[:, k]``
the others divided by the pivot.

The Newton steps of one solve factorize matrices of one pattern (the full block pattern,
stored zeros kept) whose values change little from step to step: :func:`lu_refactor` redoes
the multiply-adds with the previous step's pivots and factor patterns, without the search
(KLU's refactorization), and refuses a pivot below the same threshold, after which
:func:`lu_factor` searches afresh.

``P A Q = L U`` with ``L`` unit lower triangular (its unit diagonal stored first in each
column), ``U`` upper triangular (its diagonal stored last), ``pinv`` the row permutation
(``pinv[i]`` the pivot step of row ``i``) and ``q`` the column order.  The reference is
SuperLU (``tests/test_sparse_lu.py`` solves with both).

Modules here import nothing from ``socp_cd`` outside this package.
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: status codes of :func:`lu_factor`
OK, SINGULAR, FULL_L, FULL_U = 0, 1, 2, 3


@njit(cache=True)
def _reach_dfs(j, Lp, Li, top, xi, pstack, pinv, mark, stamp):
    """Depth-first search from row ``j`` in the graph of ``L`` (columns so far); the nodes
    it finishes are pushed on ``xi`` below ``top`` (topological order); returns the new top."""
    head = 0
    xi[0] = j
    while head >= 0:
        j = xi[head]
        jnew = pinv[j]
        if mark[j] != stamp:
            mark[j] = stamp
            pstack[head] = 0 if jnew < 0 else Lp[jnew]
        done = True
        if jnew >= 0:
            p2 = Lp[jnew + 1]
            p = pstack[head]
            while p < p2:
                i = Li[p]
                if mark[i] == stamp:
                    p += 1
                    continue
                pstack[head] = p        # resume here when i is finished
                head += 1
                xi[head] = i
                done = False
                break
        if done:
            head -= 1
            top -= 1
            xi[top] = j
    return top


@njit(cache=True)
def lu_factor(n, Ap, Ai, Ax, q, tol, Lp, Li, Lx, Up, Ui, Ux, pinv, xi, pstack, x, mark):
    """Factorize the CSC matrix ``(Ap, Ai, Ax)`` (``n x n``, no duplicate entries) in the
    column order ``q``.

    ``Lp``, ``Up`` (n + 1), ``Li``, ``Lx``, ``Ui``, ``Ux`` (capacities), ``pinv`` (n), work
    arrays ``xi`` (n), ``pstack`` (n), ``x`` (n, zero on entry and on return) and
    ``mark`` (n) are the caller's.  Returns ``(status, lnz, unz)``: :data:`OK`,
    :data:`SINGULAR` (no nonzero pivot in a column: a structurally or numerically singular
    matrix), :data:`FULL_L` / :data:`FULL_U` (a capacity too small: call again with larger
    arrays).  On success ``Li`` holds row indices in the pivot order.
    """
    lnz = 0
    unz = 0
    for i in range(n):
        pinv[i] = -1
        mark[i] = -1
    for k in range(n):
        Lp[k] = lnz
        Up[k] = unz
        if lnz + n > Li.shape[0]:
            return FULL_L, lnz, unz
        if unz + n > Ui.shape[0]:
            return FULL_U, lnz, unz
        col = q[k]
        # x = L \ A[:, col] on the reach of the column's pattern
        top = n
        for p in range(Ap[col], Ap[col + 1]):
            i = Ai[p]
            if mark[i] != k:
                top = _reach_dfs(i, Lp, Li, top, xi, pstack, pinv, mark, k)
        for p in range(Ap[col], Ap[col + 1]):      # (x is zero: each column clears its reach)
            x[Ai[p]] = Ax[p]
        for px in range(top, n):
            j = xi[px]
            J = pinv[j]
            if J < 0:
                continue
            xj = x[j]
            for p in range(Lp[J] + 1, Lp[J + 1]):
                x[Li[p]] -= Lx[p] * xj
        # the pivot
        ipiv = -1
        a = -1.0
        for px in range(top, n):
            i = xi[px]
            if pinv[i] < 0:
                t = abs(x[i])
                if t > a:
                    a = t
                    ipiv = i
            else:
                Ui[unz] = pinv[i]
                Ux[unz] = x[i]
                unz += 1
        if ipiv == -1 or not a > 0.0 or not np.isfinite(a):
            for px in range(top, n):
                x[xi[px]] = 0.0
            return SINGULAR, lnz, unz
        if pinv[col] < 0 and mark[col] == k and x[col] != 0.0 and abs(x[col]) >= a * tol:
            ipiv = col
        pivot = x[ipiv]
        Ui[unz] = k
        Ux[unz] = pivot
        unz += 1
        pinv[ipiv] = k
        Li[lnz] = ipiv
        Lx[lnz] = 1.0
        lnz += 1
        for px in range(top, n):
            i = xi[px]
            if pinv[i] < 0:
                Li[lnz] = i
                Lx[lnz] = x[i] / pivot
                lnz += 1
            x[i] = 0.0
    Lp[n] = lnz
    Up[n] = unz
    for p in range(lnz):
        Li[p] = pinv[Li[p]]
    return OK, lnz, unz


@njit(cache=True)
def lu_solve(n, pinv, q, Lp, Li, Lx, Up, Ui, Ux, b, work, out):
    """``out = A^{-1} b`` from :func:`lu_factor`'s factors (``work``: n floats)."""
    for i in range(n):
        work[pinv[i]] = b[i]
    for j in range(n):
        xj = work[j]
        for p in range(Lp[j] + 1, Lp[j + 1]):
            work[Li[p]] -= Lx[p] * xj
    for j in range(n - 1, -1, -1):
        xj = work[j] / Ux[Up[j + 1] - 1]
        work[j] = xj
        for p in range(Up[j], Up[j + 1] - 1):
            work[Ui[p]] -= Ux[p] * xj
    for k in range(n):
        out[q[k]] = work[k]


@njit(cache=True)
def lu_refactor(n, Ap, Ai, Ax, q, tol, pinv, Lp, Li, Lx, Up, Ui, Ux, x):
    """Factorize a matrix of the same pattern as :func:`lu_factor`'s last one with its row
    pivots and its factors' patterns (no search: the multiply-adds only, KLU's refactor).

    ``x`` (n) is zero on entry and on return.  Returns :data:`OK`, or :data:`SINGULAR` when
    a pivot is zero or below ``tol`` times its column's largest entry below it (the
    threshold :func:`lu_factor` keeps; the caller then factorizes afresh).  The entries of
    ``U[:, k]`` were stored in topological order, which the updates follow.
    """
    for k in range(n):
        col = q[k]
        for p in range(Ap[col], Ap[col + 1]):
            x[pinv[Ai[p]]] = Ax[p]
        for p in range(Up[k], Up[k + 1] - 1):
            j = Ui[p]
            xj = x[j]
            for t in range(Lp[j] + 1, Lp[j + 1]):
                x[Li[t]] -= Lx[t] * xj
        pivot = x[k]
        big = 0.0
        for t in range(Lp[k] + 1, Lp[k + 1]):
            v = abs(x[Li[t]])
            if v > big:
                big = v
        if not (abs(pivot) >= tol * big and pivot != 0.0 and np.isfinite(pivot)
                and np.isfinite(big)):
            for i in range(n):
                x[i] = 0.0
            return SINGULAR
        for p in range(Up[k], Up[k + 1] - 1):
            j = Ui[p]
            Ux[p] = x[j]
            x[j] = 0.0
        Ux[Up[k + 1] - 1] = pivot
        x[k] = 0.0
        for t in range(Lp[k] + 1, Lp[k + 1]):
            i = Li[t]
            Lx[t] = x[i] / pivot
            x[i] = 0.0
    return OK


@njit(cache=True)
def factor_solve(n, Ap, Ai, vals, perm, q, tol, refactor, b, Bx, Lp, Li, Lx, Up, Ui, Ux, pinv,
                 xi, pstack, x, mark, work, out):
    """One Newton direction: the CSC matrix whose entry ``p`` is ``vals[perm[p]]`` (pattern
    ``Ap``, ``Ai``, gathered into ``Bx``) factorized in the column order ``q`` — by
    :func:`lu_refactor` when ``refactor`` (the factors hold a factorization of this
    pattern) and its pivots pass, else by :func:`lu_factor` — then ``out = A^{-1} b``.
    Returns ``(status, refactored)``, the status of :func:`lu_factor` (:data:`OK` when the
    refactorization passed; ``out`` is written on :data:`OK` only)."""
    nnz = Ap[n]
    for p in range(nnz):
        Bx[p] = vals[perm[p]]
    done = False
    if refactor:
        done = lu_refactor(n, Ap, Ai, Bx, q, tol, pinv, Lp, Li, Lx, Up, Ui, Ux, x) == OK
    status = OK
    if not done:
        status, lnz, unz = lu_factor(n, Ap, Ai, Bx, q, tol, Lp, Li, Lx, Up, Ui, Ux, pinv, xi,
                                     pstack, x, mark)
    if status == OK:
        lu_solve(n, pinv, q, Lp, Li, Lx, Up, Ui, Ux, b, work, out)
    return status, done
