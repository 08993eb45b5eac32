"""Reading/writing problem files: real shared data, hand-written files, round trips."""
from __future__ import annotations

import os

import h5py
import numpy as np
import pytest
import scipy.sparse as sp

from socp_cd import FrictionContactProblem, GlobalFrictionContactProblem, Solution
from socp_cd.data import SharedProblem, shared_problems, shared_problems_dir
from socp_cd.bench.siconos_peer import siconos_available, siconos_load
from socp_cd.io import detect_format, read_problem, write_fclib

DATA = shared_problems_dir()
ENTRIES = shared_problems()
needs_data = pytest.mark.skipif(DATA is None or not ENTRIES, reason="shared data directory absent")


def _canonical(A):
    A = sp.csr_matrix(A, copy=True)
    A.sort_indices()
    return A


def assert_same_matrix(A, B):
    A, B = _canonical(A), _canonical(B)
    assert A.shape == B.shape
    np.testing.assert_array_equal(A.indptr, B.indptr)
    np.testing.assert_array_equal(A.indices, B.indices)
    np.testing.assert_array_equal(A.data, B.data)


def assert_same_solution(a, b):
    if a is None or b is None:
        assert a is None and b is None
        return
    for key in "ruv":
        x, y = getattr(a, key), getattr(b, key)
        if x is None or y is None:
            assert x is None and y is None, key
        else:
            np.testing.assert_array_equal(x, y)


def assert_same_problem(p, p2):
    assert p2.is_global == p.is_global
    assert p2.dim == p.dim
    np.testing.assert_array_equal(p2.mu, p.mu)
    if p.is_global:
        assert_same_matrix(p.M, p2.M)
        assert_same_matrix(p.H, p2.H)
        np.testing.assert_array_equal(p2.f, p.f)
        np.testing.assert_array_equal(p2.w, p.w)
    else:
        assert_same_matrix(p.W, p2.W)
        np.testing.assert_array_equal(p2.q, p.q)
    assert_same_solution(p.solution, p2.solution)
    assert len(p2.guesses) == len(p.guesses)
    for a, b in zip(p.guesses, p2.guesses):
        assert_same_solution(a, b)


# ------------------------------------------------------------ shared problems
@pytest.fixture(scope="module")
def loaded():
    """Every shared problem read once (module scope keeps the file fast)."""
    return {e.file: read_problem(e) for e in ENTRIES}


@pytest.fixture(scope="module")
def round_tripped(loaded, tmp_path_factory):
    out = tmp_path_factory.mktemp("fclib")
    return {name: read_problem(write_fclib(p, out / (name + ".h5"))) for name, p in loaded.items()}


@needs_data
def test_manifest_lists_31_problems():
    assert len(ENTRIES) == 31
    assert all(e.path.is_file() for e in ENTRIES)


@needs_data
@pytest.mark.parametrize("entry", ENTRIES, ids=[e.file for e in ENTRIES])
def test_shared_problem_matches_manifest(entry, loaded):
    p = loaded[entry.file]
    assert p.is_global == (entry.kind == "global")
    assert p.dim == entry.dim
    assert p.n_contacts == entry.contacts
    if entry.mu is not None:
        assert p.mu.min() == pytest.approx(entry.mu[0])
        assert p.mu.max() == pytest.approx(entry.mu[1])
    assert p.source == str(entry.path)
    assert p.name == entry.file
    assert (p.solution is not None) == entry.has_solution
    expected = "fclib-hdf5" if entry.format.startswith("fclib") else "siconos-dat"
    assert detect_format(entry.path) == expected


@needs_data
@pytest.mark.parametrize("entry", ENTRIES, ids=[e.file for e in ENTRIES])
def test_round_trip_is_exact(entry, loaded, round_tripped):
    p, p2 = loaded[entry.file], round_tripped[entry.file]
    assert_same_problem(p, p2)
    assert p2.info == p.info


@needs_data
def test_fclib_solution_and_guesses_read_as_stored(loaded):
    """Compare with the raw datasets read directly through h5py."""
    for e in ENTRIES:
        if not e.format.startswith("fclib"):
            continue
        p = loaded[e.file]
        with h5py.File(e.path, "r") as h:
            if "solution" in h:
                for key in h["solution"]:
                    np.testing.assert_array_equal(getattr(p.solution, key), h["solution"][key][()])
            n = int(h["guesses/number_of_guesses"][0]) if "guesses" in h else 0
            assert len(p.guesses) == n
            for k in range(n):
                for key in h[f"guesses/{k + 1}"]:
                    np.testing.assert_array_equal(getattr(p.guesses[k], key), h[f"guesses/{k + 1}"][key][()])


@needs_data
def test_hdf5_named_dat_files_are_text(loaded):
    names = [e.file for e in ENTRIES if e.file.endswith(".hdf5.dat")]
    assert names
    for name in names:
        assert detect_format(DATA / name) == "siconos-dat"


@needs_data
@pytest.mark.skipif(not siconos_available(), reason="Siconos numerics not installed for /usr/bin/python3")
@pytest.mark.parametrize("name", ["FC2D_SliderCrankLagrangian00000.dat", "Rover4396.dat",
                                  "FrictionContactProblem00071.dat", "OneObject-i1028-138.hdf5.dat",
                                  "fc2d_granularflowonwall_00667_00000.dat", "GFC3D_Example0.dat",
                                  "GFC3D_TwoRods1.dat"])
def test_text_reader_agrees_with_siconos(name, loaded, tmp_path):
    """Siconos' own reader is the oracle (its export drops |x| < DBL_EPSILON: compare to eps)."""
    p = loaded[name]
    z = siconos_load(DATA / name, "global" if p.is_global else "local")
    eps = np.finfo(float).eps
    assert int(z["dim"]) == p.dim
    np.testing.assert_array_equal(z["mu"], p.mu)
    if p.is_global:
        assert abs(sp.csr_matrix(z["M"]) - p.M).max() <= eps
        assert abs(sp.csr_matrix(z["H"]) - p.H).max() <= eps
        np.testing.assert_array_equal(z["f"], p.f)
        np.testing.assert_array_equal(z["w"], p.w)
    else:
        assert abs(sp.csr_matrix(z["W"]) - p.W).max() <= eps
        np.testing.assert_array_equal(z["q"], p.q)


# ------------------------------------------------------------ hand-written text files
DENSE_DAT = """3
1
0
3
3
3\t3
1 4 7
2 5 8
3 6 10
-1 0.5 2
0.25
1
"""  # column-major: W = [[1,2,3],[4,5,6],[7,8,10]]; trailing legacy flag "1"

SBM_DAT = """2
2
1
4
4
3
2
2
2\t4\t
2\t4\t
3
3
0\t2\t3\t
0\t1\t1\t
0
1
3
2
4
1
5
7
6
8
2
9
11
10
12
0.1 0.2 0.3 0.4
0.5 0.6
"""

# Expected matrices of the tiny files below were also confirmed with Siconos 4.4's own reader.
CSC_DAT = """2
2
2
4
4
2
CSparse Version 3.1.9, May 4, 2016.  Copyright (c) Timothy A. Davis, 2006-2016
4-by-4, nzmax: 4 nnz: 4, 1-norm: 4
    col 0 : locations 0 to 1
      0 : 1
      1 : -2
    col 1 : locations 2 to 2
      1 : 3
    col 2 : locations 3 to 2
    col 3 : locations 3 to 3
      3 : 4.5e-01
1 2 3 4
0.3 0.4
"""

TRIPLET_DAT = """2
1
2
2
2
1
CSparse Version 3.1.9, May 4, 2016.  Copyright (c) Timothy A. Davis, 2006-2016
triplet: 2-by-2, nzmax: 3 nnz: 3
    0 0 : 1.5
    1 0 : -2
    1 1 : 3
0 0
0.7
"""

GLOBAL_SBM_DAT = """2
1
1
3
3
2
2
2
1\t3\t
1\t3\t
3
2
0\t1\t2\t
0\t1\t
0
2
1
3
1
1
4
1
3
2
2
2
1
1\t3\t
2\t
3
2
0\t1\t2\t
0\t0\t
0
1
2
1
3
5
4
6
1 2 3
-0.5 0.25
0.4
"""  # M = [[2,0,0],[0,3,1],[0,1,4]], H = [[1,2],[3,4],[5,6]] (blocks of unequal sizes)


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_dense_dat_is_column_major(tmp_path):
    p = read_problem(_write(tmp_path, "dense.dat", DENSE_DAT))
    assert isinstance(p, FrictionContactProblem)
    np.testing.assert_array_equal(p.W.toarray(), [[1, 2, 3], [4, 5, 6], [7, 8, 10]])
    np.testing.assert_array_equal(p.q, [-1, 0.5, 2])
    np.testing.assert_array_equal(p.mu, [0.25])


def test_sparse_block_dat(tmp_path):
    p = read_problem(_write(tmp_path, "sbm.dat", SBM_DAT))
    assert p.dim == 2 and p.n_contacts == 2
    np.testing.assert_array_equal(p.W.toarray(), [[1, 2, 5, 6], [3, 4, 7, 8],
                                                  [0, 0, 9, 10], [0, 0, 11, 12]])
    np.testing.assert_array_equal(p.q, [0.1, 0.2, 0.3, 0.4])
    np.testing.assert_array_equal(p.mu, [0.5, 0.6])


def test_csparse_csc_dat_with_empty_column(tmp_path):
    p = read_problem(_write(tmp_path, "csc.dat", CSC_DAT))
    expected = np.zeros((4, 4))
    expected[0, 0], expected[1, 0], expected[1, 1], expected[3, 3] = 1, -2, 3, 0.45
    np.testing.assert_array_equal(p.W.toarray(), expected)
    np.testing.assert_array_equal(p.q, [1, 2, 3, 4])


def test_csparse_csr_origin_dat_headers_are_rows(tmp_path):
    """Origin 3 (NSM_CSR): Siconos prints compressed rows under the same 'col j' headers."""
    text = CSC_DAT.split("\n")
    assert text[5] == "2"
    text[5] = "3"
    p = read_problem(_write(tmp_path, "csr.dat", "\n".join(text)))
    expected = np.zeros((4, 4))
    expected[0, 0], expected[0, 1], expected[1, 1], expected[3, 3] = 1, -2, 3, 0.45
    np.testing.assert_array_equal(p.W.toarray(), expected)


def test_csparse_triplet_dat(tmp_path):
    p = read_problem(_write(tmp_path, "trip.dat", TRIPLET_DAT))
    np.testing.assert_array_equal(p.W.toarray(), [[1.5, 0], [-2, 3]])
    np.testing.assert_array_equal(p.mu, [0.7])


def test_global_dat_with_unequal_blocks(tmp_path):
    p = read_problem(_write(tmp_path, "GFC3D_tiny.dat", GLOBAL_SBM_DAT))
    assert isinstance(p, GlobalFrictionContactProblem)
    np.testing.assert_array_equal(p.M.toarray(), [[2, 0, 0], [0, 3, 1], [0, 1, 4]])
    np.testing.assert_array_equal(p.H.toarray(), [[1, 2], [3, 4], [5, 6]])
    np.testing.assert_array_equal(p.f, [1, 2, 3])
    np.testing.assert_array_equal(p.w, [-0.5, 0.25])
    # the same file forced to the local layout is rejected, not misread
    with pytest.raises(Exception):
        read_problem(tmp_path / "GFC3D_tiny.dat", global_problem=False)


def test_global_layout_found_without_gfc_name(tmp_path):
    """A global file not named GFC* does not fit the local layout; the global one is tried."""
    p = read_problem(_write(tmp_path, "renamed.dat", GLOBAL_SBM_DAT))
    assert isinstance(p, GlobalFrictionContactProblem)
    np.testing.assert_array_equal(p.H.toarray(), [[1, 2], [3, 4], [5, 6]])


def test_text_file_named_hdf5_is_read_as_text(tmp_path):
    p = read_problem(_write(tmp_path, "looks_like.hdf5", DENSE_DAT))
    assert p.W.shape == (3, 3)


# ------------------------------------------------------------ hand-written HDF5 files
W_REF = np.array([[4.0, 1.0, 0.0], [-1.0, 3.0, 0.5], [0.0, 2.0, 5.0]])  # non-symmetric


def _h5_matrix(group, m, n, nz, p, i, x, nzmax=None):
    group.create_dataset("m", data=np.array([m], dtype=np.int32))
    group.create_dataset("n", data=np.array([n], dtype=np.int32))
    group.create_dataset("nz", data=np.array([nz], dtype=np.int32))
    group.create_dataset("nzmax", data=np.array([nzmax if nzmax is not None else len(x)], dtype=np.int32))
    group.create_dataset("p", data=np.asarray(p, dtype=np.int32))
    group.create_dataset("i", data=np.asarray(i, dtype=np.int32))
    group.create_dataset("x", data=np.asarray(x, dtype=np.float64))


def _local_h5(path, matrix_args, q=(1.0, 2.0, 3.0), mu=(0.3,), extra=None):
    with h5py.File(path, "w") as h:
        g = h.create_group("fclib_local")
        g.create_dataset("spacedim", data=np.array([3], dtype=np.int32))
        _h5_matrix(g.create_group("W"), *matrix_args)
        v = g.create_group("vectors")
        v.create_dataset("q", data=np.asarray(q, dtype=float))
        v.create_dataset("mu", data=np.asarray(mu, dtype=float))
        info = g.create_group("info")
        info.create_dataset("title", data=np.bytes_(b"tiny"))
        info.create_dataset("description", data=np.bytes_(b"hand written"))
        if extra:
            extra(h)
    return path


def test_hdf5_csc(tmp_path):
    C = sp.csc_matrix(W_REF)
    p = read_problem(_local_h5(tmp_path / "csc.hdf5", (3, 3, -1, C.indptr, C.indices, C.data)))
    np.testing.assert_array_equal(p.W.toarray(), W_REF)
    assert p.info == "tiny\nhand written"
    assert p.solution is None and p.guesses == []


def test_hdf5_csr(tmp_path):
    R = sp.csr_matrix(W_REF)
    p = read_problem(_local_h5(tmp_path / "csr.hdf5", (3, 3, -2, R.indptr, R.indices, R.data)))
    np.testing.assert_array_equal(p.W.toarray(), W_REF)


def test_hdf5_triplet_with_nzmax_larger_than_nz(tmp_path):
    rows, cols = np.nonzero(W_REF)
    vals = W_REF[rows, cols]
    nz = len(vals)
    # arrays padded to nzmax with garbage that must be ignored
    pad = 3
    i = np.concatenate([rows, [99] * pad])
    p_ = np.concatenate([cols, [99] * pad])
    x = np.concatenate([vals, [np.nan] * pad])
    p = read_problem(_local_h5(tmp_path / "trip.hdf5", (3, 3, nz, p_, i, x, nz + pad)))
    np.testing.assert_array_equal(p.W.toarray(), W_REF)  # i = rows, p = columns


def test_hdf5_csc_with_nzmax_padding(tmp_path):
    C = sp.csc_matrix(W_REF)
    i = np.concatenate([C.indices, [7, 7]])
    x = np.concatenate([C.data, [1e300, 1e300]])
    p = read_problem(_local_h5(tmp_path / "cscpad.hdf5", (3, 3, -1, C.indptr, i, x, C.nnz + 2)))
    np.testing.assert_array_equal(p.W.toarray(), W_REF)


def test_hdf5_solution_and_guesses(tmp_path):
    C = sp.csc_matrix(W_REF)

    def extra(h):
        s = h.create_group("solution")
        s.create_dataset("r", data=[1.0, 0.1, 0.0])
        s.create_dataset("u", data=[0.0, 0.2, 0.3])
        g = h.create_group("guesses")
        g.create_dataset("number_of_guesses", data=np.array([2], dtype=np.int32))
        for k in (1, 2):
            gk = g.create_group(str(k))
            gk.create_dataset("r", data=[float(k), 0.0, 0.0])
            gk.create_dataset("u", data=[0.0, 0.0, float(-k)])

    p = read_problem(_local_h5(tmp_path / "sol.hdf5", (3, 3, -1, C.indptr, C.indices, C.data), extra=extra))
    np.testing.assert_array_equal(p.solution.r, [1.0, 0.1, 0.0])
    np.testing.assert_array_equal(p.solution.u, [0.0, 0.2, 0.3])
    assert p.solution.v is None
    assert len(p.guesses) == 2
    np.testing.assert_array_equal(p.guesses[1].r, [2.0, 0.0, 0.0])
    np.testing.assert_array_equal(p.guesses[1].u, [0.0, 0.0, -2.0])


def test_hdf5_file_named_dat_is_read_as_hdf5(tmp_path):
    C = sp.csc_matrix(W_REF)
    p = read_problem(_local_h5(tmp_path / "named.dat", (3, 3, -1, C.indptr, C.indices, C.data)))
    np.testing.assert_array_equal(p.W.toarray(), W_REF)


def test_write_global_with_explicit_solution(tmp_path):
    M = sp.diags([2.0, 3.0, 4.0, 5.0])
    H = sp.csr_matrix(np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]))
    g = GlobalFrictionContactProblem(M, H, [1, 2, 3, 4], [0.5, 0, 0], 0.2, 3, info="Title\nline 1\nline 2",
                                     guesses=[Solution(r=np.ones(3))])
    sol = Solution(r=np.array([1.0, 0.1, 0.1]), u=np.zeros(3), v=np.arange(4.0))
    g2 = read_problem(write_fclib(g, tmp_path / "g.h5", solution=sol))
    assert g2.info == "Title\nline 1\nline 2"
    assert_same_matrix(g.M, g2.M)
    assert_same_matrix(g.H, g2.H)
    assert_same_solution(g2.solution, sol)
    np.testing.assert_array_equal(g2.guesses[0].r, np.ones(3))
    with h5py.File(tmp_path / "g.h5", "r") as h:  # FCLib layout and dtypes
        assert int(h["fclib_global/M/nz"][0]) == -1
        assert h["fclib_global/M/p"].dtype == np.int32
        assert h["fclib_global/info/title"][()] == b"Title"
        assert int(h["fclib_global/spacedim"][0]) == 3


# ------------------------------------------------------------ data helper
def test_shared_problems_dir_env_override(tmp_path, monkeypatch):
    (tmp_path / "MANIFEST.tsv").write_text("file\tformat\tkind\tdim\tcontacts\tmu\n"
                                           "a.dat\tsiconos-dat (dense)\tlocal\t3\t1\t0.1..0.2\n"
                                           "b.hdf5\tfclib-hdf5\tglobal (stored solution)\t2\t4\t\n")
    monkeypatch.setenv("SOCP_CD_DATA", str(tmp_path))
    assert shared_problems_dir() == tmp_path
    allp = shared_problems()
    assert [e.file for e in allp] == ["a.dat", "b.hdf5"]
    assert allp[0].mu == (0.1, 0.2) and allp[1].mu is None
    assert allp[1].has_solution and not allp[0].has_solution
    assert os.fspath(allp[0]) == str(tmp_path / "a.dat")
    assert [e.file for e in shared_problems(kind="global")] == ["b.hdf5"]
    assert [e.file for e in shared_problems(dim=3)] == ["a.dat"]
    monkeypatch.setenv("SOCP_CD_DATA", str(tmp_path / "missing"))
    assert shared_problems_dir() is None
    assert shared_problems() == []


@needs_data
def test_shared_problems_filters():
    glob_ = shared_problems(kind="global")
    assert glob_ and all(e.kind == "global" for e in glob_)
    two = shared_problems(dim=2)
    assert two and all(e.dim == 2 for e in two)
    assert isinstance(ENTRIES[0], SharedProblem)


def test_text_reader_memory_is_a_small_multiple_of_the_file(tmp_path):
    """Worst case for a token-list reader: a 3 MB dense W of '0' tokens (2 bytes each).

    Reading cost 30x the file size (tracemalloc; 79x in peak RSS) with a list
    of tokens; the bound is 5x.  validation/reader_memory.py measures 8 MB files.
    """
    from _hostile import dense_zeros_text, read_memory
    path = tmp_path / "zeros.dat"
    path.write_text(dense_zeros_text(1224))
    size = path.stat().st_size
    assert size > 2_900_000
    mem = read_memory(path)
    assert mem["m"] == 1224
    assert mem["traced_peak"] <= 5 * size, mem


@pytest.mark.parametrize("row", ["a.dat\tsiconos-dat\tlocal\tthree\t1\t0.1\n",
                                 "a.dat\tsiconos-dat\tlocal\n",
                                 "a.dat\tsiconos-dat\t\t3\t1\t0.1\n",
                                 "a.dat\tsiconos-dat\tlocal\t3\t1\t0.1..x\n"],
                         ids=["dim-text", "short-row", "empty-kind", "bad-mu"])
def test_malformed_manifest_row_names_the_line(tmp_path, monkeypatch, row):
    from socp_cd.errors import ProblemFormatError
    manifest = tmp_path / "MANIFEST.tsv"
    manifest.write_text("file\tformat\tkind\tdim\tcontacts\tmu\n"
                        "ok.dat\tsiconos-dat\tlocal\t3\t1\t0.1\n" + row)
    monkeypatch.setenv("SOCP_CD_DATA", str(tmp_path))
    with pytest.raises(ProblemFormatError) as ei:
        shared_problems()
    assert ei.value.field == "line 3" and ei.value.source == str(manifest)
