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
so does this reader.  More than one trailing token, or one that is not an
integer, is reported as an error.

Line layout.  Whitespace alone cannot tell a missing value from a shifted
one: a dense ``W`` short of one value followed by the flag ``1`` parses, with
every later value moved by one.  Siconos prints each vector on a line of its
own (``q``, ``mu``; for a global problem ``q b`` on one line, then ``mu``),
older files one value per line; so the vectors that end a file must fill
whole lines, all in the same layout (one line each, or one value per line
without blank lines; a global ``q`` and ``b`` may also take a line each).
A file whose ``q`` and ``mu`` share a line is rejected.

Numbers use Python's ``float`` syntax without ``_`` digit groups (``1_4`` is
rejected); error messages quote at most ``MAX_QUOTED`` characters of a token.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidArgumentError, InvalidProblemError, ProblemFormatError
from .paths import source_name
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem

#: Number of trailing tokens tolerated after ``mu`` (legacy flag written by old Siconos).
MAX_TRAILING_TOKENS = 1

STORAGE_NAMES = {0: "dense", 1: "sparse-block", 2: "CSparse"}

_SIZE_RE = re.compile(rb"^(\d+)-by-(\d+),?$")


#: ASCII whitespace as ``bytes.split()`` understands it (space, \t, \n, \v, \f, \r).
_IS_SPACE = np.zeros(256, dtype=bool)
_IS_SPACE[[9, 10, 11, 12, 13, 32]] = True
#: Bytes of the file scanned at once when locating tokens (bounds temporaries).
_SCAN_CHUNK = 1 << 18
#: Tokens converted to numbers at once (bounds the Python objects alive at a time).
_CONVERT_CHUNK = 1 << 15
#: Longest token text quoted in an error message.
MAX_QUOTED = 40


def quote_token(tok: bytes) -> str:
    """A token for an error message: decoded, quoted, truncated to MAX_QUOTED characters."""
    text = tok[:MAX_QUOTED].decode("utf-8", errors="replace")
    if len(tok) > MAX_QUOTED:
        return f"{text!r}... ({len(tok)} bytes)"
    return repr(text)


def _token_starts(buf: np.ndarray) -> np.ndarray:
    """Offsets where the whitespace-separated tokens of *buf* (uint8) start.

    Two passes over chunks of ``_SCAN_CHUNK`` bytes (count, then fill one
    preallocated array); int32 offsets for files under 2 GiB, so the index
    costs 4 bytes per token (at most twice the file size).
    """
    def chunk_starts(a, prev):
        space = _IS_SPACE[buf[a:a + _SCAN_CHUNK]]
        begins = ~space
        begins[1:] &= space[:-1]
        begins[0] &= prev
        return begins, bool(space[-1])

    offsets = range(0, buf.size, _SCAN_CHUNK)
    counts, prev = [], True
    for a in offsets:
        begins, prev = chunk_starts(a, prev)
        counts.append(int(np.count_nonzero(begins)))
    out = np.empty(sum(counts), dtype=np.int32 if buf.size < 2**31 - 1 else np.int64)
    k, prev = 0, True
    for a, c in zip(offsets, counts):
        begins, prev = chunk_starts(a, prev)
        out[k:k + c] = np.flatnonzero(begins) + a
        k += c
    return out


#: A token: a run of non-whitespace bytes.
_TOKEN_RE = re.compile(rb"\S+")


class _Tokens:
    """Cursor over the whitespace-separated tokens of a text file.

    Tokens are located once (two offset arrays) and converted on demand, a
    chunk at a time, so reading costs a small multiple of the file size.
    Line breaks are kept: Siconos writes every vector on lines of its own, and
    :meth:`expect_own_lines` uses that to catch a value missing or in excess.
    """

    def __init__(self, data: bytes, source: str):
        self.data = bytes(data)
        self.buf = np.frombuffer(self.data, dtype=np.uint8)
        self.starts = _token_starts(self.buf)
        self.pos = 0
        self.source = source

    def _err(self, field, reason):
        return ProblemFormatError(field, reason, self.source)

    def __len__(self) -> int:
        return self.starts.size

    def remaining(self) -> int:
        return len(self) - self.pos

    def tok(self, k: int) -> bytes:
        """Text of token *k* (0-based)."""
        return _TOKEN_RE.match(self.data, int(self.starts[k])).group()

    def _span(self, k0: int, k1: int) -> bytes:
        """Bytes from the start of token *k0* to the start of token *k1* (or the end)."""
        end = int(self.starts[k1]) if k1 < len(self) else len(self.data)
        return self.data[int(self.starts[k0]):end]

    def _need(self, n, field, what):
        if self.remaining() < n:
            raise self._err(field, f"file ends early (truncated?): expected {what} at token "
                                   f"#{self.pos + 1}, only {self.remaining()} tokens left")

    def int(self, field: str) -> int:
        """Next token as an integer (decimal digits with an optional sign)."""
        self._need(1, field, "an integer")
        tok = self.tok(self.pos)
        try:
            if b"_" in tok:
                raise ValueError
            val = int(tok)
        except ValueError:
            raise self._err(field, f"expected an integer at token #{self.pos + 1}, "
                                   f"got {quote_token(tok)}") from None
        self.pos += 1
        return val

    def ints(self, n: int, field: str) -> np.ndarray:
        """Next *n* tokens as integers (int64 array)."""
        vals = self.floats(n, field, what=f"{n} integers")
        if not np.all(np.isfinite(vals)) or np.any(vals != np.round(vals)):
            bad = int(np.flatnonzero(~np.isfinite(vals) | (vals != np.round(vals)))[0])
            raise self._err(field, f"expected an integer at token #{self.pos - n + bad + 1}, "
                                   f"got {quote_token(self.tok(self.pos - n + bad))}")
        return vals.astype(np.int64)

    def floats(self, n: int, field: str, what: str | None = None) -> np.ndarray:
        """Next *n* tokens as float64, converted ``_CONVERT_CHUNK`` tokens at a time.

        Python's ``float`` syntax is accepted except digit-group underscores
        (``1_4`` is not 14 in a data file).
        """
        if n < 0:
            raise self._err(field, f"negative length {n}")
        self._need(n, field, what or f"{n} numbers")
        out = np.empty(n, dtype=np.float64)
        for c in range(0, n, _CONVERT_CHUNK):
            k0, k1 = self.pos + c, self.pos + min(c + _CONVERT_CHUNK, n)
            span = self._span(k0, k1)
            chunk = span.split()
            try:
                if b"_" in span:
                    raise ValueError
                out[c:c + len(chunk)] = np.fromiter(map(float, chunk), np.float64, len(chunk))
            except ValueError:
                k = next(k for k, t in enumerate(chunk) if not _is_float(t))
                raise self._err(field, f"non-numeric token {quote_token(chunk[k])} at "
                                       f"token #{k0 + k + 1}") from None
        self.pos += n
        return out

    def word(self, field: str) -> bytes:
        self._need(1, field, "a token")
        tok = self.tok(self.pos)
        self.pos += 1
        return tok

    def words(self, n: int, field: str) -> np.ndarray:
        """Next *n* tokens as an object array of bytes."""
        self._need(n, field, f"{n} tokens")
        arr = np.empty(n, dtype=object)
        if n:
            arr[:] = self._span(self.pos, self.pos + n).split()
        self.pos += n
        return arr

    # ------------------------------------------------------------ line layout
    def _line_break_before(self, k: int) -> bool:
        """Whether a newline separates token *k* from token *k - 1* (file ends count)."""
        if k <= 0 or k >= len(self):
            return True
        return b"\n" in self._span(k - 1, k)

    def _layouts(self, k0: int, n: int) -> set:
        """Layouts of tokens ``k0..k0+n-1``: ``"row"`` (one line), ``"column"`` (one per line)."""
        a = int(self.starts[k0])
        last = k0 + n - 1
        span = self.buf[a:int(self.starts[last]) + len(self.tok(last))]
        breaks = np.flatnonzero(span == 10)
        if breaks.size == 0:
            return {"row", "column"} if n == 1 else {"row"}
        line = np.searchsorted(breaks, self.starts[k0:k0 + n] - a)
        return {"column"} if np.array_equal(line, np.arange(n)) else set()

    def expect_own_lines(self, k0: int, n: int, field: str, layouts: set) -> set:
        """Check that tokens ``k0..k0+n-1`` (a vector) fill whole lines in one layout.

        Siconos prints each vector on one line (older files: one value per
        line).  A vector starting or ending inside a line, or split over lines
        otherwise, means that a preceding count is wrong: a value is missing
        or in excess, and every later value would be shifted.

        Returns
        -------
        set
            The layouts still possible (intersection with *layouts*).
        """
        if not self._line_break_before(k0):
            raise self._err(field, f"does not start on a new line (token #{k0 + 1}): the data "
                                   "before it have a value missing or in excess")
        if not self._line_break_before(k0 + n):
            raise self._err(field, f"{n} values expected, but its line goes on (token "
                                   f"#{k0 + n + 1}): a value in excess here or missing before")
        both = self._layouts(k0, n) & layouts
        if not both:
            raise self._err(field, f"{n} values expected on one line, or one per line like the "
                                   "vectors before it: a value is missing or in excess")
        return both


#: Layouts a vector may have in a Siconos text file.
VECTOR_LAYOUTS = frozenset({"row", "column"})


def _is_float(tok: bytes) -> bool:
    if b"_" in tok:
        return False
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
    if max(size0, size1) > t.remaining():  # the vectors after it hold that many values
        raise t._err(name, f"size {size0} x {size1} exceeds the {t.remaining()} values left in "
                           "the file (the vectors that follow need that many)")
    if storage == 0:
        return _read_dense(t, name, size0, size1), storage
    if storage == 1:
        return _read_sbm(t, name, size0, size1), storage
    return _read_csparse(t, name, size0, size1), storage


def _read_dense(t, name, size0, size1):
    """Dense column-major values, kept as a sparse matrix of their nonzeros.

    Converted a few columns at a time, so a dense matrix of zeros written as
    ``0`` tokens does not cost 8 bytes per token.
    """
    d0 = t.int(f"{name}.size0")
    d1 = t.int(f"{name}.size1")
    if (d0, d1) != (size0, size1):
        raise t._err(name, f"dense header {d0} x {d1} disagrees with matrix header {size0} x {size1}")
    t._need(size0 * size1, name, f"{size0 * size1} numbers")
    per_chunk = max(1, _CONVERT_CHUNK // max(size0, 1))
    rows, cols, vals = [], [], []
    for j0 in range(0, size1, per_chunk):
        nj = min(per_chunk, size1 - j0)
        block = t.floats(nj * size0, name).reshape(nj, size0)  # one column per row
        jj, ii = np.nonzero(block)
        rows.append(ii.astype(np.int32))
        cols.append((jj + j0).astype(np.int32))
        vals.append(block[jj, ii])
    if not vals:
        return sp.coo_matrix((size0, size1))
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(size0, size1))


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
    if np.any(count > t.remaining()):
        raise t._err(f"{name} blocks", "block sizes exceed the values left in the file")
    # token layout: [blockNum, count values] per block
    total = int(np.sum(count + 1))
    start = t.pos
    raw = t.floats(total, f"{name} blocks")
    offs = np.concatenate(([0], np.cumsum(count + 1)[:-1]))
    numbers = raw[offs]
    if not np.array_equal(numbers, np.arange(filled2, dtype=np.float64)):
        k = int(np.flatnonzero(numbers != np.arange(filled2))[0])
        raise t._err(f"{name} blocks", f"block number {quote_token(t.tok(start + offs[k]))}"
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
    if not _is_int_token(nnz_tok):
        raise t._err(f"{name}.nnz", f"expected an integer, got {quote_token(nnz_tok)}")
    nnz = int(nnz_tok)
    if nnz < 0:
        raise t._err(f"{name}.nnz", f"negative number of entries {nnz}")
    if is_triplet:
        rows, cols, vals = _csparse_triplets(t, name, nnz)
    else:
        _expect(t, b"1-norm:", name)
        t.word(f"{name}.1-norm")
        rows, cols, vals = _csparse_columns(t, name, n, nnz)
        if origin == NSM_CSR:  # Siconos prints CSR storage with the same 'col' headers: they are rows
            rows, cols = cols, rows
    if rows.size and (rows.min() < 0 or rows.max() >= m or cols.min() < 0 or cols.max() >= n):
        raise t._err(name, f"entry index out of range for a {m} x {n} matrix")
    return sp.coo_matrix((vals, (rows, cols)), shape=(m, n))


def _csparse_triplets(t, name, nnz):
    """``nnz`` lines ``i j : x``, converted ``_CONVERT_CHUNK`` tokens at a time."""
    t._need(4 * nnz, f"{name} triplet entries", f"{4 * nnz} tokens")
    rows, cols, vals = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    per_chunk = _CONVERT_CHUNK // 4
    for e in range(0, nnz, per_chunk):
        body = t.words(4 * min(per_chunk, nnz - e), f"{name} triplet entries").reshape(-1, 4)
        if not np.all(body[:, 2] == b":"):
            raise t._err(f"{name} triplet entries", "expected lines 'i j : x'")
        rows.append(_to_int(t, body[:, 0], f"{name} row indices"))
        cols.append(_to_int(t, body[:, 1], f"{name} column indices"))
        vals.append(_to_float(t, body[:, 3], f"{name} values"))
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)


#: Tokens of a ``col j : locations a to b`` header.
_COL_HEADER = 7


def _csparse_columns(t, name, n, nnz):
    """*n* ``col j : locations a to b`` headers, each followed by its ``i : x`` lines.

    Column boundaries are found from the first byte of every token (only
    ``col`` starts with ``c``), then whole columns are converted about
    ``_CONVERT_CHUNK`` tokens at a time.
    """
    total = _COL_HEADER * n + 3 * nnz
    t._need(total, f"{name} columns", f"{total} tokens")
    k0 = t.pos
    heads = np.flatnonzero(t.buf[t.starts[k0:k0 + total]] == ord("c"))
    bounds = np.append(heads, total)
    sizes = np.diff(bounds) - _COL_HEADER
    if heads.size != n or (n and heads[0] != 0) or np.any(sizes < 0) or np.any(sizes % 3):
        raise t._err(f"{name} columns", f"expected {n} 'col j : locations a to b' headers, "
                                        "each followed by 'i : x' lines")
    per_col = sizes // 3
    rows, vals = [np.zeros(0, np.int64)], [np.zeros(0)]
    j = 0
    while j < n:
        j2 = min(n, max(j + 1, int(np.searchsorted(bounds, bounds[j] + _CONVERT_CHUNK, "right")) - 1))
        body = t.words(int(bounds[j2] - bounds[j]), f"{name} columns")
        local = heads[j:j2] - heads[j]
        hdr = body[local[:, None] + np.arange(_COL_HEADER)]
        if not (np.all(hdr[:, 2] == b":") and np.all(hdr[:, 3] == b"locations")
                and np.all(hdr[:, 5] == b"to") and np.all(hdr[:, 0] == b"col")):
            raise t._err(f"{name} columns", "malformed 'col j : locations a to b' header")
        if not np.array_equal(_to_int(t, hdr[:, 1], f"{name} column numbers"), np.arange(j, j2)):
            raise t._err(f"{name} columns", "column headers are not numbered 0..n-1")
        first = _to_int(t, hdr[:, 4], f"{name} column pointers")
        last = _to_int(t, hdr[:, 6], f"{name} column pointers")
        if not np.array_equal(last - first + 1, per_col[j:j2]):
            raise t._err(f"{name} column pointers", "'locations a to b' disagree with the entries listed")
        is_entry = np.ones(body.size, dtype=bool)
        is_entry[(local[:, None] + np.arange(_COL_HEADER)).ravel()] = False
        entries = body[is_entry].reshape(-1, 3)
        if not np.all(entries[:, 1] == b":"):
            raise t._err(f"{name} entries", "expected lines 'i : x'")
        rows.append(_to_int(t, entries[:, 0], f"{name} row indices"))
        vals.append(_to_float(t, entries[:, 2], f"{name} values"))
        j = j2
    cols = np.repeat(np.arange(n), per_col)
    return np.concatenate(rows), cols, np.concatenate(vals)


def _expect(t, word, name):
    tok = t.word(f"{name} CSparse header")
    if tok != word:
        raise t._err(f"{name} CSparse header", f"expected {word.decode()!r}, got {quote_token(tok)}")


def _is_int_token(tok: bytes) -> bool:
    """Whether *tok* is an optionally signed run of decimal digits."""
    return _INT_RE.match(tok) is not None


_INT_RE = re.compile(rb"^[+-]?[0-9]{1,18}$")


def _to_int(t, arr, field):
    """Integers from an object array of tokens (decimal digits, optional sign)."""
    try:
        if b"_" in b"".join(arr):
            raise ValueError
        return np.fromiter(map(int, arr), np.int64, len(arr))
    except (ValueError, OverflowError):
        bad = next((tok for tok in arr if not _is_int_token(tok)), arr[0])
        raise t._err(field, f"non-integer token {quote_token(bad)}") from None


def _to_float(t, arr, field):
    """Floats from an object array of tokens (Python syntax, no ``_`` digit groups)."""
    try:
        if b"_" in b"".join(arr):
            raise ValueError
        return np.fromiter(map(float, arr), np.float64, len(arr))
    except ValueError:
        bad = next(tok for tok in arr if not _is_float(tok))
        raise t._err(field, f"non-numeric token {quote_token(bad)}") from None


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
    """Accept at most one trailing integer (legacy flag) on a line of its own."""
    if t.remaining() > MAX_TRAILING_TOKENS:
        raise t._err("end of file", f"{t.remaining()} unexpected tokens after mu "
                                    f"(starting with {quote_token(t.tok(t.pos))}); "
                                    "wrong n_contacts or matrix size?")
    if t.remaining():
        tok = t.tok(t.pos)
        if not _is_int_token(tok):
            raise t._err("end of file", f"unexpected token {quote_token(tok)} after mu "
                                        "(only an integer flag may follow)")


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
    path = source_name(path)
    if data is not None and not isinstance(data, (bytes, bytearray, memoryview)):
        raise InvalidArgumentError("data", f"expected the file content as bytes, got {type(data).__name__}")
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


def _vectors(t, groups) -> list:
    """Read the vectors that end a file, then check the end of file.

    *groups* lists groups of ``(field, length)``: Siconos prints each group on
    one line (``q`` / ``mu`` of a local problem; ``q b`` together, then
    ``mu``, of a global one), older files one value per line.  Every group
    must fill whole lines, all in the same layout: this catches a value
    missing or in excess anywhere before (see :meth:`_Tokens.expect_own_lines`).
    """
    out, layouts = [], set(VECTOR_LAYOUTS)
    for group in groups:
        k0 = t.pos
        lengths = [n for _, n in group]
        for field, n in group:
            out.append(t.floats(n, field))
        try:
            layouts = t.expect_own_lines(k0, sum(lengths), " and ".join(f for f, _ in group),
                                         layouts)
        except ProblemFormatError:
            if len(group) == 1:
                raise
            # hand-written files: each vector of the group on lines of its own
            for (field, n), start in zip(group, k0 + np.cumsum([0] + lengths[:-1])):
                layouts = t.expect_own_lines(int(start), n, field, layouts)
    _finish(t)
    return out


def _parse(path, data: bytes, global_problem: bool):
    source = str(path)
    t = _Tokens(data, source)
    if not len(t):
        raise ProblemFormatError("dim", "file is empty", source)
    dim, nc = _header(t)
    m = dim * nc
    name = Path(path).name
    if not global_problem:
        W, storage = _read_matrix(t, "W")
        if W.shape != (m, m):
            raise t._err("W", f"has shape {W.shape[0]} x {W.shape[1]}, expected {m} x {m} "
                              f"(dim = {dim}, n_contacts = {nc})")
        q, mu = _vectors(t, [[("q", W.shape[1])], [("mu", nc)]])
        return FrictionContactProblem(W, q, mu, dim, source=source, name=name,
                                      info=f"Siconos text file, W storage: {STORAGE_NAMES[storage]}")
    M, storage = _read_matrix(t, "M")
    if M.shape[0] != M.shape[1] or M.shape[0] == 0:
        raise t._err("M", f"must be square and non-empty, got {M.shape[0]} x {M.shape[1]}")
    H, _ = _read_matrix(t, "H")
    if H.shape != (M.shape[0], m):
        raise t._err("H", f"has shape {H.shape[0]} x {H.shape[1]}, expected {M.shape[0]} x {m} "
                          f"(dofs x dim*n_contacts)")
    f, w, mu = _vectors(t, [[("q (f)", M.shape[1]), ("b (w)", H.shape[1])],
                                 [("mu", nc)]])
    return GlobalFrictionContactProblem(M, H, f, w, mu, dim, source=source, name=name,
                                        info=f"Siconos text file, M storage: {STORAGE_NAMES[storage]}")


__all__ = ["read_siconos_dat", "is_global_dat", "STORAGE_NAMES"]
