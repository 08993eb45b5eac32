"""Cone constraints of the contact laws in the conic standard form (solver-neutral).

Conic solvers (Clarabel, SCS, ...) take ``min ½ xᵀPx + qᵀx  s.t.  A x + s = b,
s ∈ C`` where ``C`` is a product of cones listed in row order; here a cone is
a neutral ``(kind, size)`` pair with ``kind`` in :data:`CONE_KINDS` (the
Clarabel backend turns them into Clarabel objects).  Every contact law used by socp_cd asks a
stacked contact vector ``y`` (impulses ``r`` or velocities ``u``, normal first)
to lie in a per-contact convex set; this module writes that membership as a
*cone map*::

    s = G y + g,   s ∈ C,

with ``G`` sparse (one block of rows per contact, rows regrouped by cone type)
and ``g`` a constant offset (nonzero only for Tresca's ball).  A solver then
uses ``A = -G`` (local unknowns ``r``) or ``A = -G Hᵀ`` (global unknowns ``v``)
and ``b = g`` (+ ``G`` times any constant part of ``y``).  The multiplier
attached to the constraint by the solver, ``z ∈ C*``, is mapped back to contact
variables by ``Gᵀ z`` (e.g. the velocities ``u`` of a local problem, or the
impulses ``r`` of a global one).

Sets
----
* Coulomb cone ``K_mu = {||r_T|| <= mu r_N}``: ``G = diag(mu, 1, 1)`` per
  contact and ``C`` = ``("soc", 3)`` (3D); in 2D the wedge
  ``|r_T| <= mu r_N`` is the two linear rows ``mu r_N ∓ r_T >= 0``;
  ``mu = 0`` contacts give ``r_N >= 0`` (nonnegative row) and ``r_T = 0``
  (zero-cone rows).
* Dual cone ``K*_mu = K_{1/mu} = {mu ||u_T|| <= u_N}``: ``G = diag(1, mu, mu)``
  (3D SOC), rows ``u_N ∓ mu u_T >= 0`` (2D); ``mu = 0`` gives the half-space
  ``u_N >= 0`` (tangential rows are absent: they are free).
* Tresca's set ``{r_N >= 0, ||r_T|| <= g}``: a nonnegative row and an SOC on
  ``(g, r_T)`` (offset ``g``), or two linear rows ``g ∓ r_T >= 0`` in 2D.

Rows are ordered zero cone, then nonnegative cone, then the second-order cones,
so the cone list is at most ``2 + n_soc`` entries long.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.sparse as sp

from ..problem import csr_of_nonzeros


#: cone kinds of the neutral ``(kind, size)`` cones: zero cone ``{0}^size``, nonnegative
#: orthant ``R+^size``, second-order cone ``{x_0 >= ||x_1:||}`` of dimension ``size``
CONE_KINDS = ("zero", "nonneg", "soc")


class CscArrays:
    """A sparse matrix as the compressed-column arrays Clarabel's Python interface reads.

    Clarabel only reads ``data``, ``indices``, ``indptr``, ``shape`` and
    ``has_canonical_format`` from the matrices it is given.  Building a scipy
    matrix validates the arrays (tens of microseconds: as much as a whole
    one-contact SOCP solve), so the small-problem path hands Clarabel these
    arrays directly.  They must be canonical (sorted row indices per column,
    no duplicates).  :meth:`tocsc` gives the scipy matrix.
    """

    __slots__ = ("data", "indices", "indptr", "shape")
    has_canonical_format = True

    def __init__(self, data, indices, indptr, shape):
        self.data = data
        self.indices = indices
        self.indptr = indptr
        self.shape = (int(shape[0]), int(shape[1]))

    @classmethod
    def of(cls, M) -> "CscArrays":
        """Arrays of a scipy CSC matrix (or pass a :class:`CscArrays` through)."""
        if isinstance(M, CscArrays):
            return M
        M = M.tocsc()
        M.sort_indices()
        return cls(M.data, M.indices, M.indptr, M.shape)

    @property
    def nnz(self) -> int:
        return int(self.indptr[-1])

    def tocsc(self) -> sp.csc_matrix:
        """The scipy ``csc_matrix`` (shares the arrays)."""
        return sp.csc_matrix((self.data, self.indices, self.indptr), shape=self.shape)

    def toarray(self) -> np.ndarray:
        return self.tocsc().toarray()

    def __neg__(self) -> "CscArrays":
        return CscArrays(-self.data, self.indices, self.indptr, self.shape)


class ConeMap:
    """``s = G y + g ∈ C`` for a stacked contact vector ``y``.

    Attributes
    ----------
    G : scipy.sparse.csc_matrix, shape (k, m)
        (built on first access when the map was given as :class:`CscArrays`)
    csc : CscArrays
        The same matrix as bare arrays (what Clarabel reads).
    g : ndarray, shape (k,)
    n_zero, n_nonneg, n_soc, soc_dim : int
        Row counts of the zero cone, the nonnegative cone and the number and
        size of the second-order cones (rows in that order).
    """

    def __init__(self, G, g, n_zero: int, n_nonneg: int, n_soc: int, soc_dim: int = 3):
        if isinstance(G, CscArrays):
            self._G, self.csc = None, G
        else:
            self._G, self.csc = G, CscArrays.of(G)
        self.g = g
        self.n_zero = n_zero
        self.n_nonneg = n_nonneg
        self.n_soc = n_soc
        self.soc_dim = soc_dim

    @property
    def G(self) -> sp.csc_matrix:
        if self._G is None:
            self._G = self.csc.tocsc()
        return self._G

    @property
    def n_rows(self) -> int:
        """Number of constraint rows ``k``."""
        return self.csc.shape[0]

    def cones(self) -> list:
        """Cones ``(kind, size)`` matching the row order of ``G`` (see :data:`CONE_KINDS`)."""
        out = []
        if self.n_zero:
            out.append(("zero", self.n_zero))
        if self.n_nonneg:
            out.append(("nonneg", self.n_nonneg))
        out.extend([("soc", self.soc_dim)] * self.n_soc)
        return out

    def multiplier(self, z) -> np.ndarray:
        """Map Clarabel's dual variable ``z`` back to contact variables, ``Gᵀ z``."""
        return self.G.T @ np.asarray(z, dtype=np.float64)


class _Rows:
    """Collects (row-group, column, value) triplets, then orders row groups."""

    def __init__(self, m: int):
        self.m = m
        self.parts = {"zero": [], "nonneg": [], "soc": []}

    def add(self, kind: str, cols: np.ndarray, vals: np.ndarray, offs: np.ndarray):
        """Add ``len(cols)`` rows (``cols``, ``vals``: (n_rows, width); offs: (n_rows,))."""
        if len(offs):
            self.parts[kind].append((np.atleast_2d(cols), np.atleast_2d(vals), offs))

    def build(self, n_soc: int, soc_dim: int) -> ConeMap:
        rows, cols, vals, offs = [], [], [], []
        start = 0
        counts = {}
        for kind in ("zero", "nonneg", "soc"):
            n = 0
            for c, v, o in self.parts[kind]:
                k = len(o)
                rows.append(np.repeat(np.arange(start + n, start + n + k), c.shape[1]))
                cols.append(c.reshape(-1))
                vals.append(v.reshape(-1))
                offs.append(o)
                n += k
            counts[kind] = n
            start += n
        if rows:
            R, C, V = (np.concatenate(a) for a in (rows, cols, vals))
            keep = V != 0.0
            G = sp.csc_matrix((V[keep], (R[keep], C[keep])), shape=(start, self.m))
            g = np.concatenate(offs).astype(np.float64)
        else:
            G, g = sp.csc_matrix((0, self.m)), np.zeros(0)
        return ConeMap(G, g, counts["zero"], counts["nonneg"], n_soc, soc_dim)


def _soc_rows(rows: _Rows, idx: np.ndarray, dim: int, scale_n, scale_t, off_n):
    """3D SOC rows for contacts ``idx``: (scale_n y_N + off_n, scale_t y_T), interleaved per contact."""
    base = dim * idx
    n = len(idx)
    cols = np.stack([base, base + 1, base + 2], axis=1).reshape(-1, 1)
    vals = np.stack([scale_n, scale_t, scale_t], axis=1).reshape(-1, 1)
    offs = np.stack([off_n, np.zeros(n), np.zeros(n)], axis=1).reshape(-1)
    rows.add("soc", cols, vals, offs)


def _diagonal_soc_map(n_scale, t_scale, nc: int) -> ConeMap:
    """3D map with one SOC per contact and a diagonal ``G`` (every ``mu > 0``).

    Built directly in CSC (``indptr = 0..m``): the common case costs two array
    stacks instead of the generic triplet assembly.
    """
    m = 3 * nc
    vals = np.empty(m)
    vals[0::3] = n_scale
    vals[1::3] = t_scale
    vals[2::3] = t_scale
    G = CscArrays(vals, _arange32(m), _arange32(m + 1), (m, m))
    return ConeMap(G, np.zeros(m), 0, 0, nc, 3)


@lru_cache(maxsize=64)
def _arange32(n: int) -> np.ndarray:
    """Cached ``arange(n)`` index array (read-only: shared between maps)."""
    a = np.arange(n, dtype=np.int32)
    a.setflags(write=False)
    return a


def coulomb_cone_map(mu, dim: int) -> ConeMap:
    """Cone map of ``r ∈ K_mu`` (primal Coulomb cone), see the module docstring."""
    mu = np.asarray(mu, dtype=np.float64).reshape(-1)
    nc = mu.shape[0]
    if dim == 3 and nc and mu.min() > 0.0:
        return _diagonal_soc_map(mu, 1.0, nc)
    rows = _Rows(dim * nc)
    zero = np.flatnonzero(mu == 0.0)
    fric = np.flatnonzero(mu > 0.0)
    # mu = 0: r_N >= 0, r_T = 0
    rows.add("nonneg", (dim * zero)[:, None], np.ones((len(zero), 1)), np.zeros(len(zero)))
    tcols = (dim * zero[:, None] + np.arange(1, dim)[None, :]).reshape(-1, 1)
    rows.add("zero", tcols, np.ones_like(tcols, dtype=float), np.zeros(len(tcols)))
    if dim == 3:
        _soc_rows(rows, fric, 3, mu[fric], np.ones(len(fric)), np.zeros(len(fric)))
        return rows.build(len(fric), 3)
    # 2D wedge: mu r_N - r_T >= 0, mu r_N + r_T >= 0
    b = 2 * fric
    cols = np.concatenate([np.stack([b, b + 1], 1), np.stack([b, b + 1], 1)])
    vals = np.concatenate([np.stack([mu[fric], -np.ones(len(fric))], 1),
                           np.stack([mu[fric], np.ones(len(fric))], 1)])
    rows.add("nonneg", cols, vals, np.zeros(2 * len(fric)))
    return rows.build(0, 3)


def coulomb_constraint(mu, dim: int):
    """Standard-form ``(A, b, cones)`` of ``r ∈ K_mu``: ``A = -G``, ``b = g`` of :func:`coulomb_cone_map`.

    The common case (3D, every ``mu > 0``: ``A = -diag(mu, 1, 1, ...)``, one SOC
    per contact) is built directly as :class:`CscArrays`.
    """
    mu = np.asarray(mu, dtype=np.float64).reshape(-1)
    nc = mu.shape[0]
    if dim == 3 and nc and mu.min() > 0.0:
        m = 3 * nc
        vals = np.full(m, -1.0)
        vals[0::3] = -mu
        return (CscArrays(vals, _arange32(m), _arange32(m + 1), (m, m)), np.zeros(m),
                [("soc", 3)] * nc)
    cm = coulomb_cone_map(mu, dim)
    return -cm.csc, cm.g, cm.cones()


def dual_cone_map(mu, dim: int) -> ConeMap:
    """Cone map of ``u ∈ K*_mu = {mu ||u_T|| <= u_N}`` (``mu = 0``: ``u_N >= 0``)."""
    mu = np.asarray(mu, dtype=np.float64).reshape(-1)
    nc = mu.shape[0]
    if dim == 3 and nc and mu.min() > 0.0:
        return _diagonal_soc_map(1.0, mu, nc)
    rows = _Rows(dim * nc)
    zero = np.flatnonzero(mu == 0.0)
    fric = np.flatnonzero(mu > 0.0)
    rows.add("nonneg", (dim * zero)[:, None], np.ones((len(zero), 1)), np.zeros(len(zero)))
    if dim == 3:
        _soc_rows(rows, fric, 3, np.ones(len(fric)), mu[fric], np.zeros(len(fric)))
        return rows.build(len(fric), 3)
    b = 2 * fric
    cols = np.concatenate([np.stack([b, b + 1], 1), np.stack([b, b + 1], 1)])
    vals = np.concatenate([np.stack([np.ones(len(fric)), -mu[fric]], 1),
                           np.stack([np.ones(len(fric)), mu[fric]], 1)])
    rows.add("nonneg", cols, vals, np.zeros(2 * len(fric)))
    return rows.build(0, 3)


def frictionless_map(n_contacts: int, dim: int) -> ConeMap:
    """Cone map of ``r_N >= 0, r_T = 0`` (Coulomb cone with ``mu = 0``)."""
    return coulomb_cone_map(np.zeros(n_contacts), dim)


def tresca_map(threshold, dim: int) -> ConeMap:
    """Cone map of Tresca's set ``{r_N >= 0, ||r_T|| <= g}`` (``g`` per contact)."""
    g = np.asarray(threshold, dtype=np.float64).reshape(-1)
    nc = g.shape[0]
    rows = _Rows(dim * nc)
    idx = np.arange(nc)
    rows.add("nonneg", (dim * idx)[:, None], np.ones((nc, 1)), np.zeros(nc))
    if dim == 3:
        # SOC on (g, r_T1, r_T2): the first row has no column, only the offset g
        base = 3 * idx
        cols = np.stack([base + 1, base + 1, base + 2], axis=1).reshape(-1, 1)
        vals = np.stack([np.zeros(nc), np.ones(nc), np.ones(nc)], axis=1).reshape(-1, 1)
        offs = np.stack([g, np.zeros(nc), np.zeros(nc)], axis=1).reshape(-1)
        rows.add("soc", cols, vals, offs)
        return rows.build(nc, 3)
    cols = np.concatenate([(2 * idx + 1)[:, None], (2 * idx + 1)[:, None]])
    vals = np.concatenate([-np.ones((nc, 1)), np.ones((nc, 1))])
    rows.add("nonneg", cols, vals, np.concatenate([g, g]))
    return rows.build(0, 3)


def law_cone_map(problem, formulation: str, threshold=None) -> ConeMap:
    """Cone map of the feasible set of ``r`` for a law (coulomb/associated, tresca, frictionless)."""
    if formulation in ("coulomb", "associated"):
        return coulomb_cone_map(problem.mu, problem.dim)
    if formulation == "frictionless":
        return frictionless_map(problem.n_contacts, problem.dim)
    if formulation == "tresca":
        return tresca_map(threshold, problem.dim)
    raise ValueError(f"no cone map for formulation {formulation!r}")


@dataclass
class ConicData:
    """Standard-form data ``(P, q, A, b, cones)`` plus the cone map used (``P``: upper triangle).

    ``P`` and ``A`` are scipy CSC matrices, or :class:`CscArrays` for problems
    with at most :data:`DENSE_P_MAX` unknowns.
    """

    P: sp.csc_matrix
    q: np.ndarray
    A: sp.csc_matrix
    b: np.ndarray
    cone_map: ConeMap

    @property
    def cones(self) -> list:
        return self.cone_map.cones()


#: below this size ``P`` is passed with the full (dense) upper-triangle pattern
DENSE_P_MAX = 30


@lru_cache(maxsize=64)
def _dense_upper_pattern(n: int):
    """Row indices, column pointers and flat positions of the full upper triangle (CSC order)."""
    cols, rows = np.tril_indices(n)            # (col >= row), ordered by column then row
    indptr = np.zeros(n + 1, dtype=np.int32)
    indptr[1:] = np.cumsum(np.arange(1, n + 1))
    rows = rows.astype(np.int32)
    for a in (rows, indptr):
        a.setflags(write=False)
    return rows, indptr, rows * n + cols


@lru_cache(maxsize=64)
def _dense_csr_pattern(n_rows: int, n_cols: int):
    """Column indices and row pointers of a full ``n_rows x n_cols`` CSR pattern."""
    indices = np.tile(np.arange(n_cols, dtype=np.int32), n_rows)
    indptr = np.arange(0, n_rows * n_cols + 1, n_cols, dtype=np.int32)
    for a in (indices, indptr):
        a.setflags(write=False)
    return indices, indptr


def dense_to_csr(D) -> sp.csr_matrix:
    """CSR matrix of a dense array without scipy's dense-input conversion.

    Up to :data:`DENSE_P_MAX` rows the full pattern is kept (cached index
    arrays, explicit zeros harmless at that size); above, the nonzeros only.
    """
    D = np.asarray(D, dtype=np.float64)
    n, k = D.shape
    if n <= DENSE_P_MAX:
        indices, indptr = _dense_csr_pattern(n, k)
        return sp.csr_matrix((D.reshape(-1).copy(), indices.copy(), indptr.copy()), shape=(n, k))
    return csr_of_nonzeros(D)


def upper_csc_arrays(S):
    """``P`` of the standard form: :func:`upper_csc`, as bare :class:`CscArrays` for small matrices."""
    n = S.shape[0]
    if n <= DENSE_P_MAX:
        D = S.toarray() if sp.issparse(S) else np.asarray(S, dtype=np.float64)
        rows, indptr, flat = _dense_upper_pattern(n)
        return CscArrays(D.reshape(-1)[flat], rows, indptr, (n, n))
    return upper_csc(S)


def upper_csc(S) -> sp.csc_matrix:
    """Upper triangle of a (symmetric) matrix in CSC with sorted indices, as Clarabel wants ``P``.

    Sparse input: the triplets with ``row <= col`` (explicit zeros dropped),
    converted once.  Dense input (or sparse with at most :data:`DENSE_P_MAX`
    rows): the whole upper-triangle pattern, zeros included (a structural
    zero costs nothing at that size and the index arrays are cached).
    """
    n = S.shape[0]
    if n <= DENSE_P_MAX:
        U = upper_csc_arrays(S)
        return sp.csc_matrix((U.data, U.indices.copy(), U.indptr.copy()), shape=U.shape)
    C = S.tocoo() if sp.issparse(S) else sp.coo_matrix(np.asarray(S, dtype=np.float64))
    keep = (C.row <= C.col) & (C.data != 0.0)
    U = sp.csc_matrix((C.data[keep], (C.row[keep], C.col[keep])), shape=S.shape)
    U.sort_indices()
    return U


def local_conic_data(problem, formulation: str = "associated", *, threshold=None,
                     W_sym=None, q_shift=None) -> ConicData:
    """Local problem as a cone program in ``r``.

    ``min ½ rᵀ W_s r + q_shiftᵀ r  s.t.  -G r + s = g,  s ∈ C`` with ``W_s`` the
    symmetric part of ``W`` (or ``W_sym``) and ``q_shift = q`` by default.

    Parameters
    ----------
    problem : FrictionContactProblem
    formulation : {"associated", "coulomb", "tresca", "frictionless"}
        Selects the feasible set (``coulomb`` uses ``K_mu``, like associated).
    threshold : array_like, optional
        Tresca thresholds ``g`` (one per contact).
    W_sym : sparse matrix, optional
        Symmetric matrix to use for ``P`` (default ``problem.symmetric_part()``).
    q_shift : array_like, optional
        Linear term (default ``problem.q``).
    """
    cm = law_cone_map(problem, formulation, threshold)
    Ws = problem.symmetric_part() if W_sym is None else W_sym
    q = problem.q if q_shift is None else np.asarray(q_shift, dtype=np.float64)
    A = -cm.csc if Ws.shape[0] <= DENSE_P_MAX else -cm.G
    return ConicData(upper_csc_arrays(Ws), np.array(q, dtype=np.float64), A, cm.g.copy(), cm)


def global_conic_data(problem, *, w_shift=None) -> ConicData:
    """Global problem as a cone program in the velocities ``v``.

    ``min ½ vᵀ M_s v − fᵀ v  s.t.  Hᵀ v + w + w_shift ∈ K*_mu``, written as
    ``A = -G Hᵀ``, ``b = G (w + w_shift)``, ``G`` the dual-cone map.  The
    constraint multipliers are the impulses, ``r = Gᵀ z``; ``W = Hᵀ M⁻¹ H`` is
    never formed.

    Parameters
    ----------
    problem : GlobalFrictionContactProblem
    w_shift : array_like, optional
        Constant added to ``w`` (the De Saxcé shift ``mu ||u_T|| e_N``).
    """
    cm = dual_cone_map(problem.mu, problem.dim)
    M = problem.M
    Ms = (M + M.T) * 0.5
    w = problem.w if w_shift is None else problem.w + np.asarray(w_shift, dtype=np.float64)
    A = (-(cm.G @ problem.H.T.tocsc())).tocsc()
    A.sort_indices()
    b = cm.G @ w + cm.g
    return ConicData(upper_csc(Ms), -np.array(problem.f, dtype=np.float64), A, b, cm)


__all__ = ["CONE_KINDS", "CscArrays", "upper_csc_arrays", "dense_to_csr", "coulomb_constraint", "DENSE_P_MAX", "ConeMap", "ConicData", "coulomb_cone_map", "dual_cone_map", "frictionless_map",
           "tresca_map", "law_cone_map", "local_conic_data", "global_conic_data", "upper_csc"]
