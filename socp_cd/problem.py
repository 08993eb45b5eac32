"""Discrete frictional contact problems (the data of one Moreau–Jean time step).

Vocabulary used throughout socp_cd
----------------------------------
contact
    A pair of bodies that may touch; it carries a local frame whose first axis
    is the normal ``e_N`` (components are ordered *normal first*).
r
    Contact impulses (reactions), ``r = (r_N, r_T)`` per contact, stacked.
u
    Relative contact velocities, same layout as ``r``.
W
    The Delassus operator: the local (contact-space) inverse mass, so that the
    local problem reads ``u = W r + q``.
q
    Free relative velocity (what ``u`` would be without contact impulses).
mu
    Coulomb friction coefficient per contact; Coulomb cone
    ``K_mu = {(r_N, r_T) : ||r_T|| <= mu r_N}``.
M, H, f, w
    Global (FCLib) form: ``M v = H r + f`` and ``u = H^T v + w``, with ``M`` the
    ``n x n`` mass/iteration matrix, ``H`` the ``n x m`` contact Jacobian
    transpose (``m = dim * n_contacts``).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Optional

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from .errors import InvalidProblemError
from .residuals import error

#: Relative threshold (w.r.t. max |W|) below which W - W^T counts as round-off.
SYMMETRY_RTOL = 1e-10
#: Largest block (rows or columns) of a matrix factorized densely for its rank.
DENSE_RANK_LIMIT = 2000
#: Default tolerance of the "trivial at this tol" flag of ``summary()``.
TRIVIAL_TOL = 1e-8


@dataclass
class Solution:
    """A (reference or candidate) solution stored with a problem.

    Attributes
    ----------
    r, u : ndarray or None
        Contact impulses and relative velocities (normal first).
    v : ndarray or None
        Global velocities (global problems only).
    """

    r: Optional[np.ndarray] = None
    u: Optional[np.ndarray] = None
    v: Optional[np.ndarray] = None


def _reject_complex(x, name: str, source: str | None):
    """Raise when *x* holds complex numbers (NumPy would drop their imaginary part)."""
    dtype = x.dtype if sp.issparse(x) or isinstance(x, np.ndarray) else None
    if dtype is None:
        try:
            dtype = np.asarray(x).dtype
        except (TypeError, ValueError):
            return  # ragged or odd input: the float conversion reports it
    if dtype.kind == "c":
        raise InvalidProblemError(name, f"has complex dtype {dtype}; real values expected "
                                        "(the imaginary part is not dropped silently)", source)


def _as_sparse(A, name: str, source: str | None) -> sp.csr_matrix:
    """Convert *A* (dense or sparse) to float64 CSR, checking finiteness."""
    _reject_complex(A, name, source)
    try:
        if sp.issparse(A):
            A = sp.csr_matrix(A, dtype=np.float64)
        else:
            arr = np.asarray(A, dtype=np.float64)
            if arr.ndim != 2:
                raise InvalidProblemError(name, f"must be a 2-D matrix, got {arr.ndim}-D", source)
            A = sp.csr_matrix(arr)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InvalidProblemError):
            raise
        raise InvalidProblemError(name, f"cannot be converted to a float matrix ({exc})", source) from None
    if not A.has_canonical_format:
        # sum_duplicates sorts and sums in place, and A shares the caller's arrays: work on a
        # copy (the caller's matrix stays as given; a read-only one could not be sorted)
        A = A.copy()
        A.sum_duplicates()
    # the CSR arrays as compiled kernels read them (kernel_array); no copy when they already are
    index = _index_dtype(A)
    A.indptr, A.indices, A.data = (kernel_array(A.indptr, index), kernel_array(A.indices, index),
                                   kernel_array(A.data, np.float64))
    if not np.all(np.isfinite(A.data)):
        bad = int(np.count_nonzero(~np.isfinite(A.data)))
        raise InvalidProblemError(name, f"contains {bad} NaN/Inf entries", source)
    return A


def kernel_array(x, dtype=np.float64) -> np.ndarray:
    """``x`` as the compiled kernels read it: contiguous, of ``dtype``, writable.

    numba compiles a kernel once per combination of its arguments' types, and an array's
    type includes its dtype (int32 or int64 CSR indices), its layout and whether it is
    read-only (a user's ``np.frombuffer`` or memory map, the dispatcher's cached balanced
    copy).  One form per array means one compiled version of each kernel: compiling the
    other forms too took a fresh install's warm-up from 163-180 s to 286-321 s (session 37,
    ``validation/compile_cost.py``).  No copy when ``x`` already has that form.
    """
    x = np.ascontiguousarray(x, dtype=dtype)
    return x if x.flags.writeable else x.copy()


def _index_dtype(A) -> type:
    """The CSR index dtype of the kernels: int32, or int64 when ``A`` is too large for it."""
    return np.int32 if max(A.nnz, *A.shape) < np.iinfo(np.int32).max else np.int64


def csr_of_nonzeros(D) -> sp.csr_matrix:
    """The nonzero entries of a dense 2-D float array as a CSR matrix (sorted columns),
    without scipy's dense-input conversion."""
    D = np.asarray(D, dtype=np.float64)
    n, k = D.shape
    rows, cols = np.nonzero(D)                  # row-major: already in CSR order
    indptr = np.zeros(n + 1, dtype=np.int32)
    np.cumsum(np.bincount(rows, minlength=n), out=indptr[1:])
    return sp.csr_matrix((D[rows, cols], cols.astype(np.int32), indptr), shape=(n, k))


def _as_vector(x, name: str, n: int, source: str | None) -> np.ndarray:
    """Convert *x* to a finite float64 vector of length *n*."""
    _reject_complex(x, name, source)
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidProblemError(name, f"cannot be converted to floats ({exc})", source) from None
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise InvalidProblemError(name, f"must be a vector, got shape {arr.shape}", source)
    if arr.shape[0] != n:
        raise InvalidProblemError(name, f"has length {arr.shape[0]}, expected {n}", source)
    if not np.all(np.isfinite(arr)):
        raise InvalidProblemError(name, f"contains {int(np.count_nonzero(~np.isfinite(arr)))} NaN/Inf entries", source)
    return kernel_array(arr, np.float64)


def _check_dim(dim, source):
    if not isinstance(dim, (int, np.integer)) or int(dim) not in (2, 3):
        raise InvalidProblemError("dim", f"must be 2 or 3, got {dim!r}", source)
    return int(dim)


def _as_mu(mu, n_contacts: int, source: str | None) -> np.ndarray:
    """Broadcast *mu* to one finite, non-negative coefficient per contact."""
    _reject_complex(mu, "mu", source)
    try:
        arr = np.asarray(mu, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise InvalidProblemError("mu", f"cannot be converted to floats ({exc})", source) from None
    if arr.size == 1 and n_contacts != 1:
        arr = np.full(n_contacts, float(arr[0]))
    if arr.size != n_contacts:
        raise InvalidProblemError("mu", f"has {arr.size} entries, expected {n_contacts} (one per contact)", source)
    if not np.all(np.isfinite(arr)):
        raise InvalidProblemError("mu", "contains NaN/Inf", source)
    if np.any(arr < 0):
        i = int(np.flatnonzero(arr < 0)[0])
        raise InvalidProblemError("mu", f"must be >= 0, contact {i} has mu = {arr[i]!r}", source)
    return kernel_array(arr, np.float64)


def _n_contacts(m: int, dim: int, field_name: str, source) -> int:
    if m == 0:
        raise InvalidProblemError(field_name, "problem has zero contacts", source)
    if m % dim:
        raise InvalidProblemError(field_name, f"size {m} is not a multiple of dim = {dim}", source)
    return m // dim


@dataclass(frozen=True)
class RankReport:
    """Numerical rank of a sparse matrix and how it was obtained.

    Attributes
    ----------
    rank : int or None
        Number of singular values above ``max(shape) * eps * sigma_max`` (the
        NumPy ``matrix_rank`` rule on the whole matrix); None when not computed.
    structural : int
        Structural rank (maximum matching of the sparsity pattern): an upper
        bound of the numerical rank, always computed (cheap).
    method : str
        One line saying how ``rank`` was computed, or why it was not.
    """

    rank: Optional[int]
    structural: int
    method: str


#: Bytes of dense blocks factorized in one batched SVD call.
_RANK_BATCH_BYTES = 64 << 20


def _dense_blocks(coo, row_lab, col_lab, rows_per, cols_per, blocks):
    """Yield ``(block ids, stack)``: the listed blocks as dense arrays, batched by shape.

    ``stack[k]`` is block ``ids[k]`` (its rows and columns in increasing order),
    so that ``np.linalg.svd`` factorizes all blocks of one shape in one call.
    """
    def local_index(labels, per):
        order = np.argsort(labels, kind="stable")
        start = np.concatenate(([0], np.cumsum(per)))
        pos = np.empty(labels.size, dtype=np.int64)
        pos[order] = np.arange(labels.size) - start[labels[order]]
        return pos

    row_pos, col_pos = local_index(row_lab, rows_per), local_index(col_lab, cols_per)
    entry_block = row_lab[coo.row]
    shapes = np.stack([rows_per[blocks], cols_per[blocks]], axis=1)
    for r, c in np.unique(shapes, axis=0):
        same = blocks[(shapes[:, 0] == r) & (shapes[:, 1] == c)]
        per_batch = max(1, _RANK_BATCH_BYTES // (8 * int(r) * int(c)))
        for k in range(0, same.size, per_batch):
            ids = same[k:k + per_batch]
            slot = np.full(rows_per.size, -1, dtype=np.int64)
            slot[ids] = np.arange(ids.size)
            sel = slot[entry_block] >= 0
            stack = np.zeros((ids.size, r, c))
            np.add.at(stack, (slot[entry_block[sel]], row_pos[coo.row[sel]], col_pos[coo.col[sel]]),
                      coo.data[sel])
            yield ids, stack


def numerical_rank(A: sp.spmatrix, limit: int = DENSE_RANK_LIMIT) -> RankReport:
    """Numerical rank of *A*, by dense SVDs of its independent blocks.

    Rows and columns are grouped into the connected components of the
    bipartite graph of the nonzeros (contacts coupled through shared bodies);
    up to a permutation *A* is block diagonal in these groups, so its singular
    values are those of the blocks.  Each block is factorized densely; when
    the largest one exceeds *limit* rows or columns the rank is not computed
    (only the structural rank is reported).  A diagonal 6000 x 6000 matrix
    thus costs 6000 SVDs of size 1, not one of size 6000.
    """
    A = sp.csr_matrix(A)
    m, n = A.shape
    structural = int(csgraph.structural_rank(A)) if A.nnz else 0
    pattern = sp.csr_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
    graph = sp.bmat([[None, pattern], [pattern.T, None]], format="csr")
    n_blocks, labels = csgraph.connected_components(graph, directed=False)
    row_lab, col_lab = labels[:m], labels[m:]
    rows_per = np.bincount(row_lab, minlength=n_blocks)
    cols_per = np.bincount(col_lab, minlength=n_blocks)
    coupled = (rows_per > 0) & (cols_per > 0) & (np.bincount(row_lab, weights=np.diff(A.indptr),
                                                             minlength=n_blocks) > 0)
    big = int(np.max(np.maximum(rows_per, cols_per)[coupled], initial=0))
    if big > limit:
        return RankReport(None, structural,
                          f"not computed: largest coupled block has {big} rows/columns > {limit} "
                          f"(structural rank {structural} is an upper bound)")
    sigmas = [np.zeros(0)]
    for shape_blocks, stack in _dense_blocks(A.tocoo(), row_lab, col_lab, rows_per, cols_per,
                                             np.flatnonzero(coupled)):
        sigmas.append(np.linalg.svd(stack, compute_uv=False).reshape(-1))
    sv = np.concatenate(sigmas)
    tol = (sv.max() if sv.size else 0.0) * max(m, n) * np.finfo(np.float64).eps
    return RankReport(int(np.count_nonzero(sv > tol)), structural,
                      f"dense SVD of {int(coupled.sum())} independent blocks (largest {big})")


class _ProblemBase:
    """Attributes shared by local and global problems."""

    dim: int
    mu: np.ndarray
    source: Optional[str]
    name: str
    info: str
    solution: Optional[Solution]
    guesses: list

    #: the data fields: set once, by the constructor (compiled kernels read them with fixed
    #: types, and per-problem caches are derived from them)
    _DATA_FIELDS = frozenset({"dim", "q", "mu", "M", "H", "f", "w"})

    def __setattr__(self, name, value):
        """Refuse to assign a data field of a built problem (:data:`_DATA_FIELDS`).

        A problem is immutable: another ``q`` or ``mu`` (of another dtype, say) would be
        read by compiled code as the type it was built with, and the caches derived from the
        old one would stay.  Only attribute *assignment* goes through here (reads, and the
        caches ``functools.cached_property`` writes, do not): no cost per solve.
        """
        if name in self._DATA_FIELDS and name in self.__dict__:
            raise InvalidProblemError(name, "a problem is immutable once built; make a new "
                                      "one (problem.with_(...))", self.__dict__.get("source"))
        object.__setattr__(self, name, value)

    def _init_meta(self, source, name, info, solution, guesses):
        self.source = None if source is None else str(source)
        self.name = name or (self.source.rsplit("/", 1)[-1] if self.source else "problem")
        self.info = info or ""
        self.solution = solution
        self.guesses = list(guesses or [])

    @property
    def n_contacts(self) -> int:
        """Number of contacts."""
        return self.mu.shape[0]

    @property
    def m(self) -> int:
        """Number of contact unknowns, ``dim * n_contacts``."""
        return self.dim * self.mu.shape[0]      # (not through n_contacts: read on every call)

    def reshape(self, x: np.ndarray) -> np.ndarray:
        """View a stacked contact vector as an ``(n_contacts, dim)`` array."""
        return np.asarray(x, dtype=np.float64).reshape(self.n_contacts, self.dim)

    # Per-problem quantities that do not depend on ``r``, computed once.  A problem
    # is treated as immutable: its data (``W, q, mu`` or ``M, H, f, w``) are not
    # changed after construction (build a new one, e.g. with ``with_``, instead).

    @cached_property
    def zero_error(self) -> Optional[float]:
        """Siconos error of ``r = 0``, computed once (None when ``M`` is singular)."""
        try:
            return error(self, np.zeros(self.m), self.q_local)     # u(r = 0) = q_local
        except InvalidProblemError:
            return None

    def trivial_error(self) -> Optional[float]:
        """Siconos error of ``r = 0`` (None when ``M`` is singular); see :attr:`zero_error`."""
        return self.zero_error

    @cached_property
    def q_norm(self) -> float:
        """``||q||`` of the local free velocity (Siconos' error normalization), computed once."""
        q = self.q_local
        return float(np.sqrt(q.dot(q)))        # = np.linalg.norm(q), without its Python overhead

    def derived(self, key: str, compute):
        """A quantity derived from the problem's data by a layer above the problem model.

        ``compute(problem)`` runs the first time ``key`` is asked for on this
        object; the value is kept on it, as the cached properties are (so a
        shallow copy made afterwards shares it, a new problem computes its
        own).  The dispatcher keeps its balanced copy and unit factors here
        (:func:`socp_cd.solvers.scaling.balanced`).

        Parameters
        ----------
        key : str
            Name of the quantity (one per computing module).
        compute : callable
            ``compute(problem) -> value``.
        """
        slot = "derived:" + key
        try:
            return self.__dict__[slot]
        except KeyError:
            value = compute(self)
            self.__dict__[slot] = value
            return value

    def _summary_common(self, tol: float) -> dict:
        """Summary entries shared by local and global problems.

        ``trivial`` is True when ``r = 0`` already meets *tol* (``error(r=0) <= tol``):
        with ``||q||`` about 1e-18 any solver "converges" at once, so a study
        must not count such problems as wins.  ``rank_method`` says how
        ``rank`` was obtained (or why not); ``structural_rank`` bounds it.
        """
        err0 = self.trivial_error()
        report = self.rank_report
        return {
            "rank": report.rank,
            "structural_rank": report.structural,
            "rank_method": report.method,
            "rank_deficient": self.is_rank_deficient,
            "error(r=0)": err0,
            f"trivial@{tol:g}": None if err0 is None else bool(err0 <= tol),
            "has_solution": self.solution is not None,
        }

    def check_reaction(self, r, name: str = "r") -> np.ndarray:
        """Validate a candidate reaction vector (length, finiteness)."""
        return _as_vector(r, name, self.m, self.source)


class FrictionContactProblem(_ProblemBase):
    """Local frictional contact problem ``u = W r + q``, Coulomb law per contact.

    Parameters
    ----------
    W : array_like or scipy.sparse matrix, shape (m, m)
        Delassus operator, ``m = dim * n_contacts``; stored as CSR.
    q : array_like, shape (m,)
        Free local velocity.
    mu : float or array_like, shape (n_contacts,)
        Friction coefficients (>= 0); a scalar is broadcast.
    dim : {2, 3}
        Dimension of the contact frames.
    source, name, info : str, optional
        Provenance (file path, display name, free text).
    solution : Solution, optional
        Reference solution shipped with the data.
    guesses : list of Solution, optional
        Initial guesses shipped with the data.

    Raises
    ------
    InvalidProblemError
        On wrong shapes, NaN/Inf, negative mu, invalid dim or zero contacts.

    Notes
    -----
    Asymmetry and rank deficiency of ``W`` are legitimate (they occur in real
    data) and are reported by :attr:`is_symmetric`, :attr:`asymmetry`,
    :attr:`rank` and :attr:`is_rank_deficient` rather than rejected.

    A problem is immutable once built: it may share the caller's arrays (no
    copy is made when they are already contiguous, writable float64 arrays and
    int32 CSR indices, the form the compiled kernels are compiled for:
    :func:`kernel_array`; other forms are copied into it), and the quantities derived
    from them (the error of ``r = 0``, ``||q||``, the dispatcher's unit
    factors and balanced copy, NSGS's block storage, the Newton matrix's pattern
    and column order) are computed once per object.  Changing ``W``, ``q`` or
    ``mu`` in place afterwards leaves those stale; assigning other arrays to ``q``,
    ``mu`` or ``dim`` is refused
    (:class:`~socp_cd.errors.InvalidProblemError`: compiled code reads them as
    contiguous float64 vectors, :mod:`socp_cd.solvers.kernels.entry`). Build a
    new problem instead (:meth:`with_`).
    """

    is_global = False

    def __init__(self, W, q, mu, dim: int = 3, *, source=None, name=None, info=None,
                 solution: Optional[Solution] = None, guesses=None):
        dim = _check_dim(dim, source)
        W = _as_sparse(W, "W", source)
        if W.shape[0] != W.shape[1]:
            raise InvalidProblemError("W", f"must be square, got shape {W.shape}", source)
        nc = _n_contacts(W.shape[0], dim, "W", source)
        self.dim = dim
        self._W, self._csr_parts = W, (W.indptr, W.indices, W.data)
        self.q = _as_vector(q, "q", W.shape[0], source)
        self.mu = _as_mu(mu, nc, source)
        self._init_meta(source, name, info, solution, guesses)

    @property
    def W(self) -> sp.csr_matrix:
        """The Delassus operator, CSR (built on first use for a problem made from CSR arrays)."""
        W = self._W
        if W is None:
            indptr, indices, data = self._csr_parts
            W = self._W = sp.csr_matrix((data, indices, indptr), shape=(self.m, self.m))
        return W

    @property
    def csr_parts(self) -> tuple:
        """``(indptr, indices, data)`` of ``W`` in CSR form, without building a scipy matrix.

        Compiled kernels read these; a problem derived with :meth:`from_checked`
        from CSR arrays builds its scipy matrix only when :attr:`W` is asked for.
        (The tuple is made once, with the problem, or on first use when the problem was
        made without it: made on every call it cost 0.07 µs of a one-contact solve.)
        """
        parts = self._csr_parts
        if parts is None:
            W = self._W
            parts = self._csr_parts = (W.indptr, W.indices, W.data)
        return parts

    @classmethod
    def from_checked(cls, W, q: np.ndarray, mu: np.ndarray, dim: int, *,
                     source=None, name=None, info=None, solution: Optional[Solution] = None,
                     guesses=None) -> "FrictionContactProblem":
        """A problem from data already in validated form, without checking them again.

        For code that derives a problem from a validated one (e.g. the
        dispatcher's balanced copy, :mod:`socp_cd.solvers.scaling`): ``W`` a
        square float64 CSR matrix of size ``m = dim * n_contacts`` with summed
        duplicates, finite entries and contiguous arrays, or those arrays ``(indptr, indices, data)``
        (the scipy matrix is then built on first use of :attr:`W`), ``q`` a finite contiguous float64
        vector of length ``m``, ``mu`` a finite, non-negative contiguous float64
        vector with one entry per contact, ``dim`` 2 or 3.  Data from users or
        files go through the constructor, which checks all of this.  The arrays are kept as
        given: in :func:`kernel_array`'s form they reach the kernels' one compiled version
        (the balanced copy's ``q`` is read-only on purpose, and the backends that run on it
        pass ``kernel_array(problem.q)``).
        """
        self = cls.__new__(cls)
        self.dim = int(dim)
        self._W, self._csr_parts = ((None, W) if isinstance(W, tuple)
                                    else (W, (W.indptr, W.indices, W.data)))
        self.q = q
        self.mu = mu
        self._init_meta(source, name, info, solution, guesses)
        return self

    def rescaled(self, a, b, *, W_data=None, q=None) -> "FrictionContactProblem":
        """The same problem in other units: ``r = a r~``, ``u = b u~`` (one factor per contact).

        ``u~ = (S W S) r~ + q / b`` with ``S = diag(sqrt(a / b))`` (``W`` keeps its
        sparsity; ``a / b`` must be constant over each contact's components
        and positive, as :func:`socp_cd.residuals.contact_scales` gives);
        stored solutions and guesses are converted (``v`` is dropped: not a
        local quantity).  Built with :meth:`from_checked` (no validation).
        ``W_data`` (the entries of ``S W S`` on ``W``'s sparsity) and ``q``
        (``q / b``) may be passed when already computed (the dispatcher's
        compiled balancing, :mod:`socp_cd.solvers.scaling`).
        """
        indptr, indices, data = self.csr_parts
        if W_data is None:
            s = np.sqrt(a / b)                          # s_i = 1/sqrt(d_i) for the balancing scales
            rows = np.repeat(np.arange(self.m), np.diff(indptr))
            W_data = data * (s[rows] * s[indices])

        def convert(sol: Solution) -> Solution:
            return Solution(r=None if sol.r is None else sol.r / a,
                            u=None if sol.u is None else sol.u / b)

        return FrictionContactProblem.from_checked(     # S W S, same sparsity
            (indptr, indices, W_data), self.q / b if q is None else q, self.mu, self.dim,
            source=self.source,
            name=self.name, info=self.info,
            solution=None if self.solution is None else convert(self.solution),
            guesses=[convert(g) for g in self.guesses])

    # ------------------------------------------------------------------ algebra
    def velocity(self, r) -> np.ndarray:
        """Local velocity ``u = W r + q``."""
        return self.W @ np.asarray(r, dtype=np.float64) + self.q

    @property
    def q_local(self) -> np.ndarray:
        """The local free velocity ``q`` (same name as for global problems)."""
        return self.q

    @cached_property
    def asymmetry(self) -> float:
        """``max |W - W^T|`` (absolute)."""
        D = (self.W - self.W.T).tocsr()
        return float(np.max(np.abs(D.data))) if D.nnz else 0.0

    @cached_property
    def scale(self) -> float:
        """``max |W|``."""
        return float(np.max(np.abs(self.W.data))) if self.W.nnz else 0.0

    @property
    def is_symmetric(self) -> bool:
        """True when ``max|W - W^T| <= SYMMETRY_RTOL * max|W|``."""
        return self.asymmetry <= SYMMETRY_RTOL * max(self.scale, np.finfo(float).tiny)

    def symmetric_part(self) -> sp.csr_matrix:
        """``(W + W^T) / 2``."""
        return ((self.W + self.W.T) * 0.5).tocsr()

    def skew_part(self) -> sp.csr_matrix:
        """``(W - W^T) / 2``."""
        return ((self.W - self.W.T) * 0.5).tocsr()

    @cached_property
    def rank_report(self) -> RankReport:
        """Numerical and structural rank of ``W`` (see :func:`numerical_rank`)."""
        return numerical_rank(self.W)

    @property
    def rank(self) -> Optional[int]:
        """Numerical rank of ``W`` (None when a coupled block exceeds DENSE_RANK_LIMIT)."""
        return self.rank_report.rank

    @property
    def is_rank_deficient(self) -> Optional[bool]:
        """True when ``W`` is singular (then ``r`` is not unique, ``u`` is)."""
        return None if self.rank is None else self.rank < self.m

    def diagonal_blocks(self) -> np.ndarray:
        """The ``dim x dim`` diagonal blocks of ``W``, shape ``(n_contacts, dim, dim)``."""
        d, nc = self.dim, self.n_contacts
        rows = np.arange(self.m)
        out = np.zeros((nc, d, d))
        Wc = self.W.tocsr()
        for j in range(d):  # d <= 3 vectorized passes, no loop over contacts
            cols = (rows // d) * d + j
            out[:, :, j] = np.asarray(Wc[rows, cols]).reshape(nc, d)
        return out

    def with_(self, **changes) -> "FrictionContactProblem":
        """A copy with some of ``W, q, mu`` replaced (validated again)."""
        args = dict(W=self.W, q=self.q, mu=self.mu, dim=self.dim, source=self.source,
                    name=self.name, info=self.info)
        args.update(changes)
        return FrictionContactProblem(**args)

    def summary(self, tol: float = TRIVIAL_TOL) -> dict:
        """Properties users inspect first (sizes, mu range, symmetry, rank, triviality).

        See :meth:`_ProblemBase._summary_common` for the rank and ``trivial`` entries.
        """
        return {
            "name": self.name,
            "type": "local",
            "dim": self.dim,
            "contacts": self.n_contacts,
            "unknowns": self.m,
            "dofs": None,
            "nnz(W)": int(self.W.nnz),
            "mu": (float(self.mu.min()), float(self.mu.max())),
            "symmetric": self.is_symmetric,
            "max|W-W^T|": self.asymmetry,
            "max|W|": self.scale,
            **self._summary_common(tol),
        }

    def __repr__(self) -> str:
        return (f"FrictionContactProblem(name={self.name!r}, dim={self.dim}, "
                f"contacts={self.n_contacts}, nnz(W)={self.W.nnz})")


class GlobalFrictionContactProblem(_ProblemBase):
    """Global frictional contact problem (FCLib convention).

    ``M v = H r + f``, ``u = H^T v + w``, Coulomb law between ``r`` and ``u``.

    Parameters
    ----------
    M : array_like or sparse, shape (n, n)
        Mass (iteration) matrix; must be nonsingular for :meth:`to_local`.
    H : array_like or sparse, shape (n, m)
        Transpose of the contact Jacobian, ``m = dim * n_contacts``.
    f : array_like, shape (n,)
    w : array_like, shape (m,)
    mu : float or array_like, shape (n_contacts,)
    dim : {2, 3}
    """

    is_global = True

    def __init__(self, M, H, f, w, mu, dim: int = 3, *, source=None, name=None, info=None,
                 solution: Optional[Solution] = None, guesses=None):
        dim = _check_dim(dim, source)
        M = _as_sparse(M, "M", source)
        H = _as_sparse(H, "H", source)
        if M.shape[0] != M.shape[1]:
            raise InvalidProblemError("M", f"must be square, got shape {M.shape}", source)
        if M.shape[0] == 0:
            raise InvalidProblemError("M", "has zero degrees of freedom", source)
        if H.shape[0] != M.shape[0]:
            raise InvalidProblemError("H", f"has {H.shape[0]} rows, expected {M.shape[0]} (rows of M)", source)
        nc = _n_contacts(H.shape[1], dim, "H", source)
        self.dim = dim
        self.M = M
        self.H = H
        self.f = _as_vector(f, "f", M.shape[0], source)
        self.w = _as_vector(w, "w", H.shape[1], source)
        self.mu = _as_mu(mu, nc, source)
        self._init_meta(source, name, info, solution, guesses)

    @property
    def n_dofs(self) -> int:
        """Number of global degrees of freedom ``n``."""
        return self.M.shape[0]

    @cached_property
    def _lu(self):
        try:
            lu = spla.splu(self.M.tocsc())
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise InvalidProblemError("M", f"is singular ({exc})", self.source) from None
        return lu

    @cached_property
    def _HT(self):
        """``Hᵀ`` (a CSC view of ``H``), built once: every ``u`` needs it."""
        return self.H.T

    def solve_M(self, b) -> np.ndarray:
        """Solve ``M x = b`` with a cached sparse LU factorization."""
        return self._lu.solve(np.asarray(b, dtype=np.float64))

    def global_velocity(self, r) -> np.ndarray:
        """``v = M^{-1} (H r + f)``."""
        return self.solve_M(self.H @ np.asarray(r, dtype=np.float64) + self.f)

    def velocity(self, r) -> np.ndarray:
        """Local velocity ``u = H^T M^{-1} (H r + f) + w``."""
        return self._HT @ self.global_velocity(r) + self.w

    @cached_property
    def q_local(self) -> np.ndarray:
        """Local free velocity ``q = H^T M^{-1} f + w``."""
        return self._HT @ self.solve_M(self.f) + self.w

    def to_local(self, chunk: int = 512) -> FrictionContactProblem:
        """Condense to the local problem ``W = H^T M^{-1} H``, ``q = H^T M^{-1} f + w``.

        ``M^{-1}`` is never formed: a sparse LU of ``M`` is applied to blocks of
        ``chunk`` columns of ``H`` and the products are sparsified.
        """
        H = self.H.tocsc()
        HT = H.T.tocsr()
        if self.m <= chunk:                  # one block: a dense product, its nonzeros kept
            W = csr_of_nonzeros(np.asarray(HT @ self.solve_M(H.toarray())))
        else:
            blocks = []
            for start in range(0, self.m, chunk):
                X = self.solve_M(H[:, start:start + chunk].toarray())
                blocks.append(sp.csc_matrix(HT @ X))
            W = sp.hstack(blocks).tocsr()
            W.eliminate_zeros()
        sol = None
        if self.solution is not None:
            sol = Solution(r=self.solution.r, u=self.solution.u)
        return FrictionContactProblem(W, self.q_local, self.mu, self.dim, source=self.source,
                                      name=self.name, info=self.info, solution=sol,
                                      guesses=[Solution(r=g.r, u=g.u) for g in self.guesses])

    @cached_property
    def local(self) -> FrictionContactProblem:
        """:meth:`to_local`, computed once (what :func:`socp_cd.solve` condenses to
        for a backend that does not solve the global form natively)."""
        return self.to_local()

    @cached_property
    def rank_report(self) -> RankReport:
        """Numerical and structural rank of ``H`` (see :func:`numerical_rank`)."""
        return numerical_rank(self.H)

    @property
    def rank(self) -> Optional[int]:
        """Numerical rank of ``H`` (None when a coupled block exceeds DENSE_RANK_LIMIT)."""
        return self.rank_report.rank

    @property
    def is_rank_deficient(self) -> Optional[bool]:
        """True when ``rank(H) < m`` (more contact unknowns than independent dofs)."""
        return None if self.rank is None else self.rank < self.m

    @cached_property
    def asymmetry(self) -> float:
        """``max |M - M^T|``."""
        D = (self.M - self.M.T).tocsr()
        return float(np.max(np.abs(D.data))) if D.nnz else 0.0

    @property
    def is_symmetric(self) -> bool:
        """True when ``M`` is symmetric up to round-off."""
        scale = float(np.max(np.abs(self.M.data))) if self.M.nnz else 0.0
        return self.asymmetry <= SYMMETRY_RTOL * max(scale, np.finfo(float).tiny)

    def summary(self, tol: float = TRIVIAL_TOL) -> dict:
        """Properties users inspect first (sizes, mu range, symmetry, rank, triviality).

        See :meth:`_ProblemBase._summary_common` for the rank and ``trivial`` entries.
        """
        return {
            "name": self.name,
            "type": "global",
            "dim": self.dim,
            "contacts": self.n_contacts,
            "unknowns": self.m,
            "dofs": self.n_dofs,
            "nnz(M)": int(self.M.nnz),
            "nnz(H)": int(self.H.nnz),
            "mu": (float(self.mu.min()), float(self.mu.max())),
            "symmetric": self.is_symmetric,
            "max|M-M^T|": self.asymmetry,
            **self._summary_common(tol),
        }

    def __repr__(self) -> str:
        return (f"GlobalFrictionContactProblem(name={self.name!r}, dim={self.dim}, "
                f"contacts={self.n_contacts}, dofs={self.n_dofs})")


__all__ = ["FrictionContactProblem", "GlobalFrictionContactProblem", "Solution"]
