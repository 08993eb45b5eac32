"""Problem construction, validation and algebra (socp_cd.problem)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from socp_cd import FrictionContactProblem, GlobalFrictionContactProblem, InvalidProblemError


def _random_local(nc=3, dim=3, seed=0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((dim * nc, dim * nc))
    return A @ A.T + np.eye(dim * nc), rng.standard_normal(dim * nc), np.full(nc, 0.4)


# ------------------------------------------------------------------ validation
W9, Q9, MU3 = _random_local()


def _nan_at(a, index, value=np.nan):
    b = np.array(a, dtype=float, copy=True)
    b[index] = value
    return b


@pytest.mark.parametrize("kwargs, field", [
    (dict(W=W9[:, :8], q=Q9, mu=MU3), "W"),                       # not square
    (dict(W=W9, q=Q9[:8], mu=MU3), "q"),                          # q length
    (dict(W=W9, q=Q9, mu=MU3[:2]), "mu"),                         # mu length
    (dict(W=_nan_at(W9, (1, 2)), q=Q9, mu=MU3), "W"),             # NaN in W
    (dict(W=_nan_at(W9, (0, 0), np.inf), q=Q9, mu=MU3), "W"),     # Inf in W
    (dict(W=W9, q=_nan_at(Q9, 4), mu=MU3), "q"),                  # NaN in q
    (dict(W=W9, q=_nan_at(Q9, 4, -np.inf), mu=MU3), "q"),         # Inf in q
    (dict(W=W9, q=Q9, mu=_nan_at(MU3, 1)), "mu"),                 # NaN in mu
    (dict(W=W9, q=Q9, mu=_nan_at(MU3, 1, np.inf)), "mu"),         # Inf in mu
    (dict(W=W9, q=Q9, mu=np.array([0.4, -0.1, 0.4])), "mu"),      # mu < 0
    (dict(W=W9, q=Q9, mu=MU3, dim=4), "dim"),                     # dim 4
    (dict(W=W9, q=Q9, mu=MU3, dim=3.0), "dim"),                   # dim not an int
    (dict(W=np.zeros((0, 0)), q=np.zeros(0), mu=np.zeros(0)), "W"),  # zero contacts
    (dict(W=W9[:8, :8], q=Q9[:8], mu=MU3), "W"),                  # 8 not a multiple of 3
    (dict(W=np.ones(9), q=Q9, mu=MU3), "W"),                      # 1-D W
    (dict(W=W9, q=Q9.reshape(3, 3), mu=MU3), "q"),                # q not a vector
    (dict(W=[["a"] * 9] * 9, q=Q9, mu=MU3), "W"),                 # not numbers
    (dict(W=W9 + 1e-3j, q=Q9, mu=MU3), "W"),                      # complex W
    (dict(W=sp.csr_matrix(W9 + 0j), q=Q9, mu=MU3), "W"),          # complex sparse W
    (dict(W=W9, q=Q9 + 1j, mu=MU3), "q"),                         # complex q
    (dict(W=W9, q=list(Q9[:8]) + [1j], mu=MU3), "q"),             # complex in a list
    (dict(W=W9, q=Q9, mu=MU3 + 0j), "mu"),                        # complex mu
])
def test_local_validation_names_the_field(kwargs, field):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning on the way
        with pytest.raises(InvalidProblemError) as info:
            FrictionContactProblem(**kwargs)
    assert info.value.field == field
    assert f"'{field}'" in str(info.value)


def test_validation_error_names_the_source():
    with pytest.raises(InvalidProblemError, match="box.dat") as info:
        FrictionContactProblem(W9, Q9, -1.0, source="box.dat")
    assert info.value.source == "box.dat" and info.value.field == "mu"


def test_sparse_W_with_nan_is_rejected():
    W = sp.csr_matrix(_nan_at(W9, (2, 2)))
    with pytest.raises(InvalidProblemError) as info:
        FrictionContactProblem(W, Q9, MU3)
    assert info.value.field == "W"


def test_scalar_mu_is_broadcast_and_mu_zero_allowed():
    p = FrictionContactProblem(W9, Q9, 0.0)
    np.testing.assert_array_equal(p.mu, [0.0, 0.0, 0.0])
    assert (p.n_contacts, p.m, p.dim) == (3, 9, 3)


def _global_data(n=7, nc=2, dim=3, seed=1):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)   # SPD
    H = rng.standard_normal((n, dim * nc))
    return M, H, rng.standard_normal(n), rng.standard_normal(dim * nc), np.full(nc, 0.3)


@pytest.mark.parametrize("change, field", [
    (lambda d: d.update(M=d["M"][:, :6]), "M"),
    (lambda d: d.update(H=d["H"][:6]), "H"),
    (lambda d: d.update(H=d["H"][:, :5]), "H"),
    (lambda d: d.update(f=d["f"][:6]), "f"),
    (lambda d: d.update(w=d["w"][:5]), "w"),
    (lambda d: d.update(M=_nan_at(d["M"], (0, 1))), "M"),
    (lambda d: d.update(H=_nan_at(d["H"], (0, 1), np.inf)), "H"),
    (lambda d: d.update(f=_nan_at(d["f"], 0)), "f"),
    (lambda d: d.update(w=_nan_at(d["w"], 0)), "w"),
    (lambda d: d.update(mu=np.array([0.3, -1.0])), "mu"),
    (lambda d: d.update(dim=1), "dim"),
    (lambda d: d.update(M=np.zeros((0, 0)), H=np.zeros((0, 6)), f=np.zeros(0)), "M"),
    (lambda d: d.update(M=d["M"] + 0j), "M"),
    (lambda d: d.update(H=sp.csr_matrix(d["H"] * 1j)), "H"),
    (lambda d: d.update(f=d["f"] + 1e-9j), "f"),
    (lambda d: d.update(w=d["w"] + 1j), "w"),
])
def test_global_validation_names_the_field(change, field):
    M, H, f, w, mu = _global_data()
    d = dict(M=M, H=H, f=f, w=w, mu=mu)
    change(d)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning on the way
        with pytest.raises(InvalidProblemError) as info:
            GlobalFrictionContactProblem(**d)
    assert info.value.field == field


# ------------------------------------------------------------------ symmetry and rank
def test_asymmetry_of_a_built_asymmetric_W():
    W = np.diag([2.0, 1.0, 1.0, 3.0, 1.0, 1.0])
    W[0, 3], W[3, 0] = 0.5, 0.2          # |W - W^T| max = 0.3
    W[1, 4], W[4, 1] = -0.1, -0.1        # symmetric pair
    p = FrictionContactProblem(W, np.zeros(6), 0.5)
    assert p.asymmetry == pytest.approx(0.3, rel=1e-15)
    assert not p.is_symmetric
    S, K = p.symmetric_part().toarray(), p.skew_part().toarray()
    np.testing.assert_allclose(S, S.T)
    np.testing.assert_allclose(K, -K.T)
    np.testing.assert_allclose(S + K, W)
    assert K[0, 3] == pytest.approx(0.15) and S[0, 3] == pytest.approx(0.35)


def test_round_off_asymmetry_counts_as_symmetric():
    W = W9.copy()
    W[0, 1] += 1e-13 * np.abs(W9).max()
    p = FrictionContactProblem(W, Q9, MU3)
    assert p.is_symmetric and 0 < p.asymmetry < 1e-11 * np.abs(W9).max()


def test_rank_of_redundant_contacts():
    """A point mass (3 dofs) touched by two contacts with the same frame: rank 3 < 6."""
    M = np.diag([2.0, 2.0, 2.0])
    H = np.hstack([np.eye(3), np.eye(3)])       # two identical contacts
    g = GlobalFrictionContactProblem(M, H, np.zeros(3), np.zeros(6), 0.5)
    assert g.rank == 3 and g.is_rank_deficient
    W = H.T @ np.linalg.solve(M, H)
    p = FrictionContactProblem(W, np.ones(6), 0.5)
    assert p.rank == 3 and p.is_rank_deficient
    full = FrictionContactProblem(W9, Q9, MU3)
    assert full.rank == 9 and not full.is_rank_deficient


def _block_diagonal_shuffled(seed=0):
    """Random blocks of several shapes and ranks, rows and columns permuted."""
    rng = np.random.default_rng(seed)
    blocks = []
    for r, c, k in [(1, 1, 1), (3, 3, 2), (3, 3, 3), (6, 6, 4), (2, 4, 2), (5, 2, 1), (1, 1, 0)]:
        blocks.append(rng.standard_normal((r, k)) @ rng.standard_normal((k, c)))
    A = sp.block_diag(blocks).toarray()
    return A[rng.permutation(A.shape[0])][:, rng.permutation(A.shape[1])]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_blockwise_rank_equals_dense_rank(seed):
    from socp_cd.problem import numerical_rank
    A = _block_diagonal_shuffled(seed)
    report = numerical_rank(sp.csr_matrix(A))
    assert report.rank == np.linalg.matrix_rank(A) == 13
    assert report.structural >= report.rank
    assert "independent blocks" in report.method


def test_rank_of_a_large_diagonal_is_cheap_and_exact():
    """m = 6000, diagonal: 6000 blocks of size 1 (a dense SVD took 54 s and 647 MB)."""
    d = np.ones(6000)
    d[::7] = 0.0
    p = FrictionContactProblem(sp.diags(d).tocsr(), np.ones(6000), 0.3)
    assert p.rank == np.count_nonzero(d)
    assert p.summary()["rank_method"].startswith("dense SVD of")


def test_rank_not_computed_beyond_the_block_limit():
    from socp_cd.problem import numerical_rank
    A = sp.csr_matrix(np.triu(np.ones((30, 30))))
    report = numerical_rank(A, limit=20)
    assert report.rank is None and report.structural == 30
    assert "not computed" in report.method and "30" in report.method
    assert numerical_rank(A, limit=30).rank == 30


@pytest.mark.parametrize("scale, tol, trivial", [(1e-18, 1e-8, True), (1.0, 1e-8, False),
                                                 (1e-10, 1e-8, False), (1e-18, 1e-20, False)])
def test_summary_flags_problems_trivial_at_tol(scale, tol, trivial):
    """r = 0 meets tol when q is tiny (||q|| ~ 1e-18): flagged so a study does not count it."""
    from socp_cd import error
    q = scale * np.tile([-1.0, 0.5, 0.0], 3)  # approaching contacts: r = 0 is not a solution
    p = FrictionContactProblem(W9, q, MU3)
    summary = p.summary(tol=tol)
    assert summary["error(r=0)"] == pytest.approx(error(p, np.zeros(9)))
    assert summary[f"trivial@{tol:g}"] is trivial


def test_summary_default_tol_is_1e_8():
    p = FrictionContactProblem(W9, -1e-18 * np.ones(9), MU3)
    assert p.summary()["trivial@1e-08"] is True


# ------------------------------------------------------------------ algebra
def test_velocity_is_W_r_plus_q():
    p = FrictionContactProblem(W9, Q9, MU3)
    r = np.arange(9.0)
    np.testing.assert_allclose(p.velocity(r), W9 @ r + Q9, rtol=1e-14)


@pytest.mark.parametrize("chunk", [512, 2])
def test_to_local_equals_dense_condensation(chunk):
    M, H, f, w, mu = _global_data(n=11, nc=4)
    g = GlobalFrictionContactProblem(sp.csr_matrix(M), sp.csr_matrix(H), f, w, mu)
    loc = g.to_local(chunk=chunk)
    W_dense = H.T @ np.linalg.solve(M, H)
    q_dense = H.T @ np.linalg.solve(M, f) + w
    np.testing.assert_allclose(loc.W.toarray(), W_dense, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(loc.q, q_dense, rtol=1e-12, atol=1e-13)
    np.testing.assert_array_equal(loc.mu, mu)
    assert loc.dim == 3 and not loc.is_global and g.is_global
    # the global and condensed velocities agree, and v solves M v = H r + f
    r = np.linspace(-1.0, 1.0, g.m)
    np.testing.assert_allclose(g.velocity(r), loc.velocity(r), rtol=1e-11, atol=1e-12)
    v = g.global_velocity(r)
    np.testing.assert_allclose(M @ v, H @ r + f, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(g.q_local, q_dense, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("M", [
    np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),   # two equal rows
    np.diag([1.0, 0.0, 2.0]),                                        # zero pivot
])
def test_singular_M_raises(M):
    g = GlobalFrictionContactProblem(M, np.eye(3), np.ones(3), np.zeros(3), 0.5)
    with pytest.raises(InvalidProblemError) as info:
        g.to_local()
    assert info.value.field == "M"
    with pytest.raises(InvalidProblemError):
        g.velocity(np.zeros(3))


@pytest.mark.parametrize("dim", [2, 3])
def test_diagonal_blocks(dim):
    nc = 4
    rng = np.random.default_rng(dim)
    W = rng.standard_normal((dim * nc, dim * nc))
    W[np.abs(W) < 0.5] = 0.0      # sparse, with some zero entries inside blocks
    p = FrictionContactProblem(sp.csr_matrix(W), np.zeros(dim * nc), 0.3, dim)
    B = p.diagonal_blocks()
    assert B.shape == (nc, dim, dim)
    for i in range(nc):
        np.testing.assert_array_equal(B[i], W[dim * i:dim * (i + 1), dim * i:dim * (i + 1)])


def test_with_revalidates():
    p = FrictionContactProblem(W9, Q9, MU3, name="p")
    p2 = p.with_(mu=0.9)
    np.testing.assert_array_equal(p2.mu, [0.9] * 3)
    np.testing.assert_array_equal(p2.q, p.q)
    with pytest.raises(InvalidProblemError) as info:
        p.with_(q=np.ones(4))
    assert info.value.field == "q"


def test_check_reaction():
    p = FrictionContactProblem(W9, Q9, MU3)
    with pytest.raises(InvalidProblemError) as info:
        p.check_reaction(np.ones(8))
    assert info.value.field == "r"
    with pytest.raises(InvalidProblemError):
        p.check_reaction(_nan_at(np.ones(9), 3))


def test_error_message_does_not_echo_megabytes():
    """NumPy's conversion error quotes the whole string; the message keeps 500 characters."""
    with pytest.raises(InvalidProblemError) as info:
        FrictionContactProblem(W9, ["7" * 2_000_000 + "x"] * 9, MU3)
    assert info.value.field == "q"
    assert len(str(info.value)) < 700 and "characters)" in str(info.value)


def test_arrays_held_in_the_kernels_form_whatever_the_caller_gave():
    # int64 CSR indices and read-only buffers (np.frombuffer, a memory map) are held as int32
    # and writable copies, so each compiled kernel has one version (numba compiles one per
    # argument type: the other forms doubled a fresh install's compile time); the caller's
    # arrays are left as they were, and shared when already in that form
    rng = np.random.default_rng(3)
    A = rng.standard_normal((6, 6))
    W = sp.csr_matrix(A @ A.T + 6 * np.eye(6))
    W.indices, W.indptr = W.indices.astype(np.int64), W.indptr.astype(np.int64)
    W.data.flags.writeable = False
    q, mu = rng.standard_normal(6), np.array([0.3, 0.5])
    for a in (q, mu):
        a.flags.writeable = False
    p = FrictionContactProblem(W, q, mu, 3)
    indptr, indices, data = p.csr_parts
    assert indptr.dtype == indices.dtype == np.int32
    for a in (data, p.q, p.mu):
        assert a.flags.writeable and a.flags.c_contiguous and a.dtype == np.float64
    assert np.array_equal(p.q, q) and np.array_equal(p.mu, mu)
    assert np.array_equal(p.W.toarray(), W.toarray())
    assert W.indices.dtype == np.int64 and not W.data.flags.writeable and not q.flags.writeable
    q2 = rng.standard_normal(6)                      # already in form: shared, not copied
    assert FrictionContactProblem(p.W, q2, 0.3, 3).q is q2
    r = rng.standard_normal(6)
    assert np.array_equal(p.velocity(r), W @ r + q)


def test_unsorted_duplicates_read_only_csr_leaves_the_callers_matrix_alone():
    # W given with unsorted columns and a duplicate entry, its arrays read-only: the problem
    # sums and sorts a copy (scipy's sum_duplicates works in place, on arrays the matrix
    # object shares with the caller's)
    data = np.array([1.0, 4.0, 2.0, 0.5, 3.0, 1.0, 2.0])
    indices = np.array([2, 0, 1, 0, 1, 1, 2], dtype=np.int64)   # row 0 unsorted; row 1: 0, 1, 1
    indptr = np.array([0, 3, 6, 7], dtype=np.int64)
    for a in (data, indices, indptr):
        a.flags.writeable = False
    W = sp.csr_matrix((data, indices, indptr), shape=(3, 3))
    before = [a.copy() for a in (W.data, W.indices, W.indptr)]
    p = FrictionContactProblem(W, [-1.0, 0.0, 0.0], 0.5, 3)
    assert all(np.array_equal(x, y) for x, y in zip(before, (W.data, W.indices, W.indptr)))
    assert np.array_equal(p.W.toarray(), W.toarray())
    indptr_p, indices_p, data_p = p.csr_parts
    assert indices_p.dtype == np.int32 and p.W.has_canonical_format and data_p.flags.writeable
    assert np.array_equal(indptr_p, [0, 3, 5, 6])
