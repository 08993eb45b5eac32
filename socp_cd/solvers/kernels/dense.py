"""Dense linear algebra of small problems, compiled (numba), mostly without BLAS/LAPACK.

The Delassus operator ``W`` of a problem with a few contacts is formed densely
once; mat-vecs, LU solves with partial pivoting, the symmetric/skew split and
the condensation of a small global problem are written out here instead of
calling BLAS/LAPACK: at these sizes it costs about the same, and it cannot fall
into multithreaded-OpenBLAS oversubscription, which on a loaded machine turns
a 0.2 ms ``162 x 162`` solve into 50-100 ms.  Above :data:`NAIVE_LU_MAX_N`
unknowns, on patterns whose envelope fills much of the triangle (:func:`envelope_fraction`;
the caller decides), :func:`dense_solve` calls LAPACK (the ``getrf``/``getrs`` of scipy's LAPACK) from compiled
code, where the blocked LU is 1.4-2.1x faster than the loop of :func:`lu_solve` on a full
matrix; the caller limits BLAS to one thread around it.

:func:`dense_error` is Siconos' relative error with ``u = W r + q``
recomputed, through :func:`socp_cd.solvers.kernels.cone.law_error`.
"""
from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core.errors import TypingError
from numba.extending import get_cython_function_address, intrinsic

from .cone import law_error

#: relative pivot below which a matrix counts as singular (both LUs of :func:`dense_solve`)
PIVOT_TOL = 1e-15


@njit(cache=True)
def matvec_into(A, x, b, out):
    """``out = A x + b`` (no BLAS)."""
    n, k = A.shape
    for i in range(n):
        s = b[i]
        for j in range(k):
            s += A[i, j] * x[j]
        out[i] = s


@njit(cache=True, inline="always")
def abs_max(A):
    """``max |A_ij|`` of a square matrix, NaN entries ignored (0 when there are none else).

    Four running maxima, not one: a single one chains every comparison to the last
    (latency-bound: 2 us of a 42 x 42 LU's 9.5).  The maximum does not depend on the order.
    """
    n = A.shape[0]
    s0 = s1 = s2 = s3 = 0.0
    for i in range(n):
        j = 0
        while j + 4 <= n:
            a0 = abs(A[i, j])
            a1 = abs(A[i, j + 1])
            a2 = abs(A[i, j + 2])
            a3 = abs(A[i, j + 3])
            if a0 > s0:
                s0 = a0
            if a1 > s1:
                s1 = a1
            if a2 > s2:
                s2 = a2
            if a3 > s3:
                s3 = a3
            j += 4
        while j < n:
            a0 = abs(A[i, j])
            if a0 > s0:
                s0 = a0
            j += 1
    if s1 > s0:
        s0 = s1
    if s3 > s2:
        s2 = s3
    return s2 if s2 > s0 else s0


@njit(cache=True)
def lu_solve_many(A, B):
    """Solve ``A X = B`` (``B`` of shape ``(n, k)``) by LU with partial pivoting.

    In place: ``A`` and ``B`` are destroyed.  Returns ``(X, ok)``; ``ok`` is
    False on a zero (or non-finite) pivot or a non-finite solution.
    """
    n, k = B.shape
    X = np.zeros((n, k))
    scale = abs_max(A)
    tiny = 1e-300 + PIVOT_TOL * scale
    un = np.uint64(n)
    for c in range(n):
        p = c
        amax = abs(A[c, c])
        for i in range(c + 1, n):
            a = abs(A[i, c])
            if a > amax:
                amax = a
                p = i
        if not (amax > tiny):          # also catches NaN
            return X, False
        if p != c:
            for j in range(np.uint64(c), un):
                t = A[c, j]
                A[c, j] = A[p, j]
                A[p, j] = t
            for j in range(k):
                t = B[c, j]
                B[c, j] = B[p, j]
                B[p, j] = t
        inv = 1.0 / A[c, c]
        # unsigned bounds: with a signed start numba keeps negative-index wrap-around in the
        # loop and LLVM does not vectorize it (a 42 x 42 solve 21 -> 9 us, LAPACK 10 us)
        lo = np.uint64(c + 1)
        for i in range(c + 1, n):
            f = A[i, c] * inv
            if f != 0.0:
                for j in range(lo, un):
                    A[i, j] -= f * A[c, j]
                for j in range(k):
                    B[i, j] -= f * B[c, j]
    for i in range(n - 1, -1, -1):
        for j in range(k):
            s = B[i, j]
            for l in range(i + 1, n):
                s -= A[i, l] * X[l, j]
            X[i, j] = s / A[i, i]
            if not np.isfinite(X[i, j]):
                return X, False
    return X, True


@njit(cache=True)
def lu_solve(A, b):
    """Solve ``A x = b`` (in place, ``A`` destroyed; ``b`` kept); returns ``(x, ok)``."""
    X, ok = lu_solve_many(A, b.reshape(b.shape[0], 1).copy())
    return X[:, 0].copy(), ok


#: :func:`dense_solve`'s callers take the written-out LU up to this order whatever the
#: matrix (session 16: 18 us on a full 60 x 60 matrix, LAPACK 19; 78 vs 52 at 100), and
#: above it on patterns of a small :func:`envelope_fraction`
#: (``socp_cd.solvers.newton.COMPILED_LU_MAX_ENVELOPE``; formulations/newton.md, "The dense LU")
NAIVE_LU_MAX_N = 72


@njit(cache=True)
def envelope_fraction(indptr, indices, m):
    """The share of the lower triangle inside the envelope of the pattern of ``A + Aᵀ``.

    ``A`` (``m x m``) in CSR form; row ``i``'s envelope runs from its first stored column
    (of ``A`` or ``Aᵀ``) to the diagonal: ``sum_i (i - first_i) / (m² / 2)`` (0 for a
    diagonal matrix, ~1 for a full one).
    """
    first = np.arange(m)
    for i in range(m):
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j < first[i]:
                first[i] = j
            elif j > i and i < first[j]:
                first[j] = i
    s = 0
    for i in range(m):
        s += i - first[i]
    return s / (0.5 * m * m) if m > 0 else 0.0


def _lowered_c_call(context, builder, signature, args):
    """Lowering of :func:`_c_call6` / :func:`_c_call9`: the C function ``void f(void *, ...)``
    at the address ``args[0]`` called with the data pointers of the ``ctypes`` views after it."""
    p8 = ir.IntType(8).as_pointer()
    fnty = ir.FunctionType(ir.VoidType(), [p8] * (len(args) - 1))
    f = builder.inttoptr(args[0], fnty.as_pointer())
    ptrs = [builder.bitcast(context.make_helper(builder, ty, val).data, p8)
            for ty, val in zip(signature.args[1:], args[1:])]
    builder.call(f, ptrs)
    return context.get_dummy_value()


def _c_call_signature(addr, views):
    """The signature of a C call at ``addr`` (an integer) on ``views`` (arrays' ``.ctypes``:
    each holds its array alive through the call, where a bare address would not)."""
    if not isinstance(addr, types.Integer) or not all(isinstance(v, types.ArrayCTypes)
                                                      for v in views):
        raise TypingError("a C call takes an integer address and arrays' .ctypes views")
    return types.void(addr, *views)


@intrinsic
def _c_call6(typingctx, addr, a0, a1, a2, a3, a4, a5):
    """``f(a0, ..., a5)`` for the C function at the address ``addr`` (LAPACK's ``getrf``)."""
    return _c_call_signature(addr, (a0, a1, a2, a3, a4, a5)), _lowered_c_call


@intrinsic
def _c_call9(typingctx, addr, a0, a1, a2, a3, a4, a5, a6, a7, a8):
    """``f(a0, ..., a8)`` for the C function at the address ``addr`` (LAPACK's ``getrs``)."""
    return _c_call_signature(addr, (a0, a1, a2, a3, a4, a5, a6, a7, a8)), _lowered_c_call


#: the ``lapack`` argument of :func:`dense_solve` above :data:`NAIVE_LU_MAX_N` unknowns: the
#: addresses of ``dgetrf`` and ``dgetrs`` in ``scipy.linalg.cython_lapack`` (scipy's
#: LAPACK, the one ``scipy.linalg.lu_factor`` calls).  Addresses, not ctypes functions:
#: numba cannot cache a kernel holding a ctypes pointer as a global, a ctypes argument costs
#: ~1 µs a call, and its type differs from :data:`WRITTEN_OUT`'s, so every kernel that takes
#: the argument was compiled twice (session 47, ``validation/compile_cost.py``).  Pass it as
#: an argument only: a kernel that read it as a global would cache this process's addresses
#: as constants, and a later process (another address space) would call them
#: (``tests/test_newton_dense.py`` checks that no kernel names it)
LAPACK_LU = (get_cython_function_address("scipy.linalg.cython_lapack", "dgetrf"),
             get_cython_function_address("scipy.linalg.cython_lapack", "dgetrs"))
#: the ``lapack`` argument of :func:`dense_solve` for the written-out LU (:func:`lu_solve`)
WRITTEN_OUT = (0, 0)


@njit(cache=True)
def _lapack_solve(A, b, lapack, strict):
    """Solve ``A x = b`` by LAPACK's ``getrf``/``getrs`` (``A`` kept); ``(x, ok)`` as
    :func:`lu_solve`, with the same pivot test when ``strict``, else singular on an exact
    zero pivot only (``scipy.linalg.lu_factor``'s test)."""
    getrf, getrs = lapack
    n = A.shape[0]
    F = np.empty((n, n))            # A in column-major order, as LAPACK reads it
    scale = 0.0
    for i in range(n):
        for j in range(n):
            a = A[i, j]
            F[j, i] = a
            if not np.isfinite(a):
                return np.zeros(n), False
            if abs(a) > scale:
                scale = abs(a)
    dims = np.array([n, 1, 0], dtype=np.int32)      # n, nrhs, info
    piv = np.empty(n, dtype=np.int32)
    _c_call6(getrf, dims.ctypes, dims.ctypes, F.ctypes, dims.ctypes, piv.ctypes, dims[2:].ctypes)
    if dims[2] < 0:
        return np.zeros(n), False
    tiny = 1e-300 + PIVOT_TOL * scale if strict else 0.0
    for i in range(n):
        if not (abs(F[i, i]) > tiny):     # (F's diagonal is U's)
            return np.zeros(n), False
    x = b.copy()
    trans = np.array([78], dtype=np.uint8)      # "N"
    _c_call9(getrs, trans.ctypes, dims.ctypes, dims[1:].ctypes, F.ctypes, dims.ctypes,
             piv.ctypes, x.ctypes, dims.ctypes, dims[2:].ctypes)
    for k in range(n):
        if not np.isfinite(x[k]):
            return x, False
    return x, True


@njit(cache=True)
def dense_solve(A, b, lapack, strict):
    """Solve ``A x = b``: :func:`lu_solve` (``A`` destroyed) when ``lapack`` is
    :data:`WRITTEN_OUT`, else LAPACK (``lapack``: :data:`LAPACK_LU`; ``A`` kept).  Returns
    ``(x, ok)``; ``ok`` is False on a singular matrix (the caller regularizes or gives up) or
    a non-finite solution.  Singular: a pivot below ``PIVOT_TOL max|A|`` (the written-out LU
    always; LAPACK when ``strict``, else an exact zero pivot, scipy's test).

    Which pivots rounding leaves on a singular matrix depends on the algorithm and the
    size (~1e-17 of the largest entry on a rank-deficient 5 x 5, up to 7e-14 on a
    150 x 150 one, which LAPACK then "solves"), so no relative test is right everywhere:
    the plain Newton step asks ``strict`` of its first factorization, to be sent to the
    regularized retry on the singular matrices of box stacks, and not of the retry, which
    must not fail where scipy's test had let a usable step through (formulations/newton.md
    §5, "The dense LU").

    Callers pass :data:`WRITTEN_OUT` up to :data:`NAIVE_LU_MAX_N` unknowns and on patterns
    of a small :func:`envelope_fraction` (one compiled version for both: the two are tuples
    of two integers)."""
    if lapack[0] == 0 or lapack[1] == 0:       # (no address: the written-out LU)
        return lu_solve(A, b)
    return _lapack_solve(A, b, lapack, strict)


@njit(cache=True)
def normal_matrix(J, F, A, g):
    """``A = JᵀJ`` and ``g = -JᵀF`` (zero entries of ``J`` skipped)."""
    m = J.shape[0]
    A[:, :] = 0.0
    g[:] = 0.0
    for k in range(m):
        for i in range(m):
            a = J[k, i]
            if a != 0.0:
                g[i] -= a * F[k]
                for j in range(m):
                    A[i, j] += a * J[k, j]


@njit(cache=True)
def dense_error(W, q, r, mu, dim, law, norm_q, u):
    """Relative natural-map error of ``r`` (``u = W r + q`` written into ``u``).

    ``law`` is a law code of :mod:`.cone` (``LAW_COULOMB``: Siconos' error;
    ``LAW_ASSOCIATED``: ``u`` instead of ``û``).
    """
    matvec_into(W, r, q, u)
    return law_error(r, u, mu, np.zeros(mu.shape[0]), dim, law, norm_q)


@njit(cache=True)
def dense_condense(M, H, f, w):
    """Local form of a small global problem: ``W = Hᵀ M⁻¹ H``, ``q = Hᵀ M⁻¹ f + w``.

    One LU of ``M`` with partial pivoting (no LAPACK), ``M``, ``H`` dense.
    Returns ``(W, q, ok)``; ``ok`` is False when ``M`` is numerically singular.
    """
    n, m = H.shape
    A = M.copy()
    B = np.empty((n, m + 1))
    for i in range(n):
        for j in range(m):
            B[i, j] = H[i, j]
        B[i, m] = f[i]
    W = np.zeros((m, m))
    q = np.zeros(m)
    X, ok = lu_solve_many(A, B)
    if not ok:
        return W, q, False
    for a in range(m):
        for i in range(n):
            h = H[i, a]
            if h != 0.0:
                for b in range(m):
                    W[a, b] += h * X[i, b]
                q[a] += h * X[i, m]
        q[a] += w[a]
    for a in range(m):
        if not np.isfinite(q[a]):
            return W, q, False
        for b in range(m):
            if not np.isfinite(W[a, b]):
                return W, q, False
    return W, q, True


@njit(cache=True)
def csr_to_dense(indptr, indices, data, n_rows, n_cols):
    """Dense ``(n_rows, n_cols)`` matrix from CSR arrays (duplicates summed, as scipy does)."""
    W = np.zeros((n_rows, n_cols))
    for i in range(n_rows):
        for p in range(indptr[i], indptr[i + 1]):
            W[i, indices[p]] += data[p]
    return W


@njit(cache=True)
def csr_matvec_add(indptr, indices, data, x, b):
    """``A x + b`` for ``A`` in CSR form (the row sums in scipy's order: bit-identical to
    ``A @ x + b``), without scipy's per-call dispatch."""
    out = np.empty(indptr.shape[0] - 1)
    csr_matvec_add_into(indptr, indices, data, x, b, out)
    return out


@njit(cache=True, inline="always")
def csr_matvec_add_into(indptr, indices, data, x, b, out):
    """:func:`csr_matvec_add` into ``out`` (not ``x``, not ``b``)."""
    for i in range(indptr.shape[0] - 1):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            s += data[k] * x[indices[k]]
        out[i] = s + b[i]


@njit(cache=True)
def dense_split(indptr, indices, data, m):
    """Dense ``W`` (from CSR arrays) and its symmetric and skew parts.

    Returns ``(W, W_s, W_a, max|W_a|·2, max|W|, sum|diag W|)``; the second
    value is ``max|W - Wᵀ|`` as :attr:`FrictionContactProblem.asymmetry`.
    """
    W = csr_to_dense(indptr, indices, data, m, m)
    Ws = np.empty((m, m))
    Wa = np.empty((m, m))
    asym = 0.0
    scale = 0.0
    dsum = 0.0
    for i in range(m):
        dsum += abs(W[i, i])
        for j in range(m):
            a = W[i, j]
            b = W[j, i]
            Ws[i, j] = 0.5 * (a + b)
            Wa[i, j] = 0.5 * (a - b)
            if abs(a - b) > asym:
                asym = abs(a - b)
            if abs(a) > scale:
                scale = abs(a)
    return W, Ws, Wa, asym, scale, dsum


@njit(cache=True)
def matvec(A, x):
    """``A x`` without BLAS (no thread pool involved)."""
    out = np.zeros(A.shape[0])
    matvec_into(A, x, out, out)
    return out


__all__ = ["csr_to_dense", "dense_error", "dense_condense", "dense_split", "dense_solve", "matvec",
           "lu_solve", "lu_solve_many", "normal_matrix", "matvec_into", "NAIVE_LU_MAX_N",
           "LAPACK_LU", "WRITTEN_OUT", "PIVOT_TOL", "envelope_fraction", "csr_matvec_add",
           "csr_matvec_add_into"]
