"""Malformed problem files raise a socp_cd exception naming the file and the field."""
from __future__ import annotations

import h5py
import numpy as np
import pytest
import scipy.sparse as sp

from socp_cd import FrictionContactProblem, GlobalFrictionContactProblem
from socp_cd.errors import InvalidProblemError, ProblemFormatError, SocpCdError
from socp_cd.io import read_problem, write_fclib

from _hostile import read_capped, siconos_dense_text

# A valid local problem: dim 3, one contact, dense W = identity (column-major).
GOOD = ["3", "1", "0", "3", "3", "3", "3",
        "1", "0", "0", "0", "1", "0", "0", "0", "1",
        "-1", "0", "0",
        "0.5"]
W_FIRST = 7   # index of the first W value in GOOD
Q_FIRST = 16  # index of the first q value


def check(exc_info, path, field, exc_type=ProblemFormatError):
    exc = exc_info.value
    assert type(exc) is exc_type
    assert isinstance(exc, SocpCdError)
    assert exc.source == str(path)
    assert exc.field == field
    msg = str(exc)
    assert str(path) in msg
    assert f"'{field}'" in msg
    return msg


def write_tokens(tmp_path, tokens, name="bad.dat"):
    path = tmp_path / name
    path.write_text("\n".join(tokens) + "\n")
    return path


def replaced(index, value):
    toks = list(GOOD)
    toks[index] = value
    return toks


def test_good_base_file_is_valid(tmp_path):
    p = read_problem(write_tokens(tmp_path, GOOD, "good.dat"))
    np.testing.assert_array_equal(p.W.toarray(), np.eye(3))


# ------------------------------------------------------------------ any file
def test_nonexistent_file(tmp_path):
    path = tmp_path / "missing.dat"
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "does not exist" in check(ei, path, "file")


def test_directory_instead_of_file(tmp_path):
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(tmp_path)
    check(ei, tmp_path, "file")


def test_empty_file(tmp_path):
    path = tmp_path / "empty.dat"
    path.write_bytes(b"")
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "empty" in check(ei, path, "file")


def test_whitespace_only_file(tmp_path):
    path = tmp_path / "blank.dat"
    path.write_text("\n \n\t\n")
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "empty" in check(ei, path, "dim")


# ------------------------------------------------------------------ Siconos text
def test_truncated_text_missing_mu(tmp_path):
    path = write_tokens(tmp_path, GOOD[:-1])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "truncated" in check(ei, path, "mu")


def test_truncated_text_inside_matrix(tmp_path):
    path = write_tokens(tmp_path, GOOD[:W_FIRST + 4])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "truncated" in check(ei, path, "W")


def test_non_numeric_token(tmp_path):
    path = write_tokens(tmp_path, replaced(W_FIRST + 4, "1.0x"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "1.0x" in check(ei, path, "W")


def test_non_integer_header(tmp_path):
    path = write_tokens(tmp_path, replaced(1, "one"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "one" in check(ei, path, "n_contacts")


def test_unknown_storage_code(tmp_path):
    path = write_tokens(tmp_path, replaced(2, "7"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "storage code 7" in check(ei, path, "W.storage")


def test_wrong_dim(tmp_path):
    path = write_tokens(tmp_path, replaced(0, "4"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "got 4" in check(ei, path, "dim")


def test_negative_mu(tmp_path):
    path = write_tokens(tmp_path, replaced(-1, "-0.3"))
    with pytest.raises(InvalidProblemError) as ei:
        read_problem(path)
    assert ">= 0" in check(ei, path, "mu", InvalidProblemError)


def test_nan_in_q(tmp_path):
    path = write_tokens(tmp_path, replaced(Q_FIRST + 1, "nan"))
    with pytest.raises(InvalidProblemError) as ei:
        read_problem(path)
    assert "NaN" in check(ei, path, "q", InvalidProblemError)


def test_inf_in_matrix(tmp_path):
    path = write_tokens(tmp_path, replaced(W_FIRST + 2, "inf"))
    with pytest.raises(InvalidProblemError) as ei:
        read_problem(path)
    assert "NaN/Inf" in check(ei, path, "W", InvalidProblemError)


def test_zero_contacts(tmp_path):
    path = write_tokens(tmp_path, replaced(1, "0"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "zero contacts" in check(ei, path, "n_contacts")


def test_matrix_size_disagrees_with_contacts(tmp_path):
    path = write_tokens(tmp_path, replaced(1, "2"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "expected 6 x 6" in check(ei, path, "W")


def test_dense_header_mismatch(tmp_path):
    path = write_tokens(tmp_path, replaced(5, "2"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    check(ei, path, "W")


def test_trailing_garbage(tmp_path):
    path = write_tokens(tmp_path, GOOD + ["0.5", "0.5"])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "unexpected tokens" in check(ei, path, "end of file")


SBM = ["3", "1", "1", "3", "3", "1", "1", "1", "3", "3", "2", "1", "0", "1", "0",
       "0", "1", "0", "0", "0", "1", "0", "0", "0", "1",
       "-1", "0", "0", "0.5"]


def test_sbm_valid_then_bad_block_number(tmp_path):
    p = read_problem(write_tokens(tmp_path, SBM, "sbm_ok.dat"))
    np.testing.assert_array_equal(p.W.toarray(), np.eye(3))
    bad = list(SBM)
    bad[15] = "5"  # block number must be 0
    path = write_tokens(tmp_path, bad)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "block number" in check(ei, path, "W blocks")


def test_sbm_block_column_out_of_range(tmp_path):
    bad = list(SBM)
    bad[14] = "3"  # index2_data: only one block column
    path = write_tokens(tmp_path, bad)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "out of range" in check(ei, path, "W.index2_data")


def test_sbm_block_sizes_disagree_with_matrix(tmp_path):
    bad = list(SBM)
    bad[8] = "4"  # cumulative row size 4 != 3
    path = write_tokens(tmp_path, bad)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    check(ei, path, "W.blocksize0")


CSC_LINES = ["2", "1", "2", "2", "2", "2",
             "CSparse Version 3.1.9, May 4, 2016.  Copyright (c) Timothy A. Davis, 2006-2016",
             "2-by-2, nzmax: 2 nnz: 2, 1-norm: 1",
             "    col 0 : locations 0 to 0", "      0 : 1",
             "    col 1 : locations 1 to 1", "      1 : 1",
             "0 0", "0.1"]


def test_csparse_locations_inconsistent(tmp_path):
    p = read_problem(write_tokens(tmp_path, CSC_LINES, "csc_ok.dat"))
    np.testing.assert_array_equal(p.W.toarray(), np.eye(2))
    bad = list(CSC_LINES)
    bad[8] = "    col 0 : locations 0 to 1"
    path = write_tokens(tmp_path, bad)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    check(ei, path, "W column pointers")


def test_csparse_row_index_out_of_range(tmp_path):
    bad = list(CSC_LINES)
    bad[11] = "      5 : 1"
    path = write_tokens(tmp_path, bad)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "out of range" in check(ei, path, "W")


# ------------------------------------------------------------------ FCLib HDF5
@pytest.fixture
def good_h5(tmp_path):
    """A valid local FCLib file (written once per test, 3 contacts)."""
    rng = np.random.default_rng(0)
    A = rng.standard_normal((9, 9))
    p = FrictionContactProblem(sp.csr_matrix(A @ A.T), rng.standard_normal(9), 0.3, 3)
    path = write_fclib(p, tmp_path / "good.hdf5")
    assert read_problem(path).n_contacts == 3
    return path


def mutate(path, fn):
    with h5py.File(path, "r+") as h:
        fn(h)
    return path


def replace_ds(h, name, data):
    del h[name]
    h.create_dataset(name, data=data)


def test_truncated_hdf5(good_h5):
    data = good_h5.read_bytes()
    good_h5.write_bytes(data[: len(data) // 2])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    exc = ei.value
    assert exc.source == str(good_h5) and str(good_h5) in str(exc)
    assert f"'{exc.field}'" in str(exc) and exc.field  # a named field (file or dataset)


def test_hdf5_header_only(good_h5):
    good_h5.write_bytes(good_h5.read_bytes()[:16])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "cannot be opened" in check(ei, good_h5, "HDF5 file")


def test_hdf5_without_fclib_groups(tmp_path):
    path = tmp_path / "other.h5"
    with h5py.File(path, "w") as h:
        h.create_dataset("data", data=np.arange(3))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "not an FCLib" in check(ei, path, "/fclib_local or /fclib_global")


@pytest.mark.parametrize("name", ["/fclib_local/W", "/fclib_local/vectors/q", "/fclib_local/vectors/mu",
                                  "/fclib_local/spacedim", "/fclib_local/W/x"])
def test_hdf5_missing_dataset(good_h5, name):
    mutate(good_h5, lambda h: h.__delitem__(name))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "missing" in check(ei, good_h5, name)


def test_hdf5_q_length_mismatch(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/vectors/q", np.zeros(8)))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "expected 9" in check(ei, good_h5, "/fclib_local/vectors/q")


def test_hdf5_non_numeric_vector(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/vectors/q", np.bytes_(b"oops")))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "numeric" in check(ei, good_h5, "/fclib_local/vectors/q")


def test_hdf5_nan_mu(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/vectors/mu", [0.3, np.nan, 0.3]))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "NaN" in check(ei, good_h5, "/fclib_local/vectors/mu")


def test_hdf5_negative_mu(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/vectors/mu", [0.3, -0.1, 0.3]))
    with pytest.raises(InvalidProblemError) as ei:
        read_problem(good_h5)
    check(ei, good_h5, "mu", InvalidProblemError)


def test_hdf5_wrong_spacedim(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/spacedim", np.array([4], dtype=np.int32)))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "got 4" in check(ei, good_h5, "/fclib_local/spacedim")


def _to_triplet(h, row_shift=0):
    W = sp.coo_matrix(np.ones((9, 9)))
    replace_ds(h, "/fclib_local/W/nz", np.array([W.nnz], dtype=np.int32))
    replace_ds(h, "/fclib_local/W/i", (W.row + row_shift).astype(np.int32))
    replace_ds(h, "/fclib_local/W/p", W.col.astype(np.int32))
    replace_ds(h, "/fclib_local/W/x", W.data)


def test_hdf5_triplet_index_out_of_range(good_h5):
    mutate(good_h5, lambda h: _to_triplet(h, row_shift=1))  # largest row index becomes 9 >= m
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "row index 9 out of range" in check(ei, good_h5, "/fclib_local/W/i")


def test_hdf5_csc_pointers_decreasing(good_h5):
    def fn(h):
        p = h["/fclib_local/W/p"][()]
        p[3], p[4] = p[4], p[3]
        replace_ds(h, "/fclib_local/W/p", p)
    mutate(good_h5, fn)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "non-decreasing" in check(ei, good_h5, "/fclib_local/W/p")


def test_hdf5_csc_pointer_beyond_entries(good_h5):
    def fn(h):
        p = h["/fclib_local/W/p"][()]
        p[-1] += 5
        replace_ds(h, "/fclib_local/W/p", p)
    mutate(good_h5, fn)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "at least 86 expected" in check(ei, good_h5, "/fclib_local/W/i")


def test_hdf5_csc_too_few_pointers(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/W/p", h["/fclib_local/W/p"][()][:5]))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "at least 10 expected" in check(ei, good_h5, "/fclib_local/W/p")


def test_hdf5_unknown_storage_code(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/W/nz", np.array([-3], dtype=np.int32)))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "unknown storage code -3" in check(ei, good_h5, "/fclib_local/W/nz")


def test_hdf5_global_H_rows_mismatch(tmp_path):
    g = GlobalFrictionContactProblem(sp.eye(4), sp.csr_matrix(np.ones((4, 3))), np.ones(4), np.zeros(3), 0.2, 3)
    path = write_fclib(g, tmp_path / "g.hdf5")

    def fn(h):
        replace_ds(h, "/fclib_global/H/m", np.array([5], dtype=np.int32))
    mutate(path, fn)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "expected 4" in check(ei, path, "/fclib_global/H")


def test_hdf5_missing_guess_group(good_h5):
    def fn(h):
        g = h.create_group("guesses")
        g.create_dataset("number_of_guesses", data=np.array([2], dtype=np.int32))
        g.create_group("1").create_dataset("r", data=np.zeros(9))
    mutate(good_h5, fn)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "missing group" in check(ei, good_h5, "/guesses/2")


def test_hdf5_solution_wrong_length(good_h5):
    mutate(good_h5, lambda h: h.create_group("solution").create_dataset("r", data=np.zeros(4)))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "expected 9" in check(ei, good_h5, "/solution/r")


# ------------------------------------------- Siconos text: shifted values, odd tokens
def drop_token(text, index):
    """*text* without its whitespace-separated token number *index*, line layout kept."""
    lines, seen = text.split("\n"), 0
    for li, line in enumerate(lines):
        toks = line.split()
        if seen + len(toks) > index:
            del toks[index - seen]
            lines[li] = " ".join(toks)
            return "\n".join(lines)
        seen += len(toks)
    raise IndexError(index)


W2D = np.array([[2.0, 0.5, 0.1, 0.0], [0.5, 1.0, 0.0, 0.2], [0.1, 0.0, 3.0, 0.4], [0.0, 0.2, 0.4, 2.0]])


def test_siconos_layout_helper_reads_back(tmp_path):
    path = tmp_path / "ok.dat"
    path.write_text(siconos_dense_text(W2D, [-1, 0.5, -2, 0.25], [0.3, 0.6], 2, trailing="1"))
    p = read_problem(path)
    np.testing.assert_array_equal(p.W.toarray(), W2D)
    np.testing.assert_array_equal(p.mu, [0.3, 0.6])


def test_dense_missing_W_value_with_trailing_flag_is_rejected(tmp_path):
    """One W value lost: q and mu would shift by one and the flag '1' become a mu."""
    text = siconos_dense_text(W2D, [-1, 0.5, -2, 0.25], [0.3, 0.6], 2, trailing="1")
    path = tmp_path / "missing_w.dat"
    path.write_text(drop_token(text, 7 + 5))  # 7 header tokens, then W
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "new line" in check(ei, path, "q")


def test_old_layout_missing_W_value_is_rejected(tmp_path):
    """Old files: one value per line, blank lines between sections."""
    toks = ["3", "1", "", "0", "3", "3", "", "3", "3", "", "1", "0", "0", "", "0", "1", "0", "",
            "0", "0", "1", "", "-1", "0", "0", "", "0.5", "1"]
    del toks[toks.index("1", 10)]  # first W value
    path = tmp_path / "old.dat"
    path.write_text("\n".join(toks))
    with pytest.raises(ProblemFormatError):
        read_problem(path)


def test_2d_missing_mu_value_followed_by_flag_is_rejected(tmp_path):
    text = siconos_dense_text(W2D, [-1, 0.5, -2, 0.25], [0.3, 0.6], 2, trailing="0")
    path = tmp_path / "missing_mu.dat"
    path.write_text(drop_token(text, 7 + 16 + 4 + 1))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    check(ei, path, "mu")


def test_2d_one_mu_too_many_is_rejected(tmp_path):
    text = siconos_dense_text(W2D, [-1, 0.5, -2, 0.25], [0.3, 0.6, 0.9], 2)
    assert text.startswith("2\n3\n")
    text = "2\n2\n" + text[4:]  # header keeps 2 contacts
    path = tmp_path / "extra_mu.dat"
    path.write_text(text)
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert "line goes on" in check(ei, path, "mu")


def test_huge_token_is_not_echoed_whole(tmp_path):
    path = write_tokens(tmp_path, replaced(W_FIRST + 4, "7" * 2_000_000 + "x"))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    msg = check(ei, path, "W")
    assert len(msg) < 500
    assert "2000001 bytes" in msg


@pytest.mark.parametrize("index, value, field", [(W_FIRST + 4, "1_4", "W"), (Q_FIRST, "1_0", "q"),
                                                 (1, "0_1", "n_contacts")])
def test_underscore_digit_groups_are_rejected(tmp_path, index, value, field):
    path = write_tokens(tmp_path, replaced(index, value))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    assert value in check(ei, path, field)


def test_trailing_token_must_be_an_integer_flag(tmp_path):
    path = write_tokens(tmp_path, GOOD + ["0.5"])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path)
    check(ei, path, "end of file")


def test_declared_size_beyond_the_file_fails_before_allocating(tmp_path):
    """An all-zero sparse-block W declared 10^9 x 10^9 must not allocate its row pointers."""
    path = write_tokens(tmp_path, ["2", str(10**9 // 2), "1", str(10**9), str(10**9), "0", "0.5"])
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(path, global_problem=False)
    assert "exceeds" in check(ei, path, "W")


# ------------------------------------------- FCLib HDF5: sizes declared, never stored
def declare_unwritten(h, name, n, dtype="f8", **kw):
    """Replace dataset *name* by one declaring *n* values and storing none."""
    del h[name]
    h.create_dataset(name, shape=(n,), dtype=dtype, **kw)


@pytest.mark.parametrize("name, n, kw", [
    ("/fclib_local/vectors/q", 2 * 10**9, {}),
    ("/fclib_local/W/x", 2 * 10**9, {}),
    ("/fclib_local/W/i", 4 * 10**8, {"compression": "gzip", "chunks": (10**6,)}),
], ids=["q-2e9", "W.x-2e9", "W.i-gzip-4e8"])
def test_hdf5_inflated_dataset_rejected_before_reading(good_h5, name, n, kw):
    """A small file declaring gigabytes: rejected from the declared size, nothing read.

    Run under a 1 GB address-space cap, so that reading it (16 GB, 3.2 GB)
    would end in a raw MemoryError instead of a format error.
    """
    mutate(good_h5, lambda h: declare_unwritten(h, name, n, "i4" if name.endswith("/i") else "f8", **kw))
    assert good_h5.stat().st_size < 100_000
    out = read_capped(good_h5)
    assert out["status"] == "error", out
    assert out["type"] == "ProblemFormatError"
    assert f"field '{name}'" in out["message"]
    assert out["maxrss_kb"] < 400_000


def test_hdf5_unwritten_small_dataset_reads_as_fill_value(good_h5):
    """Real files hold small datasets never written (Box_Stacks /solution/r): zeros, not an error."""
    def add(h):
        h.create_group("solution").create_dataset("r", shape=(9,), dtype="f8")
    mutate(good_h5, add)
    np.testing.assert_array_equal(read_problem(good_h5).solution.r, np.zeros(9))


def test_hdf5_size_field_with_many_values_rejected(good_h5):
    mutate(good_h5, lambda h: replace_ds(h, "/fclib_local/W/m", np.array([9, 9], dtype=np.int32)))
    with pytest.raises(ProblemFormatError) as ei:
        read_problem(good_h5)
    assert "expected 1" in check(ei, good_h5, "/fclib_local/W/m")


# ------------------------------------------------------------------ path arguments
@pytest.mark.parametrize("path", [None, 3, 2.5, b"\xff\xfe.dat", "", object()],
                         ids=["None", "int", "float", "non-utf8-bytes", "empty", "object"])
@pytest.mark.parametrize("reader", ["read_problem", "read_fclib", "read_siconos_dat"])
def test_non_path_argument_raises_socp_cd_error(path, reader):
    import socp_cd.io
    from socp_cd.errors import InvalidArgumentError
    with pytest.raises(InvalidArgumentError) as ei:
        getattr(socp_cd.io, reader)(path)
    assert isinstance(ei.value, SocpCdError) and ei.value.argument == "path"
    assert "path" in str(ei.value)


def test_utf8_bytes_path_is_accepted(tmp_path):
    path = write_tokens(tmp_path, GOOD, "good.dat")
    assert read_problem(str(path).encode()).n_contacts == 1


# ------------------------------------------------------------------ command line
def run_cli(argv, capsys):
    from socp_cd.cli import main
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def good_dat(tmp_path):
    return write_tokens(tmp_path, GOOD, "good.dat")


@pytest.mark.parametrize("argv", [
    ["solve", "MISSING"], ["info", "MISSING"], ["solve", "GOOD", "--solver", "foo"],
    ["solve", "GOOD", "--tol", "0"], ["solve", "GOOD", "--tol", "abc"], ["bogus"], ["solve"],
    ["info", "BAD"], ["solve", "GOOD", "--time-limit", "-1"],
    ["solve", "GOOD", "--time-limit", "nan"],
], ids=["solve-missing", "info-missing", "solver-foo", "tol-0", "tol-abc", "bogus-cmd",
        "no-file", "bad-file", "time-limit-negative", "time-limit-nan"])
def test_cli_bad_input_is_one_line_and_code_2(argv, good_dat, tmp_path, capsys):
    from socp_cd.cli import EXIT_BAD_INPUT
    bad = write_tokens(tmp_path, GOOD[:-1], "bad.dat")
    names = {"MISSING": tmp_path / "missing.dat", "GOOD": good_dat, "BAD": bad}
    code, out, err = run_cli([names.get(a, a) for a in argv], capsys)
    assert code == EXIT_BAD_INPUT
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("socp-cd") and "error:" in lines[0]
    assert "Traceback" not in err


def test_cli_codes_are_distinct_and_documented(capsys):
    from socp_cd import cli
    codes = [cli.EXIT_OK, cli.EXIT_NOT_CONVERGED, cli.EXIT_BAD_INPUT, cli.EXIT_INTERNAL]
    assert len(set(codes)) == 4
    with pytest.raises(SystemExit) as ei:
        cli.main(["--help"])
    assert ei.value.code == 0
    out = capsys.readouterr().out
    for code in codes:
        assert f"{code:3d}  {cli.EXIT_CODES[code]}" in out


def test_cli_internal_error_is_one_line_and_code_3(good_dat, capsys, monkeypatch):
    import socp_cd
    from socp_cd.cli import EXIT_INTERNAL

    def broken(*args, **kwargs):
        raise ZeroDivisionError("boom\nsecond line")
    monkeypatch.setattr(socp_cd, "read_problem", broken)
    monkeypatch.delenv("SOCP_CD_DEBUG", raising=False)
    code, out, err = run_cli(["info", good_dat], capsys)
    assert code == EXIT_INTERNAL
    assert err.strip().splitlines() == ["socp-cd info: internal error: ZeroDivisionError: boom second line "
                                        "(set SOCP_CD_DEBUG=1 for the traceback)"]


def test_cli_not_converged_is_code_1(tmp_path, capsys):
    from socp_cd.cli import EXIT_NOT_CONVERGED
    rng = np.random.default_rng(3)
    A = rng.standard_normal((12, 12))
    p = FrictionContactProblem(A @ A.T + np.eye(12), -rng.random(12), 0.8, 3)
    path = write_fclib(p, tmp_path / "p.hdf5")
    code, out, err = run_cli(["solve", path, "--solver", "nsgs", "--max-iter", "1", "--tol", "1e-14"],
                             capsys)
    assert code == EXIT_NOT_CONVERGED, out + err
    assert "converged      False" in out


def test_cli_solve_runs_solves_default_and_passes_its_time_limit(good_dat, capsys, monkeypatch):
    # `socp-cd solve` without --solver runs what socp_cd.solve runs without one ("auto"), and
    # passes --time-limit through (None without it)
    import inspect

    import socp_cd
    default = inspect.signature(socp_cd.solve).parameters["solver"].default
    code, out, err = run_cli(["solve", good_dat, "--time-limit", "100"], capsys)
    assert code == 0, out + err
    assert f"solver         {default}" in out
    assert "converged      True" in out
    seen = []
    real = socp_cd.solve

    def spy(*args, **kw):
        seen.append(kw.get("time_limit", "missing"))
        return real(*args, **kw)

    monkeypatch.setattr(socp_cd, "solve", spy)
    assert run_cli(["solve", good_dat, "--time-limit", "2.5"], capsys)[0] == 0
    assert run_cli(["solve", good_dat], capsys)[0] == 0
    assert seen == [2.5, None]


def test_cli_info_states_rank_method_and_triviality(good_dat, capsys):
    code, out, err = run_cli(["info", good_dat, "--tol", "1e-8"], capsys)
    assert code == 0
    assert "rank_method      dense SVD of" in out
    assert "trivial@1e-08    False" in out


def test_a_built_problems_data_cannot_be_reassigned():
    # compiled kernels read a problem's arrays with the types it was built with (entry points
    # check nothing) and caches are derived from them: another q of float32, say, would be
    # misread; assigning a data field is refused with the field named, metadata stays free,
    # and copies and pickles (which do not assign) still work
    import copy
    import pickle

    import socp_cd
    p = FrictionContactProblem(2 * np.eye(3), np.array([-1.0, 0.1, 0.0]), 0.3, 3)
    g = GlobalFrictionContactProblem(sp.eye(6), sp.csr_matrix(np.eye(6)[:, :3]), -np.ones(6),
                                     np.zeros(3), 0.2, 3)
    for prob, fields in ((p, ("q", "mu", "dim")), (g, ("M", "H", "f", "w", "mu", "dim"))):
        for field in fields:
            before = getattr(prob, field)
            with pytest.raises(InvalidProblemError, match="immutable") as e:
                setattr(prob, field, np.ones(3, dtype=np.float32))
            assert e.value.field == field and getattr(prob, field) is before
    p.name = "renamed"
    assert p.name == "renamed"
    ref = socp_cd.solve(p)
    for other in (copy.copy(p), pickle.loads(pickle.dumps(p))):
        res = socp_cd.solve(other)
        assert res.converged and np.array_equal(res.r, ref.r)
    assert socp_cd.solve(p.with_(q=np.array([-2.0, 0.0, 0.0]))).converged
