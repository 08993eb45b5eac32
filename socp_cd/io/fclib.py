"""FCLib HDF5 problems (the Frictional Contact Library format).

Layout
------
local problem
    ``/fclib_local/{spacedim, W, vectors/q, vectors/mu, info}``
global problem
    ``/fclib_global/{spacedim, M, H, vectors/f, vectors/w, vectors/mu, info}``
    (``M v = H r + f``, ``u = H^T v + w``)
optional
    ``/solution/{r, u, v}``, ``/guesses/{number_of_guesses, 1, 2, ...}``
    (each guess a group with ``r, u[, v]``), ``info/{title, description, math_info}``.

A matrix is a group with integer datasets ``nzmax, m, n, nz`` and arrays
``p, i, x``.  ``nz = -1``: compressed columns (``p`` has ``n + 1`` pointers,
``i`` row indices); ``nz = -2``: compressed rows (``p`` has ``m + 1`` pointers,
``i`` column indices); ``nz >= 0``: triplet form with ``nz`` entries, ``i``
holding row and ``p`` column indices (as in the FCLib files, whatever the
FCLib header comment says).  ``nzmax`` may exceed the number of entries; only
the first ``nz`` (triplet) or ``p[-1]`` (compressed) entries count.

``info`` of a problem read from FCLib is ``title`` followed, when the
description is not empty, by a newline and ``description``; :func:`write_fclib`
splits it back at the first newline.  ``math_info`` is not kept.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidProblemError, ProblemFormatError
from .paths import source_name
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem, Solution

#: Largest ratio of declared to stored bytes accepted for a filtered (compressed)
#: dataset: deflate cannot expand data more than about 1032 times.
MAX_EXPANSION = 1100
#: Bytes a dataset may declare beyond what it stores (times MAX_EXPANSION when
#: filtered), besides the size of the file: HDF5 returns the fill value (0) for
#: what was never written, and real files hold such datasets (an unwritten
#: ``/solution/r`` in Box_Stacks), but a few kilobytes cannot declare gigabytes.
UNSTORED_SLACK = 1 << 20

#: Errors h5py/numpy may raise on corrupt or unexpected content.
_H5_ERRORS = (OSError, KeyError, ValueError, TypeError, RuntimeError, IndexError, AttributeError)


class _Reader:
    """Checked access to the datasets of one open FCLib file."""

    def __init__(self, h5, source: str):
        self.h5 = h5
        self.source = source
        try:
            self.file_size = Path(source).stat().st_size
        except OSError:
            self.file_size = 0

    def err(self, field, reason):
        return ProblemFormatError(field, reason, self.source)

    def node(self, path: str, kind: str = "dataset"):
        import h5py
        try:
            obj = self.h5.get(path)
        except _H5_ERRORS as exc:
            raise self.err(path, f"cannot be read ({exc}); truncated or corrupt file?") from None
        if obj is None:
            raise self.err(path, f"missing {kind}")
        want = h5py.Dataset if kind == "dataset" else h5py.Group
        if not isinstance(obj, want):
            raise self.err(path, f"is not a {kind}")
        return obj

    def dataset(self, path: str, *, size: int | None = None, at_least: int | None = None):
        """The dataset at *path*, its declared size checked before anything is read.

        Parameters
        ----------
        size, at_least : int, optional
            Number of values required (exactly / at least), known from the
            size fields (``m, n, nz``) read before.

        Raises
        ------
        ProblemFormatError
            Wrong declared size, or a declared size far beyond what the file
            stores for the dataset (see ``UNSTORED_SLACK``).
        """
        ds = self.node(path)
        try:
            declared = int(ds.size or 0)  # a null dataspace has size None
            itemsize = ds.dtype.itemsize
            stored = ds.id.get_storage_size()
            filtered = bool(ds.compression or ds.id.get_create_plist().get_nfilters())
        except _H5_ERRORS as exc:
            raise self.err(path, f"cannot be read ({exc}); truncated or corrupt file?") from None
        if size is not None and declared != size:
            raise self.err(path, f"has length {declared}, expected {size}")
        if at_least is not None and declared < at_least:
            raise self.err(path, f"has {declared} entries, at least {at_least} expected "
                                 "(from the size fields m, n, nz or the pointer array)")
        nbytes = declared * itemsize
        limit = (MAX_EXPANSION if filtered else 1) * stored + self.file_size + UNSTORED_SLACK
        if nbytes > limit:
            raise self.err(path, f"declares {declared} values ({nbytes} bytes), far more than the "
                                 f"file ({self.file_size} bytes) stores for it ({stored} bytes): "
                                 "truncated or inflated size")
        return ds

    def array(self, path: str, *, size: int | None = None, at_least: int | None = None,
              count: int | None = None) -> np.ndarray:
        """Read a dataset (its first *count* values only, when given) as a flat array."""
        ds = self.dataset(path, size=size, at_least=at_least)
        try:
            if count is not None and ds.ndim == 1:
                arr = np.asarray(ds[:count])
            else:
                arr = np.asarray(ds[()]).reshape(-1)[:count]
        except _H5_ERRORS as exc:
            raise self.err(path, f"cannot be read ({exc}); truncated or corrupt file?") from None
        return arr

    def numeric(self, path: str, dtype=np.float64, **sizes) -> np.ndarray:
        arr = self.array(path, **sizes)
        if arr.dtype.kind not in "biuf":
            raise self.err(path, f"must be numeric, got dtype {arr.dtype}")
        return arr.astype(dtype, copy=False).reshape(-1)

    def integer(self, path: str) -> int:
        arr = self.numeric(path, np.float64, size=1)
        val = arr[0]
        if not np.isfinite(val) or val != int(val):
            raise self.err(path, f"must be an integer, got {val!r}")
        return int(val)

    def vector(self, path: str, n: int | None = None) -> np.ndarray:
        arr = self.numeric(path, size=n)
        if not np.all(np.isfinite(arr)):
            raise self.err(path, f"contains {int(np.count_nonzero(~np.isfinite(arr)))} NaN/Inf entries")
        return np.ascontiguousarray(arr, dtype=np.float64)

    def text(self, path: str) -> str:
        """A string stored as a dataset, or as an attribute of the parent group."""
        parent, _, key = path.rpartition("/")
        try:
            if path in self.h5:
                arr = self.array(path, count=1)
            elif parent in self.h5 and key in self.h5[parent].attrs:
                arr = np.asarray(self.h5[parent].attrs[key])
            else:
                return ""
        except _H5_ERRORS:
            return ""
        val = arr.reshape(-1)[0] if arr.size else b""
        if isinstance(val, bytes):
            return val.rstrip(b"\0").decode("utf-8", errors="replace")
        return str(val)

    def matrix(self, path: str) -> sp.spmatrix:
        """Read an FCLib matrix group (CSC, CSR or triplet) as a sparse matrix."""
        self.node(path, "group")
        m = self.integer(f"{path}/m")
        n = self.integer(f"{path}/n")
        nz = self.integer(f"{path}/nz")
        self.integer(f"{path}/nzmax")
        if m < 0 or n < 0:
            raise self.err(path, f"negative size {m} x {n}")
        if nz >= 0:  # triplet: i rows, p columns, nz entries each
            i = self._indices(f"{path}/i", nz)
            p = self._indices(f"{path}/p", nz)
            x = self.numeric(f"{path}/x", at_least=nz, count=nz)
            self._check_range(f"{path}/i", i, m, "row")
            self._check_range(f"{path}/p", p, n, "column")
            return sp.coo_matrix((x, (i, p)), shape=(m, n))
        if nz not in (-1, -2):
            raise self.err(f"{path}/nz", f"unknown storage code {nz} (-1 CSC, -2 CSR, >= 0 triplet)")
        outer, inner, kind = (n, m, "column") if nz == -1 else (m, n, "row")
        p = self._indices(f"{path}/p", outer + 1)
        if p[0] != 0 or np.any(np.diff(p) < 0):
            raise self.err(f"{path}/p", f"{kind} pointers must start at 0 and be non-decreasing")
        nnz = int(p[-1])
        idx = self._indices(f"{path}/i", nnz)
        x = self.numeric(f"{path}/x", at_least=nnz, count=nnz)
        self._check_range(f"{path}/i", idx, inner, "row" if nz == -1 else "column")
        cls = sp.csc_matrix if nz == -1 else sp.csr_matrix
        return cls((x, idx, p), shape=(m, n))

    def _indices(self, path: str, count: int) -> np.ndarray:
        """The first *count* values of an index array (the dataset must declare that many)."""
        arr = self.numeric(path, np.float64, at_least=count, count=count)
        if arr.size and (not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr))):
            raise self.err(path, "index array holds non-integer values")
        return arr.astype(np.int64)

    def _check_range(self, field, idx, bound, what):
        if idx.size and (idx.min() < 0 or idx.max() >= bound):
            bad = idx[(idx < 0) | (idx >= bound)][0]
            raise self.err(field, f"{what} index {bad} out of range [0, {bound})")

    def solution(self, group: str, m: int, n: int | None) -> Solution:
        vals = {}
        for key, size in (("r", m), ("u", m), ("v", n)):
            path = f"{group}/{key}"
            if path in self.h5:
                vals[key] = self.vector(path, size)  # size None: v of a local problem, kept as is
        return Solution(**vals)


def read_fclib(path) -> FrictionContactProblem | GlobalFrictionContactProblem:
    """Read an FCLib HDF5 file (local or global problem).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    FrictionContactProblem or GlobalFrictionContactProblem
        With ``solution`` (``/solution``) and ``guesses`` (``/guesses``) when present.

    Raises
    ------
    ProblemFormatError
        Unreadable/truncated HDF5, missing group or dataset, inconsistent matrix storage.
    InvalidProblemError
        Inconsistent problem data (raised by the problem constructor, with the file as source).
    """
    import h5py
    source = source_name(path)
    try:
        h5 = h5py.File(source, "r")
    except _H5_ERRORS as exc:
        raise ProblemFormatError("HDF5 file", f"cannot be opened ({exc}); truncated or corrupt?",
                                 source) from None
    with h5:
        rd = _Reader(h5, source)
        try:
            return _read_open(rd, Path(source).name)
        except (ProblemFormatError, InvalidProblemError):
            raise
        except _H5_ERRORS as exc:  # anything h5py raises on corrupt content
            raise ProblemFormatError("HDF5 file", f"cannot be read ({type(exc).__name__}: {exc})",
                                     source) from None


def _read_open(rd: _Reader, name: str):
    h5 = rd.h5
    if "fclib_local" in h5:
        root, is_global = "/fclib_local", False
    elif "fclib_global" in h5:
        root, is_global = "/fclib_global", True
    else:
        raise rd.err("/fclib_local or /fclib_global", "neither group is present: not an FCLib problem file")
    dim = rd.integer(f"{root}/spacedim")
    if dim not in (2, 3):
        raise rd.err(f"{root}/spacedim", f"must be 2 or 3, got {dim}")
    title = rd.text(f"{root}/info/title")
    description = rd.text(f"{root}/info/description")
    info = title + ("\n" + description if description else "")
    if not is_global:
        W = rd.matrix(f"{root}/W")
        if W.shape[0] != W.shape[1]:
            raise rd.err(f"{root}/W", f"must be square, got {W.shape[0]} x {W.shape[1]}")
        m, n_dofs = W.shape[0], None
        q = rd.vector(f"{root}/vectors/q", m)
    else:
        M = rd.matrix(f"{root}/M")
        H = rd.matrix(f"{root}/H")
        if M.shape[0] != M.shape[1]:
            raise rd.err(f"{root}/M", f"must be square, got {M.shape[0]} x {M.shape[1]}")
        if H.shape[0] != M.shape[0]:
            raise rd.err(f"{root}/H", f"has {H.shape[0]} rows, expected {M.shape[0]} (size of M)")
        m, n_dofs = H.shape[1], M.shape[0]
        f = rd.vector(f"{root}/vectors/f", n_dofs)
        w = rd.vector(f"{root}/vectors/w", m)
    if m % dim:
        raise rd.err(f"{root}/{'H' if is_global else 'W'}",
                     f"{m} contact unknowns is not a multiple of spacedim = {dim}")
    mu = rd.vector(f"{root}/vectors/mu", m // dim)
    solution = rd.solution("/solution", m, n_dofs) if "solution" in h5 else None
    guesses = []
    if "guesses" in h5:
        count = rd.integer("/guesses/number_of_guesses")
        if count < 0:
            raise rd.err("/guesses/number_of_guesses", f"negative count {count}")
        for k in range(1, count + 1):
            rd.node(f"/guesses/{k}", "group")
            guesses.append(rd.solution(f"/guesses/{k}", m, n_dofs))
    meta = dict(source=rd.source, name=name, info=info, solution=solution, guesses=guesses)
    if is_global:
        return GlobalFrictionContactProblem(M, H, f, w, mu, dim, **meta)
    return FrictionContactProblem(W, q, mu, dim, **meta)


# ------------------------------------------------------------------ writing
def _int(value) -> np.ndarray:
    return np.array([value], dtype=np.int32)


def _text(value: str) -> np.ndarray:
    raw = value.encode("utf-8")
    return np.array(raw, dtype=f"S{max(len(raw), 1)}")


def _write_matrix(group, A) -> None:
    """Write *A* as an FCLib compressed-column matrix (``nz = -1``)."""
    C = sp.csc_matrix(A, dtype=np.float64, copy=True)
    C.sort_indices()
    group.create_dataset("nzmax", data=_int(C.nnz))
    group.create_dataset("m", data=_int(C.shape[0]))
    group.create_dataset("n", data=_int(C.shape[1]))
    group.create_dataset("nz", data=_int(-1))
    group.create_dataset("p", data=C.indptr.astype(np.int32))
    group.create_dataset("i", data=C.indices.astype(np.int32))
    group.create_dataset("x", data=C.data.astype(np.float64))


def _write_solution(group, sol) -> None:
    for key in ("r", "u", "v"):
        val = getattr(sol, key, None)
        if val is not None:
            group.create_dataset(key, data=np.asarray(val, dtype=np.float64).reshape(-1))


def write_fclib(problem, path, solution=None, *, guesses=None, title: str | None = None,
                description: str | None = None, math_info: str = ""):
    """Write a problem to an FCLib HDF5 file.

    Matrices are stored in compressed-column form (``nz = -1``), integers as
    int32 and vectors as float64, as the FCLib C library does.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    path : str or path-like
        Output file (overwritten).
    solution : Solution or object with ``r, u[, v]`` attributes, optional
        Written to ``/solution``; default ``problem.solution``.
    guesses : list of Solution, optional
        Written to ``/guesses``; default ``problem.guesses``.
    title, description : str, optional
        ``info`` strings; default: ``problem.info`` split at its first newline.
    math_info : str, optional

    Returns
    -------
    pathlib.Path
        The written file, so that ``read_problem(write_fclib(p, path))`` works.
    """
    import h5py
    path = Path(path)
    if solution is None:
        solution = problem.solution
    if guesses is None:
        guesses = problem.guesses
    head, _, tail = (problem.info or "").partition("\n")
    title = head if title is None else title
    description = tail if description is None else description
    root_name = "fclib_global" if problem.is_global else "fclib_local"
    with h5py.File(path, "w") as h5:
        root = h5.create_group(root_name)
        root.create_dataset("spacedim", data=_int(problem.dim))
        if problem.is_global:
            _write_matrix(root.create_group("M"), problem.M)
            _write_matrix(root.create_group("H"), problem.H)
        else:
            _write_matrix(root.create_group("W"), problem.W)
        vec = root.create_group("vectors")
        if problem.is_global:
            vec.create_dataset("f", data=problem.f)
            vec.create_dataset("w", data=problem.w)
        else:
            vec.create_dataset("q", data=problem.q)
        vec.create_dataset("mu", data=problem.mu)
        info = root.create_group("info")
        info.create_dataset("title", data=_text(title))
        info.create_dataset("description", data=_text(description))
        info.create_dataset("math_info", data=_text(math_info))
        if solution is not None:
            _write_solution(h5.create_group("solution"), solution)
        if guesses:
            g = h5.create_group("guesses")
            g.create_dataset("number_of_guesses", data=_int(len(guesses)))
            for k, guess in enumerate(guesses, start=1):
                _write_solution(g.create_group(str(k)), guess)
    return path


__all__ = ["read_fclib", "write_fclib"]
