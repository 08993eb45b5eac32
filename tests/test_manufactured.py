"""Manufactured problems: exact solutions by construction, recovered by every solver."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.bench.generators import STATES, coulomb_pairs, generate, manufactured
from socp_cd.errors import UnsupportedError

TOL = 1e-6
#: Safety factor on the monotone error bound (the Coulomb law is not monotone).
SAFETY = 10.0


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("mu", [0.0, 0.3, 2.0])
def test_pairs_obey_the_coulomb_law_state_by_state(dim, mu):
    nc = 400
    r, u, states = coulomb_pairs(nc, dim, mu, rng=1)
    R, U = r.reshape(nc, dim), u.reshape(nc, dim)
    rt = np.linalg.norm(R[:, 1:], axis=1)
    ut = np.linalg.norm(U[:, 1:], axis=1)
    sep, stick, slide, graze = (states == i for i in range(4))
    assert set(np.unique(states)) == set(range(len(STATES)))       # every state present
    assert np.all(R[sep] == 0) and np.all(U[sep, 0] > 0)
    assert np.all(U[stick] == 0) and np.all(R[stick, 0] > 0) and np.all(rt[stick] <= mu * R[stick, 0])
    assert np.all(U[slide, 0] == 0) and np.all(ut[slide] > 0)
    np.testing.assert_allclose(rt[slide], mu * R[slide, 0], rtol=1e-14)   # on the cone boundary
    # r_T opposite to u_T: r_T . u_T = -||r_T|| ||u_T||
    np.testing.assert_allclose(np.einsum("ij,ij->i", R[slide, 1:], U[slide, 1:]),
                               -rt[slide] * ut[slide], rtol=1e-12, atol=1e-15)
    assert np.all(R[graze] == 0) and np.all(U[graze] == 0)
    # and the natural map (an independent characterization) vanishes
    assert np.max(np.abs(socp_cd.natural_map(r, u, mu, dim))) < 1e-14


@pytest.mark.parametrize("dim", [2, 3])
def test_manufactured_problem_structure(dim):
    p = manufactured(30, dim, 0.3, seed=4)
    s = p.solution
    np.testing.assert_allclose(p.velocity(s.r), s.u, atol=1e-13)
    assert socp_cd.error(p, s.r) < 1e-14
    assert p.is_symmetric and np.linalg.eigvalsh(p.W.toarray()).min() > 0   # SPD
    psd = generate("manufactured_psd", 30, dim, seed=4)
    assert psd.is_rank_deficient and psd.rank <= dim * 15
    assert socp_cd.error(psd, psd.solution.r) < 1e-14
    assert np.linalg.eigvalsh(psd.W.toarray()).min() > -1e-12                 # PSD


def test_badly_scaled_manufactured_problem_keeps_its_solution():
    p = manufactured(40, 3, 0.5, contact_scale=1e6, q_scale=1e4, seed=2)
    a = np.abs(p.W.data)
    assert a.max() / a.min() > 1e8
    assert socp_cd.error(p, p.solution.r) < 1e-13


def _coulomb_solvers():
    return [n for n, s in socp_cd.solvers().items() if "coulomb" in s["formulations"]]


CASES = [(1, 2), (1, 3), (10, 2), (10, 3), (1000, 3)]


@pytest.mark.parametrize("solver", _coulomb_solvers())
@pytest.mark.parametrize("nc,dim", CASES)
def test_solvers_recover_the_manufactured_solution(solver, nc, dim):
    p = manufactured(nc, dim, 0.3, seed=0)
    try:
        res = socp_cd.solve(p, solver=solver, tol=TOL)
    except UnsupportedError as exc:
        pytest.skip(str(exc))
    assert res.status == "converged", res
    assert socp_cd.error(p, res.r) <= TOL
    # Error bound of a strongly monotone affine problem (W SPD, eigenvalues in
    # [lmin, lmax]): ||r - r*|| <= (1 + lmax) / lmin * ||F(r)||, with the natural
    # map ||F(r)|| <= tol * max(||q||, ||r||, ||u||); u - u* = W (r - r*).
    if p.m > 3:
        lmax = spla.eigsh(p.W, k=1, which="LA", return_eigenvectors=False)[0]
        lmin = spla.eigsh(p.W.tocsc(), k=1, sigma=0, which="LM", return_eigenvectors=False)[0]
    else:
        lmin, lmax = np.linalg.eigvalsh(p.W.toarray())[[0, -1]]
    assert lmin > 0
    norm = max(np.linalg.norm(p.q), np.linalg.norm(res.r), np.linalg.norm(res.u))
    bound_r = SAFETY * (1 + lmax) / lmin * TOL * norm
    assert np.linalg.norm(res.r - p.solution.r) <= bound_r
    assert np.linalg.norm(res.u - p.solution.u) <= lmax * bound_r
