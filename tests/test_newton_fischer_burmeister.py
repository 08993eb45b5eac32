"""Newton's third equation of the law: Fischer–Burmeister's (``equation="fischer_burmeister"``).

The Lorentz-cone function against finite differences, its closed-form limit element on the
degenerate set against the limit of derivatives, the determinant identity that keeps the map
exact there; the Coulomb blocks (kernel = NumPy reference, finite differences in every
state, zero exactly at the law, mu = 0); and the Newton runs on it.
"""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.cones import FB_DEGENERATE, fb_determinant, fischer_burmeister_jacobian, lorentz_fb
from socp_cd.errors import InvalidProblemError
from socp_cd.solvers import newton
from socp_cd.solvers.kernels import newton_fb
from socp_cd.solvers.kernels.newton_fb import fb_blocks

from _law_kernels import assert_blocks_are_central_differences, run_blocks


def _kernel_lorentz(x, y):
    d = x.shape[0]
    phi, Mx, My = np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3))
    xx, yy = np.zeros(3), np.zeros(3)
    xx[:d], yy[:d] = x, y
    deg = newton_fb.lorentz_fb(xx, yy, d, phi, Mx, My)
    return phi[:d], Mx[:d, :d], My[:d, :d], deg


def _blocks(r, u, mu, rho, dim, jac=True):
    return run_blocks(fb_blocks, r, u, mu, rho, dim, jac)


def test_the_two_thresholds_agree():
    assert FB_DEGENERATE == newton_fb.FB_DEGENERATE


@pytest.mark.parametrize("dim", [2, 3])
def test_determinant_identity(dim):
    """det(x² + y²) as a sum of squares equals z₀² − ||z̄||², and is exactly 0 on the
    degenerate set, where the difference form leaves ~eps z₀² of noise."""
    rng = np.random.default_rng(0)
    for _ in range(500):
        x, y = rng.normal(size=dim), rng.normal(size=dim)
        z = np.r_[x @ x + y @ y, 2 * (x[0] * x[1:] + y[0] * y[1:])]
        assert fb_determinant(x, y) == pytest.approx(z[0] ** 2 - z[1:] @ z[1:], abs=1e-12 * z[0] ** 2)
    w = rng.normal(size=dim - 1)
    w /= np.linalg.norm(w)
    c = np.r_[1.0, w]
    for a, b in [(2.0, 0.0), (0.0, 1.5), (1.0, -0.5), (-1.0, 2.0)]:
        assert abs(fb_determinant(a * c, b * c)) <= 1e-28 * (a * a + b * b) ** 2


def test_determinant_is_exact_at_3d_grazing_pairs():
    """x = (mu r_N, r_T) with r on the cone's surface, y = 0: z is on the boundary; the sum
    of squares is ~eps² z₀², the difference form ~eps z₀² (whose root is ~1e-8 |x|)."""
    rng = np.random.default_rng(7)
    worst_sum = worst_diff = 0.0
    for _ in range(2000):
        mu = rng.uniform(0.05, 3.0)
        t = rng.normal(size=2)
        t /= np.linalg.norm(t)
        x = np.r_[mu * 1.3, mu * 1.3 * t]          # mu r_N with r = (1.3, 1.3 mu t)
        y = np.zeros(3)
        z = np.r_[x @ x, 2 * x[0] * x[1:]]
        worst_sum = max(worst_sum, abs(fb_determinant(x, y)) / z[0] ** 2)
        worst_diff = max(worst_diff, abs(z[0] ** 2 - z[1:] @ z[1:]) / z[0] ** 2)
    assert worst_sum <= 1e-28 and worst_diff > 1e-20


def test_the_option_runs_this_kernel():
    assert newton._LAW_BLOCKS["fischer_burmeister"] is fb_blocks
    assert "fischer_burmeister" in newton.EQUATIONS


@pytest.mark.parametrize("grazing", ["r on the surface, u = 0", "r = 0, û on the dual surface",
                                     "r = u = 0"])
def test_newton_is_superlinear_near_grazing_solutions(grazing):
    """Plain Newton steps on one contact from 1e-2 off a grazing solution reach 1e-12 within
    seven steps: the limit element is taken only this close to the degenerate set
    (FB_DEGENERATE; with 1e-10 the steps went linear, rate ~0.7, stalling near 1e-10)."""
    rng = np.random.default_rng(3)
    dim, mu = 3, np.array([0.5])
    A = rng.normal(size=(3, 3))
    W = A @ A.T + np.eye(3)
    t = rng.normal(size=2)
    t /= np.linalg.norm(t)
    r_star, u_star = {"r on the surface, u = 0": (np.r_[1.0, 0.5 * t], np.zeros(3)),
                      "r = 0, û on the dual surface": (np.zeros(3), np.r_[0.0, 0.7 * t]),
                      "r = u = 0": (np.zeros(3), np.zeros(3))}[grazing]
    q = u_star - W @ r_star
    rho = np.array([1.0 / W[0, 0]])
    for seed in range(3):
        r = r_star + 1e-2 * np.random.default_rng(seed).normal(size=3)
        errors = []
        for _ in range(7):
            _, F, Dr, Du, _ = _blocks(r, W @ r + q, mu, rho, dim)
            if not np.any(F):
                errors.append(np.linalg.norm(r - r_star))
                break
            r = r - np.linalg.solve(Dr[0] + Du[0] @ W, F)
            errors.append(np.linalg.norm(r - r_star))
        assert min(errors) <= 1e-12, (seed, errors)


@pytest.mark.parametrize("dim", [2, 3])
def test_lorentz_fb_derivative_and_kernel(dim):
    rng = np.random.default_rng(1)
    h = 1e-7
    for _ in range(100):
        x, y = rng.normal(size=dim), rng.normal(size=dim)
        phi, Mx, My, deg = lorentz_fb(x, y)
        assert not deg
        fx = np.array([(lorentz_fb(x + h * e, y)[0] - lorentz_fb(x - h * e, y)[0]) / (2 * h)
                       for e in np.eye(dim)]).T
        fy = np.array([(lorentz_fb(x, y + h * e)[0] - lorentz_fb(x, y - h * e)[0]) / (2 * h)
                       for e in np.eye(dim)]).T
        np.testing.assert_allclose(np.eye(dim) - Mx, fx, atol=1e-6)
        np.testing.assert_allclose(np.eye(dim) - My, fy, atol=1e-6)
        k = _kernel_lorentz(x, y)
        np.testing.assert_allclose(k[0], phi, atol=1e-14)
        np.testing.assert_allclose(k[1], Mx, atol=1e-13)
        np.testing.assert_allclose(k[2], My, atol=1e-13)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("a,b", [(2.0, 0.0), (0.0, 1.5), (1.0, -0.5), (-1.0, 2.0), (0.0, 0.0)])
def test_degenerate_element_is_the_limit_of_derivatives(dim, a, b):
    """On ``x = a c``, ``y = b c`` (``c`` on the cone's boundary; ``x² + y²`` on it too) the
    closed form is the limit of the derivative along ``(x + τe, y + τe)``: the distance
    falls linearly with ``τ`` (×10 per decade) to below 1e-3 at ``τ = 1e-4``; kernel and
    reference agree."""
    rng = np.random.default_rng(2)
    w = rng.normal(size=dim - 1)
    w /= np.linalg.norm(w)
    x, y = a * np.r_[1.0, w], b * np.r_[1.0, w]
    phi, Mx, My, deg = lorentz_fb(x, y)
    assert deg
    e = np.r_[1.0, np.zeros(dim - 1)]
    gaps = []
    for tau in (1e-2, 1e-3, 1e-4):
        _, Mx2, My2, deg2 = lorentz_fb(x + tau * e, y + tau * e)
        assert not deg2
        gaps.append(max(np.abs(Mx - Mx2).max(), np.abs(My - My2).max()))
    if a == b == 0.0:
        assert max(gaps) < 1e-12
    else:
        assert gaps[0] > 5 * gaps[1] > 25 * gaps[2] and gaps[2] < 1e-3
    k = _kernel_lorentz(x, y)
    assert k[3]
    np.testing.assert_allclose(k[0], phi, atol=1e-15)
    np.testing.assert_allclose(k[1], Mx, atol=1e-15)
    np.testing.assert_allclose(k[2], My, atol=1e-15)
    # φ is the scalar FB of (a, b) along c: zero exactly when a, b >= 0 and ab = 0
    expect = (a + b - np.hypot(a, b)) * np.r_[1.0, w]
    np.testing.assert_allclose(phi, expect, atol=1e-15)


def _state(state, dim, rng, mu, rho):
    """``(r, u)`` of one contact strictly inside a smooth region of the map, ``u_T != 0``."""
    t = rng.normal(size=dim - 1)
    t /= np.linalg.norm(t)
    if state == "separated":
        return np.r_[0.1, 0.02 * t], np.r_[3.0, 0.4 * t] / rho
    if state == "stick":
        return np.r_[2.0, 0.2 * mu * t], np.r_[0.01, 0.02 * rng.normal(size=dim - 1)] / rho
    return np.r_[1.0, 1.3 * mu * t], np.r_[0.05, -2.0 * t] / rho            # "slide"


@pytest.mark.parametrize("rho", [0.05, 0.7, 20.0])
@pytest.mark.parametrize("mu", [0.0, 0.3, 2.0])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("state", ["separated", "stick", "slide"])
def test_jacobian_matches_finite_differences(dim, state, mu, rho):
    rng = np.random.default_rng(11)
    r, u = _state(state, dim, rng, max(mu, 0.3), rho)
    m, p = np.array([mu]), np.array([rho])
    _, F, Dr, Du, br = _blocks(r, u, m, p, dim)
    assert br[0] == 0
    assert_blocks_are_central_differences(fb_blocks, r, u, m, p, dim, Dr, Du)


@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_equals_reference_with_degenerate_blocks(dim):
    rng = np.random.default_rng(5)
    nc = 300
    r, u = rng.normal(size=nc * dim), rng.normal(size=nc * dim)
    mu, rho = rng.uniform(0, 2, nc), rng.uniform(0.1, 3, nc)
    mu[:10] = 0.0
    R, U = r.reshape(nc, dim), u.reshape(nc, dim)
    U[10:20, 1:] = 0.0                         # u_T = 0 (w = 0)
    for i in range(20, 30):                    # grazing: r on the cone's surface, u = 0
        t = rng.normal(size=dim - 1)
        R[i] = np.r_[1.0, mu[i] * t / np.linalg.norm(t)]
        U[i] = 0.0
    R[30] = U[30] = R[5] = U[5] = 0.0          # r = u = 0, with and without friction
    nF, F, Dr, Du, br = _blocks(r, u, mu, rho, dim)
    F0, Dr0, Du0, br0 = fischer_burmeister_jacobian(r, u, mu, dim, rho)
    assert br0[20:31].all() and br0[5] == 1 and br0[31:].sum() == 0
    np.testing.assert_array_equal(br, br0)
    np.testing.assert_allclose(F, F0, atol=1e-13)
    np.testing.assert_allclose(Dr, Dr0, atol=1e-13)
    np.testing.assert_allclose(Du, Du0, atol=1e-13)
    assert nF == pytest.approx(np.linalg.norm(F0), rel=1e-13)
    # the grazing solutions are solutions: F exactly 0 there (the determinant identity)
    assert np.abs(F.reshape(nc, dim)[20:31]).max() <= 1e-15


@pytest.mark.parametrize("dim", [2, 3])
def test_zero_exactly_at_the_law(dim):
    for mu in (0.0, 0.8):
        p = manufactured(25, dim, mu, seed=3)
        r, u = p.solution.r, p.solution.u
        rho = np.random.default_rng(0).uniform(0.1, 10, p.n_contacts)
        assert _blocks(r, u, p.mu, rho, dim, False)[0] <= 1e-12 * max(1.0, np.linalg.norm(r))
        assert _blocks(r + 0.01, u, p.mu, rho, dim, False)[0] > 1e-4


def _refuse(*args):
    raise AssertionError("another equation's kernel ran in a Fischer–Burmeister solve")


@pytest.mark.parametrize("policy", ["prox", "plain", "hybrid", "prox_error"])
def test_no_path_runs_another_kernel(monkeypatch, policy):
    """Only this kernel runs in such a solve, and it does run (counted)."""
    calls = []

    def counted(*args):
        calls.append(1)
        return fb_blocks(*args)
    monkeypatch.setattr(newton, "_LAW_BLOCKS", dict(alart_curnier=_refuse, natural_map=_refuse,
                                                    fischer_burmeister=counted))
    monkeypatch.setattr(newton, "ac_blocks", _refuse)
    p = manufactured(12, 3, 0.8, seed=2)
    res = socp_cd.solve(p, "newton", tol=1e-10, equation="fischer_burmeister", policy=policy,
                        history=True)
    assert res.converged and calls


def test_split_parameters_refused():
    p = manufactured(3, 3, 0.5, seed=1)
    with pytest.raises(InvalidProblemError) as exc:
        socp_cd.solve(p, "newton", equation="fischer_burmeister", rho="split")
    assert exc.value.field == "rho"
