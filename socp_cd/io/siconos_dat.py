"""Reader of Siconos numerics text problem files (``*.dat``).

Layout (as written by Siconos ``frictionContact_printInFile`` and
``globalFrictionContact_printInFile``), whitespace-separated tokens:

local problem (``FrictionContactProblem``)
    ``dim``, ``n_contacts``, NumericsMatrix ``W``, ``q`` (``W.size1`` values),
    ``mu`` (``n_contacts`` values).
global problem (``GlobalFrictionContactProblem``, file names ``GFC3D_*``)
    ``dim``, ``n_contacts``, NumericsMatrix ``M``, NumericsMatrix ``H``,
    ``q`` (``M.size1`` values), ``b`` (``H.size1`` values), ``mu``.
    Siconos writes ``M v = q + H r``, ``u = H^T v + b``; this is the FCLib
    convention ``M v = H r + f``, ``u = H^T v + w`` with ``f = q``, ``w = b``
    (no sign change).

A NumericsMatrix is ``storage size0 size1`` followed by

* storage 0 (dense): the sizes again (``size0 size1``) and ``size0*size1``
  values in column-major order;
* storage 1 (sparse block, SBM): ``nbblocks`` (0 means an all-zero matrix and
  nothing follows), ``blocknumber0 blocknumber1``, the cumulative block sizes
  of rows and columns, ``filled1 filled2``, the block-row pointer
  ``index1_data`` (``filled1`` values) and block-column indices
  ``index2_data`` (``filled2`` values), then for every block its number and
  its values in column-major order;
* storage 2 (CSparse): an origin code (1 triplet, 2 CSC, 3 CSR), a
  ``CSparse Version ...`` banner, a
  ``m-by-n, nzmax: .. nnz: ..`` line (prefixed by ``triplet:`` for triplet
  storage), then ``col j : locations a to b`` headers each followed by
  ``i : x`` lines (compressed columns; for origin 3 the headers number rows),
  or ``i j : x`` lines (triplet).
  CSparse prints values with ``%g`` (6 significant digits).

Many files end with one extra integer (a legacy flag); Siconos ignores it and
so does this reader.  More than one trailing token is reported as an error.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidProblemError, ProblemFormatError
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem

#: Number of trailing tokens tolerated after ``mu`` (legacy flag written by old Siconos).
MAX_TRAILING_TOKENS = 1

STORAGE_NAMES = {0: "dense", 1: "sparse-block", 2: "CSparse"}

_SIZE_RE = re.compile(rb"^(\d+)-by-(\d+),?$")


class _Tokens:
    """Cursor over the whitespace-separated tokens of a text file."""

    def __init__(self, data: bytes, source: str):
        self.toks = data.split()
        self.pos = 0
        self.source = source

    def _err(self, field, reason):
        return ProblemFormatError(field, reason, self.source)

    def remaining(self) -> int:
        return len(self.toks) - self.pos

    def _need(self, n, field, what):
        if self.remaining() < n:
            raise self._err(field, f"file ends early (truncated?): expected {what} at token "
                                   f"#{self.pos + 1}, only {self.remaining()} tokens left")

    def int(self, field: str) -> int:
        """Next token as an integer."""
        self._need(1, field, "an integer")
        tok = self.toks[self.pos]
        try:
            val = int(tok)
        except ValueError:
            raise self._err(field, f"expected an integer at token #{self.pos + 1}, "
                                   f"got {tok.decode(errors='replace')!r}") from None
        self.pos += 1
        return val

    def ints(self, n: int, field: str) -> np.ndarray:
        """Next *n* tokens as integers (int64 array)."""
        vals = self.floats(n, field, what=f"{n} integers")
        if not np.all(np.isfinite(vals)) or np.any(vals != np.round(vals)):
            bad = int(np.flatnonzero(~np.isfinite(vals) | (vals != np.round(vals)))[0])
            raise self._err(field, f"expected an integer at token #{self.pos - n + bad + 1}, "
                                   f"got {self.toks[self.pos - n + bad].decode(errors='replace')!r}")
        return vals.astype(np.int64)

    def floats(self, n: int, field: str, what: str | None = None) -> np.ndarray:
        """Next *n* tokens as float64 (vectorized conversion)."""
        if n < 0:
            raise self._err(field, f"negative length {n}")
        self._need(n, field, what or f"{n} numbers")
        chunk = self.toks[self.pos:self.pos + n]
        try:
            vals = np.array(list(map(float, chunk)), dtype=np.float64)
        except ValueError:
            k = next(k for k, t in enumerate(chunk) if not _is_float(t))
            raise self._err(field, f"non-numeric token {chunk[k].decode(errors='replace')!r} at "
                                   f"token #{self.pos + k + 1}") from None
        self.pos += n
        return vals.reshape(n)

    def word(self, field: str) -> bytes:
        self._need(1, field, "a token")
        tok = self.toks[self.pos]
        self.pos += 1
        return tok


def _is_float(tok: bytes) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


# ---------------------------------------------------------------- matrices
def _read_matrix(t: _Tokens, name: str) -> tuple[sp.spmatrix | np.ndarray, int]:
    """Read one NumericsMatrix; return (matrix, storage code)."""
    storage = t.int(f"{name}.storage")
    if storage not in STORAGE_NAMES:
        raise t._err(f"{name}.storage", f"unknown NumericsMatrix storage code {storage} "
                                        "(expected 0 dense, 1 sparse-block, 2 CSparse)")
    size0 = t.int(f"{name}.size0")
    size1 = t.int(f"{name}.size1")
    if size0 < 0 or size1 < 0:
        raise t._err(name, f"negative size {size0} x {size1}")
    if storage == 0:
        return _read_dense(t, name, size0, size1), storage
    if storage == 1:
        return _read_sbm(t, name, size0, size1), storage
    return _read_csparse(t, name, size0, size1), storage


def _read_dense(t, name, size0, size1):
    d0 = t.int(f"{name}.size0")
    d1 = t.int(f"{name}.size1")
    if (d0, d1) != (size0, size1):
        raise t._err(name, f"dense header {d0} x {d1} disagrees with matrix header {size0} x {size1}")
    vals = t.floats(size0 * size1, name)
    return vals.reshape(size1, size0).T  # column-major storage


def _read_sbm(t, name, size0, size1):
    nbblocks = t.int(f"{name}.nbblocks")
    if nbblocks < 0:
        raise t._err(f"{name}.nbblocks", f"negative number of blocks {nbblocks}")
    if nbblocks == 0:  # Siconos writes nothing more: an all-zero matrix
        return sp.csr_matrix((size0, size1))
    bn0 = t.int(f"{name}.blocknumber0")
    bn1 = t.int(f"{name}.blocknumber1")
    if bn0 <= 0 or bn1 <= 0:
        raise t._err(name, f"invalid numbers of block rows/columns {bn0} x {bn1}")
    rowsz = _cumulative_sizes(t, bn0, f"{name}.blocksize0", size0)
    colsz = _cumulative_sizes(t, bn1, f"{name}.blocksize1", size1)
    filled1 = t.int(f"{name}.filled1")
    filled2 = t.int(f"{name}.filled2")
    if not 1 <= filled1 <= bn0 + 1:
        raise t._err(f"{name}.filled1", f"{filled1} is not in [1, blocknumber0 + 1 = {bn0 + 1}]")
    if filled2 != nbblocks:
        raise t._err(f"{name}.filled2", f"{filled2} differs from the number of blocks {nbblocks}")
    index1 = t.ints(filled1, f"{name}.index1_data")
    index2 = t.ints(filled2, f"{name}.index2_data")
    if index1[0] != 0 or np.any(np.diff(index1) < 0) or index1[-1] != filled2:
        raise t._err(f"{name}.index1_data", "block-row pointer must start at 0, be non-decreasing "
                                            f"and end at filled2 = {filled2}")
    if filled2 and (index2.min() < 0 or index2.max() >= bn1):
        raise t._err(f"{name}.index2_data", f"block-column index out of range [0, {bn1})")
    # shape of every block, in file order
    brow = np.repeat(np.arange(filled1 - 1), np.diff(index1))
    rstart = np.concatenate(([0], rowsz[:-1]))
    cstart = np.concatenate(([0], colsz[:-1]))
    nr = (rowsz - rstart)[brow]
    nc = (colsz - cstart)[index2]
    count = nr * nc
    # token layout: [blockNum, count values] per block
    total = int(np.sum(count + 1))
    start = t.pos
    raw = t.floats(total, f"{name} blocks")
    offs = np.concatenate(([0], np.cumsum(count + 1)[:-1]))
    numbers = raw[offs]
    if not np.array_equal(numbers, np.arange(filled2, dtype=np.float64)):
        k = int(np.flatnonzero(numbers != np.arange(filled2))[0])
        raise t._err(f"{name} blocks", f"block number {t.toks[start + offs[k]].decode(errors='replace')!r}"
                                        f" at token #{start + offs[k] + 1}, expected {k}")
    # position of every value: block k, local index l in [0, count_k)
    blk = np.repeat(np.arange(filled2), count)
    local = np.arange(blk.size) - np.repeat(np.cumsum(count) - count, count)
    vals = raw[offs[blk] + 1 + local]
    rows = rstart[brow][blk] + local % nr[blk]
    cols = cstart[index2][blk] + local // nr[blk]
    return sp.coo_matrix((vals, (rows, cols)), shape=(size0, size1))


def _cumulative_sizes(t, n, field, total):
    sizes = t.ints(n, field)
    if sizes[0] < 0 or np.any(np.diff(sizes) < 0):
        raise t._err(field, "cumulative block sizes must be non-negative and non-decreasing")
    if sizes[-1] != total:
        raise t._err(field, f"last cumulative block size {sizes[-1]} differs from the matrix size {total}")
    return sizes


#: NumericsSparseMatrix origin codes (Siconos ``NSM_t``).
NSM_TRIPLET, NSM_CSC, NSM_CSR = 1, 2, 3


def _read_csparse(t, name, size0, size1):
    origin = t.int(f"{name}.origin")
    if origin not in (NSM_TRIPLET, NSM_CSC, NSM_CSR):
        raise t._err(f"{name}.origin", f"unknown sparse origin code {origin} (1 triplet, 2 CSC, 3 CSR)")
    # skip the "CSparse Version ..." banner up to the "m-by-n," token
    is_triplet = False
    for _ in range(64):
        tok = t.word(f"{name} CSparse header")
        if tok == b"triplet:":
            is_triplet = True
        match = _SIZE_RE.match(tok)
        if match:
            break
    else:
        raise t._err(f"{name} CSparse header", "no 'm-by-n' size line found")
    m, n = int(match.group(1)), int(match.group(2))
    if (m, n) != (size0, size1):
        raise t._err(name, f"CSparse size {m} x {n} disagrees with matrix header {size0} x {size1}")
    _expect(t, b"nzmax:", name)
    t.int(f"{name}.nzmax")
    _expect(t, b"nnz:", name)
    nnz_tok = t.word(f"{name}.nnz").rstrip(b",")
    try:
        nnz = int(nnz_tok)
    except ValueError:
        raise t._err(f"{name}.nnz", f"expected an integer, got {nnz_tok.decode(errors='replace')!r}") from None
    if nnz < 0:
        raise t._err(f"{name}.nnz", f"negative number of entries {nnz}")
    if is_triplet:
        body = _words(t, 4 * nnz, f"{name} triplet entries").reshape(nnz, 4)
        if nnz and not np.all(body[:, 2] == b":"):
            raise t._err(f"{name} triplet entries", "expected lines 'i j : x'")
        rows = _to_int(t, body[:, 0], f"{name} row indices")
        cols = _to_int(t, body[:, 1], f"{name} column indices")
        vals = _to_float(t, body[:, 3], f"{name} values")
    else:
        _expect(t, b"1-norm:", name)
        t.word(f"{name}.1-norm")
        body = _words(t, 7 * n + 3 * nnz, f"{name} columns")
        heads = np.flatnonzero(body == b"col")
        if heads.size != n or np.any(heads[1:] - heads[:-1] < 7) or (n and heads[0] != 0):
            raise t._err(f"{name} columns", f"expected {n} 'col j : locations a to b' headers")
        hdr = body[heads[:, None] + np.arange(7)]
        if n and not (np.all(hdr[:, 2] == b":") and np.all(hdr[:, 3] == b"locations")
                      and np.all(hdr[:, 5] == b"to")):
            raise t._err(f"{name} columns", "malformed 'col j : locations a to b' header")
        if not np.array_equal(_to_int(t, hdr[:, 1], f"{name} column numbers"), np.arange(n)):
            raise t._err(f"{name} columns", "column headers are not numbered 0..n-1")
        is_entry = np.ones(body.size, dtype=bool)
        is_entry[(heads[:, None] + np.arange(7)).ravel()] = False
        entries = body[is_entry].reshape(-1, 3)
        if nnz and not np.all(entries[:, 1] == b":"):
            raise t._err(f"{name} entries", "expected lines 'i : x'")
        per_col = (np.diff(np.append(heads, body.size)) - 7) // 3
        first = _to_int(t, hdr[:, 4], f"{name} column pointers")
        last = _to_int(t, hdr[:, 6], f"{name} column pointers")
        if not np.array_equal(last - first + 1, per_col):
            raise t._err(f"{name} column pointers", "'locations a to b' disagree with the entries listed")
        cols = np.repeat(np.arange(n), per_col)
        rows = _to_int(t, entries[:, 0], f"{name} row indices")
        vals = _to_float(t, entries[:, 2], f"{name} values")
        if origin == NSM_CSR:  # Siconos prints CSR storage with the same 'col' headers: they are rows
            rows, cols = cols, rows
    if rows.size and (rows.min() < 0 or rows.max() >= m or cols.min() < 0 or cols.max() >= n):
        raise t._err(name, f"entry index out of range for a {m} x {n} matrix")
    return sp.coo_matrix((vals, (rows, cols)), shape=(m, n))


def _expect(t, word, name):
    tok = t.word(f"{name} CSparse header")
    if tok != word:
        raise t._err(f"{name} CSparse header", f"expected {word.decode()!r}, got "
                                               f"{tok.decode(errors='replace')!r}")


def _words(t, n, field):
    t._need(n, field, f"{n} tokens")
    arr = np.array(t.toks[t.pos:t.pos + n], dtype=object)
    t.pos += n
    return arr


def _to_int(t, arr, field):
    try:
        return np.array(list(map(int, arr)), dtype=np.int64)
    except ValueError:
        raise t._err(field, "non-integer token") from None


def _to_float(t, arr, field):
    try:
        return np.array(list(map(float, arr)), dtype=np.float64)
    except ValueError:
        raise t._err(field, "non-numeric token") from None


# ---------------------------------------------------------------- problems
def _header(t):
    dim = t.int("dim")
    if dim not in (2, 3):
        raise t._err("dim", f"must be 2 or 3, got {dim}")
    nc = t.int("n_contacts")
    if nc <= 0:
        raise t._err("n_contacts", f"problem has {'zero' if nc == 0 else 'a negative number of'} contacts ({nc})")
    return dim, nc


def _finish(t):
    if t.remaining() > MAX_TRAILING_TOKENS:
        raise t._err("end of file", f"{t.remaining()} unexpected tokens after mu "
                                    f"(starting with {t.toks[t.pos].decode(errors='replace')!r}); "
                                    "wrong n_contacts or matrix size?")


def is_global_dat(path) -> bool:
    """Whether a Siconos text file holds a global problem (name starts with ``GFC``)."""
    return Path(path).name.upper().startswith("GFC")


def read_siconos_dat(path, data: bytes | None = None, *, global_problem: bool | None = None):
    """Read a Siconos numerics text problem.

    Parameters
    ----------
    path : str or path-like
        File to read (used in error messages as the source).
    data : bytes, optional
        File content when already read.
    global_problem : bool, optional
        Force the global (``M, H, q, b, mu``) or the local layout.  Default:
        files whose name starts with ``GFC`` are tried as global first, others
        as local first; when that layout does not fit, the other one is tried
        and, if it fails too, the error of the first layout is raised.

    Returns
    -------
    FrictionContactProblem or GlobalFrictionContactProblem

    Raises
    ------
    ProblemFormatError
        Truncated file, non-numeric token, unknown storage code, inconsistent sizes.
    InvalidProblemError
        NaN/Inf values, negative mu (raised by the problem constructor).
    """
    if data is None:
        try:
            data = Path(path).read_bytes()
        except OSError as exc:
            raise ProblemFormatError("file", f"cannot be read ({exc})", str(path)) from None
    if global_problem is not None:
        return _parse(path, data, global_problem)
    first = is_global_dat(path)
    try:
        return _parse(path, data, first)
    except ProblemFormatError as exc:
        try:
            return _parse(path, data, not first)
        except (ProblemFormatError, InvalidProblemError):
            raise exc from None


def _parse(path, data: bytes, global_problem: bool):
    source = str(path)
    t = _Tokens(data, source)
    if not t.toks:
        raise ProblemFormatError("dim", "file is empty", source)
    dim, nc = _header(t)
    m = dim * nc
    name = Path(path).name
    if not global_problem:
        W, storage = _read_matrix(t, "W")
        if W.shape != (m, m):
            raise t._err("W", f"has shape {W.shape[0]} x {W.shape[1]}, expected {m} x {m} "
                              f"(dim = {dim}, n_contacts = {nc})")
        q = t.floats(W.shape[1], "q")
        mu = t.floats(nc, "mu")
        _finish(t)
        return FrictionContactProblem(W, q, mu, dim, source=source, name=name,
                                      info=f"Siconos text file, W storage: {STORAGE_NAMES[storage]}")
    M, storage = _read_matrix(t, "M")
    if M.shape[0] != M.shape[1] or M.shape[0] == 0:
        raise t._err("M", f"must be square and non-empty, got {M.shape[0]} x {M.shape[1]}")
    H, _ = _read_matrix(t, "H")
    if H.shape != (M.shape[0], m):
        raise t._err("H", f"has shape {H.shape[0]} x {H.shape[1]}, expected {M.shape[0]} x {m} "
                          f"(dofs x dim*n_contacts)")
    f = t.floats(M.shape[1], "q (f)")
    w = t.floats(H.shape[1], "b (w)")
    mu = t.floats(nc, "mu")
    _finish(t)
    return GlobalFrictionContactProblem(M, H, f, w, mu, dim, source=source, name=name,
                                        info=f"Siconos text file, M storage: {STORAGE_NAMES[storage]}")


__all__ = ["read_siconos_dat", "is_global_dat", "STORAGE_NAMES"]
