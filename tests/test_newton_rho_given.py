"""``solver="newton"`` with the equation's parameter given as numbers (``rho=1.0`` or one per
contact, in the units of the problem as written: Siconos' NSN convention)."""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.errors import InvalidProblemError
from socp_cd.problem import FrictionContactProblem

EQUATIONS = ["alart_curnier", "natural_map", "fischer_burmeister"]


@pytest.mark.parametrize("equation", EQUATIONS)
@pytest.mark.parametrize("policy", ["prox", "plain"])
@pytest.mark.parametrize("per_contact", [False, True])
def test_given_values_solve_manufactured_problems(per_contact, policy, equation):
    p = manufactured(20, 3, 0.5, seed=3)
    rho = np.linspace(0.5, 2.0, p.n_contacts) if per_contact else 1.0
    res = socp_cd.solve(p, "newton", tol=1e-10, rho=rho, equation=equation, policy=policy)
    assert res.converged and socp_cd.error(p, res.r) <= 1e-10
    assert res.info["rho"] == "given"
    assert socp_cd.solve(p, "newton", equation=equation).info["rho"] == "block"


@pytest.mark.parametrize("equation", EQUATIONS)
def test_given_values_are_in_the_units_as_written(equation):
    # impulses in a unit k times larger: W2 = k W, the same q, r2 = r / k.  The parameter
    # rho / k on the second problem is the same equation (F2 = F / k), so the two runs take
    # the same steps.  W is rank deficient: r is not unique and the answer records the
    # path.  Read in the solver's working units instead, rho would differ between the runs
    p = manufactured(15, 3, 0.8, structure="redundant", seed=5)
    k = 100.0
    p2 = FrictionContactProblem(k * p.W, p.q, p.mu, p.dim)
    a = socp_cd.solve(p, "newton", rho=0.3, equation=equation, tol=1e-10)
    b = socp_cd.solve(p2, "newton", rho=0.3 / k, equation=equation, tol=1e-10)
    assert a.converged and b.converged
    assert (a.iterations, a.info["newton_steps"]) == (b.iterations, b.info["newton_steps"])
    np.testing.assert_allclose(k * b.r, a.r, rtol=0, atol=1e-8 * np.linalg.norm(a.r))
    # (the same value on both problems is another equation: another path)
    c = socp_cd.solve(p2, "newton", rho=0.3, equation=equation, tol=1e-10)
    assert np.linalg.norm(k * c.r - a.r) > 1e-6 * np.linalg.norm(a.r)


@pytest.mark.parametrize("equation", EQUATIONS)
def test_given_values_follow_a_change_of_units_per_contact(equation):
    # contact i in its own unit: r = d_i r3, u3 = d_i u (W3 = D W D, q3 = D q); the
    # equation at contact i is the same with rho3_i = rho_i / d_i²
    p = manufactured(12, 3, 0.8, structure="redundant", seed=8)
    d = np.repeat(np.geomspace(0.1, 10.0, p.n_contacts), 3)
    p3 = FrictionContactProblem(d[:, None] * p.W.toarray() * d[None, :], d * p.q, p.mu, p.dim)
    rho = np.linspace(0.5, 2.0, p.n_contacts)
    a = socp_cd.solve(p, "newton", rho=rho, equation=equation, tol=1e-10)
    b = socp_cd.solve(p3, "newton", rho=rho / d[::3] ** 2, equation=equation, tol=1e-10)
    assert a.converged and b.converged
    assert (a.iterations, a.info["newton_steps"]) == (b.iterations, b.info["newton_steps"])
    np.testing.assert_allclose(d * b.r, a.r, rtol=0, atol=1e-7 * np.linalg.norm(a.r))


@pytest.mark.parametrize("bad", [True, 0.0, -1.0, np.nan, np.inf, 1j, "nope", [1.0, 2.0],
                                 np.ones((2, 2)), object(), [True] * 4, ["1"] * 4])
def test_bad_given_values_name_the_field(bad):
    p = manufactured(4, 3, 0.5, seed=1)
    with pytest.raises(InvalidProblemError) as exc:
        socp_cd.solve(p, "newton", rho=bad)
    assert exc.value.field == "rho"


def test_given_values_with_the_split_strategy_rules():
    # a number is one parameter per contact: allowed with every equation ("split" is not)
    p = manufactured(6, 2, 0.5, seed=2)
    res = socp_cd.solve(p, "newton", rho=np.full(p.n_contacts, 2.0), equation="natural_map")
    assert res.converged
    with pytest.raises(InvalidProblemError) as exc:
        socp_cd.solve(p, "newton", rho="split", equation="natural_map")
    assert exc.value.field == "rho"
