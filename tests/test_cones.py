"""Coulomb cones, projections and convex-analysis certificates (socp_cd.cones).

Expected values are derived by hand (see formulations/coulomb.md); the random
tests check identities that do not reuse the code's formulas (Moreau's
decomposition, the variational inequality of a projection, the Fenchel–Young
inequality, the dual cone's definition).
"""
from __future__ import annotations

import numpy as np
import pytest

from socp_cd.cones import (ContactStatus, bipotential, classify_contacts, desaxce_velocity,
                           fenchel_young_gap, in_cone_violation, natural_map,
                           normal_velocity_violation, project_cone, project_dual_cone,
                           tangential_norm)

MU = 0.5
RNG_SEED = 12345


def P(x, mu=MU, dim=3):
    return project_cone(np.asarray(x, dtype=float), mu, dim)


# ------------------------------------------------------------------ projection
@pytest.mark.parametrize("x, mu, expected", [
    # inside: ||x_T|| = 0.5 <= mu x_N = 1
    ((2.0, 0.3, 0.4), 0.5, (2.0, 0.3, 0.4)),
    # polar cone: mu ||x_T|| = 0.25 <= -x_N = 2
    ((-2.0, 0.3, 0.4), 0.5, (0.0, 0.0, 0.0)),
    # boundary ray: t = 5, p_N = (1 + 0.5*5)/(1 + 0.25) = 2.8, p_T = 0.5*2.8/5*(3, 4)
    ((1.0, 3.0, 4.0), 0.5, (2.8, 0.84, 1.12)),
    # negative normal but outside the polar cone: p_N = (-1 + 2.5)/1.25 = 1.2
    ((-1.0, 3.0, 4.0), 0.5, (1.2, 0.36, 0.48)),
    # exactly on the boundary: ||x_T|| = 1 = mu x_N
    ((2.0, 0.6, 0.8), 0.5, (2.0, 0.6, 0.8)),
    # apex and the normal axis
    ((0.0, 0.0, 0.0), 0.5, (0.0, 0.0, 0.0)),
    ((3.0, 0.0, 0.0), 0.5, (3.0, 0.0, 0.0)),
    ((-3.0, 0.0, 0.0), 0.5, (0.0, 0.0, 0.0)),
    # tangential only: p_N = mu t/(1+mu^2) = 2.5/1.25 = 2, p_T = 0.5*2/5*(3,4)
    ((0.0, 3.0, 4.0), 0.5, (2.0, 0.6, 0.8)),
    # mu = 0: the half-line x_T = 0, x_N >= 0
    ((2.0, 3.0, 4.0), 0.0, (2.0, 0.0, 0.0)),
    ((-2.0, 3.0, 4.0), 0.0, (0.0, 0.0, 0.0)),
    # mu = 1 (45 degrees): p_N = (1 + 5)/2 = 3, p_T = 3/5*(3, 4)
    ((1.0, 3.0, 4.0), 1.0, (3.0, 1.8, 2.4)),
])
def test_projection_3d_branches(x, mu, expected):
    np.testing.assert_allclose(P(x, mu), expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("x, expected", [
    ((1.0, 0.2), (1.0, 0.2)),      # inside the wedge |x_T| <= mu x_N
    ((-1.0, 0.2), (0.0, 0.0)),     # polar: mu |x_T| = 0.1 <= 1
    ((1.0, -3.0), (2.0, -1.0)),    # p_N = (1 + 1.5)/1.25 = 2, p_T = -mu p_N
    ((1.0, 3.0), (2.0, 1.0)),      # the other edge of the wedge
    ((2.0, -1.0), (2.0, -1.0)),    # on the edge
    ((0.0, 0.0), (0.0, 0.0)),
])
def test_projection_2d_wedge(x, expected):
    np.testing.assert_allclose(P(x, MU, 2), expected, rtol=0, atol=1e-15)


def test_projection_huge_mu_tends_to_half_space():
    mu = 1e8
    # inside (||x_T|| = 5 <= 1e8 * 1)
    np.testing.assert_array_equal(P((1.0, 3.0, 4.0), mu), (1.0, 3.0, 4.0))
    # x_N < 0: the cone is nearly the half-space x_N >= 0, projection nearly (0, x_T)
    p = P((-1.0, 3.0, 4.0), mu)
    pn = (-1.0 + mu * 5.0) / (1.0 + mu * mu)
    np.testing.assert_allclose(p, (pn, mu * pn * 0.6, mu * pn * 0.8), rtol=1e-14)
    np.testing.assert_allclose(p, (0.0, 3.0, 4.0), atol=1e-7)


def test_projection_vectorized_layouts_and_per_contact_mu():
    X = np.array([[2.0, 0.3, 0.4], [1.0, 3.0, 4.0], [2.0, 3.0, 4.0]])
    mu = np.array([0.5, 0.5, 0.0])
    expected = np.array([[2.0, 0.3, 0.4], [2.8, 0.84, 1.12], [2.0, 0.0, 0.0]])
    np.testing.assert_allclose(project_cone(X, mu, 3), expected, atol=1e-15)
    stacked = project_cone(X.ravel(), mu, 3)
    assert stacked.shape == (9,)
    np.testing.assert_allclose(stacked, expected.ravel(), atol=1e-15)


def test_distance_to_cone_closed_form():
    # outside the cone and the polar cone: dist = (t - mu x_N) / sqrt(1 + mu^2)
    x = np.array([1.0, 3.0, 4.0, 2.0, 0.3, 0.4, -2.0, 0.3, 0.4])
    d = in_cone_violation(x, MU, 3)
    np.testing.assert_allclose(d, [4.5 / np.sqrt(1.25), 0.0, np.linalg.norm([2.0, 0.3, 0.4])],
                               rtol=1e-14)


def test_tangential_norm_and_normal_velocity_violation():
    np.testing.assert_allclose(tangential_norm([1.0, 3.0, 4.0, 0.0, -6.0, 8.0]), [5.0, 10.0])
    np.testing.assert_allclose(tangential_norm([1.0, -3.0], dim=2), [3.0])
    np.testing.assert_array_equal(normal_velocity_violation([-2.0, 1.0, 1.0, 3.0, 0.0, 0.0]),
                                  [2.0, 0.0])


# ------------------------------------------------------------------ dual cone
def test_dual_cone_is_coulomb_cone_of_inverse_mu():
    # K*_2 = K_{1/2}: same numbers as the boundary-ray case above
    np.testing.assert_allclose(project_dual_cone([1.0, 3.0, 4.0], 2.0), (2.8, 0.84, 1.12),
                               atol=1e-15)
    np.testing.assert_allclose(project_dual_cone([1.0, 0.3, 0.4], 2.0), (1.0, 0.3, 0.4))


def test_dual_cone_mu_zero_is_half_space():
    np.testing.assert_array_equal(project_dual_cone([-1.0, 3.0, 4.0], 0.0), (0.0, 3.0, 4.0))
    np.testing.assert_array_equal(project_dual_cone([1.0, 3.0, 4.0], 0.0), (1.0, 3.0, 4.0))
    np.testing.assert_array_equal(project_dual_cone([-1.0, 3.0], 0.0, dim=2), (0.0, 3.0))


@pytest.mark.parametrize("dim", [2, 3])
def test_dual_cone_matches_its_definition(dim):
    """y ∈ K* iff y·x >= 0 on every ray x = (1, mu d), |d| = 1, i.e. y_N >= mu ||y_T||."""
    rng = np.random.default_rng(RNG_SEED)
    mu = 0.7
    Y = rng.standard_normal((2000, dim))
    if dim == 3:
        ang = np.linspace(0, 2 * np.pi, 721)
        D = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    else:
        D = np.array([[1.0], [-1.0]])
    rays = np.concatenate([np.ones((len(D), 1)), mu * D], axis=1)
    min_dot = (Y @ rays.T).min(axis=1)
    in_dual_by_definition = min_dot >= 0
    proj = project_dual_cone(Y, mu, dim)
    in_dual_by_projection = np.all(np.abs(proj - Y) <= 1e-12, axis=1)
    # points within the discretisation slack of the boundary are excluded
    clear = np.abs(Y[:, 0] - mu * np.linalg.norm(Y[:, 1:], axis=1)) > 1e-3
    np.testing.assert_array_equal(in_dual_by_definition[clear], in_dual_by_projection[clear])
    # projected points are in K*: nonnegative products with every ray of K
    assert (proj @ rays.T).min() >= -1e-12


# ------------------------------------------------------------------ Moreau & projection properties
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("mu", [0.0, 0.3, 1.0, 7.0])
def test_moreau_decomposition(dim, mu):
    """x = P_K(x) + P_K°(x), P_K(x)·P_K°(x) = 0, with K° = -K* projected separately."""
    rng = np.random.default_rng(RNG_SEED + dim)
    X = 3.0 * rng.standard_normal((500, dim))
    pk = project_cone(X, mu, dim)
    pkpolar = -project_dual_cone(-X, mu, dim)
    np.testing.assert_allclose(pk + pkpolar, X, atol=1e-12)
    np.testing.assert_allclose(np.einsum("ij,ij->i", pk, pkpolar), 0.0, atol=1e-11)
    assert np.all(in_cone_violation(pk, mu, dim) <= 1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_projection_properties(dim):
    rng = np.random.default_rng(RNG_SEED + 10 * dim)
    mu = rng.uniform(0.0, 2.0, 400)
    X = 2.0 * rng.standard_normal((400, dim))
    Y = 2.0 * rng.standard_normal((400, dim))
    px, py = project_cone(X, mu, dim), project_cone(Y, mu, dim)
    # idempotent
    np.testing.assert_allclose(project_cone(px, mu, dim), px, atol=1e-13)
    # nonexpansive
    assert np.all(np.linalg.norm(px - py, axis=1) <= np.linalg.norm(X - Y, axis=1) + 1e-13)
    # variational inequality: (x - P x)·(z - P x) <= 0 for z in K (z = P y)
    assert np.all(np.einsum("ij,ij->i", X - px, py - px) <= 1e-12)
    # positively homogeneous
    np.testing.assert_allclose(project_cone(3.5 * X, mu, dim), 3.5 * px, rtol=1e-13, atol=1e-13)


# ------------------------------------------------------------------ De Saxcé velocity
def test_desaxce_velocity():
    np.testing.assert_allclose(desaxce_velocity([1.0, 3.0, 4.0], MU), [3.5, 3.0, 4.0])
    np.testing.assert_allclose(desaxce_velocity([1.0, -3.0], MU, dim=2), [2.5, -3.0])
    U = np.array([[0.0, 3.0, 4.0], [-1.0, 0.0, 0.0]])
    np.testing.assert_allclose(desaxce_velocity(U, [0.5, 2.0]), [[2.5, 3.0, 4.0], [-1.0, 0, 0]])


# ------------------------------------------------------------------ solutions of the law
#: name -> (r, u, status), mu = 0.5; each satisfies K* ∋ û ⊥ r ∈ K.
SOLUTIONS_3D = {
    "separated": ((0.0, 0.0, 0.0), (2.0, 1.0, -1.0), ContactStatus.SEPARATED),
    "sticking": ((1.0, 0.3, 0.2), (0.0, 0.0, 0.0), ContactStatus.STICKING),
    "sticking_on_boundary": ((2.0, 0.6, 0.8), (0.0, 0.0, 0.0), ContactStatus.STICKING),
    # ||r_T|| = mu r_N = 1, r_T = -(0.6, 0.8) opposite to u_T = (3, 4)
    "sliding": ((2.0, -0.6, -0.8), (0.0, 3.0, 4.0), ContactStatus.SLIDING),
    "grazing": ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ContactStatus.GRAZING),
}
SOLUTIONS_2D = {
    "separated": ((0.0, 0.0), (1.0, -5.0), ContactStatus.SEPARATED),
    "sticking": ((1.0, 0.2), (0.0, 0.0), ContactStatus.STICKING),
    "sliding": ((2.0, -1.0), (0.0, 3.0), ContactStatus.SLIDING),
    "sliding_back": ((2.0, 1.0), (0.0, -0.5), ContactStatus.SLIDING),
    "grazing": ((0.0, 0.0), (0.0, 0.0), ContactStatus.GRAZING),
}
#: feasible pairs (r ∈ K, u_N >= 0) that violate the law: expected Fenchel–Young gap r·û
NON_SOLUTIONS_3D = {
    "slides_with_r_T": ((2.0, 0.6, 0.8), (0.0, 3.0, 4.0), 2 * 2.5 + 5.0),
    "slip_inside_cone": ((1.0, 0.3, 0.2), (0.0, 1.0, 0.0), 0.3 + 0.5 * 1.0 * 1.0),
    "push_and_separate": ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0), 1.0),
    "sliding_too_little_friction": ((2.0, -0.3, -0.4), (0.0, 3.0, 4.0), 2 * 2.5 - 2.5),
}


def _stack(cases):
    r = np.array([c[0] for c in cases.values()], dtype=float)
    u = np.array([c[1] for c in cases.values()], dtype=float)
    return r, u


@pytest.mark.parametrize("dim, cases", [(3, SOLUTIONS_3D), (2, SOLUTIONS_2D)])
@pytest.mark.parametrize("rho", [1.0, 0.1, 10.0])
def test_natural_map_vanishes_at_solutions(dim, cases, rho):
    r, u = _stack(cases)
    F = natural_map(r.ravel(), u.ravel(), MU, dim, rho=rho)
    np.testing.assert_allclose(F, 0.0, atol=1e-15)


@pytest.mark.parametrize("dim, cases", [(3, SOLUTIONS_3D), (2, SOLUTIONS_2D)])
def test_fenchel_young_gap_zero_and_bipotential_equality_at_solutions(dim, cases):
    r, u = _stack(cases)
    np.testing.assert_allclose(fenchel_young_gap(r, u, MU, dim), 0.0, atol=1e-15)
    # b(-u, r) = -u·r exactly at the law (the conjugate-pair statement)
    b = bipotential(u, r, MU, dim)
    np.testing.assert_allclose(b, -np.einsum("ij,ij->i", u, r), atol=1e-15)


def test_sliding_bipotential_value():
    # b(-u, r) = mu r_N ||u_T|| = 0.5 * 2 * 5
    assert bipotential([0.0, 3.0, 4.0], [2.0, -0.6, -0.8], MU)[0] == pytest.approx(5.0)


def test_natural_map_and_gap_nonzero_off_solutions():
    r, u = _stack({k: v[:2] + (None,) for k, v in NON_SOLUTIONS_3D.items()})
    F = natural_map(r.ravel(), u.ravel(), MU).reshape(-1, 3)
    assert np.all(np.linalg.norm(F, axis=1) > 1e-3)
    gaps = fenchel_young_gap(r, u, MU)
    np.testing.assert_allclose(gaps, [v[2] for v in NON_SOLUTIONS_3D.values()], rtol=1e-14)
    assert np.all(gaps > 0)


def test_natural_map_detects_penetration_and_outside_cone():
    # r = 0 with u_N < 0: F = -P_K(-û) = -(1, 0, 0)
    np.testing.assert_allclose(natural_map([0.0, 0.0, 0.0], [-1.0, 0.0, 0.0], MU), [-1, 0, 0])
    # r outside the cone with u = 0: F = r - P_K(r)
    r = np.array([1.0, 3.0, 4.0])
    np.testing.assert_allclose(natural_map(r, np.zeros(3), MU), r - (2.8, 0.84, 1.12), atol=1e-15)


def test_bipotential_domain():
    # r outside K, or u_N < 0: +inf
    assert np.isinf(bipotential([0.0, 1.0, 0.0], [1.0, 3.0, 4.0], MU)[0])
    assert np.isinf(bipotential([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], MU)[0])
    assert bipotential([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], MU)[0] == 0.0


@pytest.mark.parametrize("dim", [2, 3])
def test_fenchel_young_inequality_on_random_feasible_pairs(dim):
    """b(-u, r) >= -u·r for r ∈ K, u_N >= 0 (gap >= 0), and gap = 0 ⇔ natural map = 0."""
    rng = np.random.default_rng(RNG_SEED + 100 * dim)
    n = 1000
    mu = rng.uniform(0.0, 1.5, n)
    r = project_cone(rng.standard_normal((n, dim)), mu, dim)
    u = rng.standard_normal((n, dim))
    u[:, 0] = np.abs(u[:, 0])
    # projected r lie on the boundary up to round-off: allow it in the domain test
    assert np.max(in_cone_violation(r, mu, dim)) <= 1e-15
    b = bipotential(u, r, mu, dim, feas_tol=1e-15)
    assert np.all(np.isfinite(b))
    assert np.all(b + np.einsum("ij,ij->i", u, r) >= -1e-12)
    gap = fenchel_young_gap(r, u, mu, dim)
    np.testing.assert_allclose(gap, b + np.einsum("ij,ij->i", u, r), atol=1e-12)
    F = np.linalg.norm(natural_map(r, u, mu, dim), axis=1)
    assert np.all((gap > 1e-9) <= (F > 0))  # a positive gap means not a solution


# ------------------------------------------------------------------ classification
@pytest.mark.parametrize("dim, cases", [(3, SOLUTIONS_3D), (2, SOLUTIONS_2D)])
def test_classify_contacts(dim, cases):
    r, u = _stack(cases)
    got = classify_contacts(r.ravel(), u.ravel(), MU, dim)
    assert list(got) == [int(c[2]) for c in cases.values()]


def test_classify_contacts_tolerance_is_relative():
    # a 1e-12 impulse on a contact next to a 1e3 one counts as zero
    r = np.array([1e3, 0.0, 0.0, 1e-12, 0.0, 0.0])
    u = np.array([0.0, 0.0, 0.0, 5.0, 0.0, 0.0])
    assert list(classify_contacts(r, u, MU)) == [ContactStatus.STICKING, ContactStatus.SEPARATED]


@pytest.mark.parametrize("dim", [2, 3])
def test_desaxce_velocity_jacobian_matches_finite_differences(dim):
    """D = I + mu e_N wᵀ against central differences of desaxce_velocity (u_T != 0), and
    w = 0 where u_T = 0."""
    from socp_cd.cones import desaxce_velocity_jacobian
    rng = np.random.default_rng(4)
    nc = 20
    u, mu = rng.normal(size=nc * dim), rng.uniform(0, 2, nc)
    D = desaxce_velocity_jacobian(u, mu, dim)
    h = 1e-7
    for j in range(nc * dim):
        e = np.zeros(nc * dim)
        e[j] = h
        fd = (desaxce_velocity(u + e, mu, dim) - desaxce_velocity(u - e, mu, dim)) / (2 * h)
        i, c = divmod(j, dim)
        np.testing.assert_allclose(D[i, :, c], fd[i * dim:(i + 1) * dim], atol=1e-7)
    u.reshape(nc, dim)[:, 1:] = 0.0
    np.testing.assert_array_equal(desaxce_velocity_jacobian(u, mu, dim),
                                  np.repeat(np.eye(dim)[None], nc, axis=0))
