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
import scipy.sparse.linalg as spla

from .errors import InvalidProblemError

#: Relative threshold (w.r.t. max |W|) below which W - W^T counts as round-off.
SYMMETRY_RTOL = 1e-10
#: Largest size for which a dense rank computation is attempted.
DENSE_RANK_LIMIT = 6000


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
    A.sum_duplicates()
    if not np.all(np.isfinite(A.data)):
        bad = int(np.count_nonzero(~np.isfinite(A.data)))
        raise InvalidProblemError(name, f"contains {bad} NaN/Inf entries", source)
    return A


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
    return np.ascontiguousarray(arr)


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
    return np.ascontiguousarray(arr)


def _n_contacts(m: int, dim: int, field_name: str, source) -> int:
    if m == 0:
        raise InvalidProblemError(field_name, "problem has zero contacts", source)
    if m % dim:
        raise InvalidProblemError(field_name, f"size {m} is not a multiple of dim = {dim}", source)
    return m // dim


def _numerical_rank(A: sp.spmatrix) -> Optional[int]:
    """Numerical rank of a sparse matrix (dense SVD); None when too large."""
    if max(A.shape) > DENSE_RANK_LIMIT:
        return None
    return int(np.linalg.matrix_rank(A.toarray()))


class _ProblemBase:
    """Attributes shared by local and global problems."""

    dim: int
    mu: np.ndarray
    source: Optional[str]
    name: str
    info: str
    solution: Optional[Solution]
    guesses: list

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
        return self.dim * self.n_contacts

    def reshape(self, x: np.ndarray) -> np.ndarray:
        """View a stacked contact vector as an ``(n_contacts, dim)`` array."""
        return np.asarray(x, dtype=np.float64).reshape(self.n_contacts, self.dim)

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
        self.W = W
        self.q = _as_vector(q, "q", W.shape[0], source)
        self.mu = _as_mu(mu, nc, source)
        self._init_meta(source, name, info, solution, guesses)

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
    def rank(self) -> Optional[int]:
        """Numerical rank of ``W`` (None when ``m`` exceeds DENSE_RANK_LIMIT)."""
        return _numerical_rank(self.W)

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

    def summary(self) -> dict:
        """Properties users inspect first (sizes, mu range, symmetry, rank)."""
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
            "rank": self.rank,
            "rank_deficient": self.is_rank_deficient,
            "has_solution": self.solution is not None,
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

    def solve_M(self, b) -> np.ndarray:
        """Solve ``M x = b`` with a cached sparse LU factorization."""
        return self._lu.solve(np.asarray(b, dtype=np.float64))

    def global_velocity(self, r) -> np.ndarray:
        """``v = M^{-1} (H r + f)``."""
        return self.solve_M(self.H @ np.asarray(r, dtype=np.float64) + self.f)

    def velocity(self, r) -> np.ndarray:
        """Local velocity ``u = H^T M^{-1} (H r + f) + w``."""
        return self.H.T @ self.global_velocity(r) + self.w

    @cached_property
    def q_local(self) -> np.ndarray:
        """Local free velocity ``q = H^T M^{-1} f + w``."""
        return self.H.T @ self.solve_M(self.f) + self.w

    def to_local(self, chunk: int = 512) -> FrictionContactProblem:
        """Condense to the local problem ``W = H^T M^{-1} H``, ``q = H^T M^{-1} f + w``.

        ``M^{-1}`` is never formed: a sparse LU of ``M`` is applied to blocks of
        ``chunk`` columns of ``H`` and the products are sparsified.
        """
        H = self.H.tocsc()
        HT = H.T.tocsr()
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
    def rank(self) -> Optional[int]:
        """Numerical rank of ``H`` (None when too large for a dense SVD)."""
        return _numerical_rank(self.H)

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

    def summary(self) -> dict:
        """Properties users inspect first (sizes, mu range, symmetry, rank)."""
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
            "rank": self.rank,
            "rank_deficient": self.is_rank_deficient,
            "has_solution": self.solution is not None,
        }

    def __repr__(self) -> str:
        return (f"GlobalFrictionContactProblem(name={self.name!r}, dim={self.dim}, "
                f"contacts={self.n_contacts}, dofs={self.n_dofs})")


__all__ = ["FrictionContactProblem", "GlobalFrictionContactProblem", "Solution"]
