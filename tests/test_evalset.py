"""The evaluation set: exact solutions on real operators, scaled copies, a stable split."""
import numpy as np
import pytest

import socp_cd
from socp_cd.bench.evalset import (MIXES, REFRAMINGS, case_split, exact_error, manufacture,
                                   manufactured_cases, reframe, reframed_cases, reframing, rescaled,
                                   split_of)
from socp_cd.bench.transforms import contact_map, velocity_back
from socp_cd.errors import InvalidProblemError
from socp_cd.data import shared_problems_dir

DATA = shared_problems_dir()
pytestmark = pytest.mark.skipif(DATA is None, reason="shared problems not found")


@pytest.fixture(scope="module")
def cases():
    return manufactured_cases(DATA, max_contacts=100)


def test_every_small_real_file_is_covered(cases):
    sources = {c.source for c in cases}
    small = {p.name for p in DATA.iterdir()
             if p.name != "MANIFEST.tsv" and socp_cd.read_problem(p).n_contacts <= 100}
    assert sources == small
    assert {c.family for c in cases} == {"real-manufactured", "real-scaled"}


def test_split_is_deterministic_and_mixed(cases):
    assert all(c.split == split_of(c.case_id) for c in cases)
    frac = np.mean([c.split == "tune" for c in cases])
    assert 0.15 < frac < 0.45
    assert len({c.case_id for c in cases}) == len(cases)


@pytest.mark.parametrize("name", ["Capsules-i122-1617.dat", "GFC3D_TwoRods1.dat",
                                  "FrictionContactProblem00071.dat", "OneObject-i1028-138.hdf5.dat"])
@pytest.mark.parametrize("mix", list(MIXES))
def test_manufactured_solution_is_exact_on_real_operator(name, mix):
    base = socp_cd.read_problem(DATA / name)
    p = manufacture(base, 0.5, MIXES[mix], seed=3)
    assert p.is_global == base.is_global
    r = p.solution.r
    assert socp_cd.error(p, r) < 1e-12
    assert exact_error(p, r) < 1e-12
    # the operator is the real one, the data are new
    if not p.is_global:
        assert (p.W != base.W).nnz == 0
        assert not np.allclose(p.q, base.q)
    # r = 0 is not a solution: the problem is not trivial
    assert socp_cd.error(p, np.zeros(p.m)) > 1e-3


@pytest.mark.parametrize("what", ["q", "Wq"])
@pytest.mark.parametrize("lam", [1e-6, 1e6])
def test_rescaled_copies_keep_exact_solution(what, lam):
    base = socp_cd.read_problem(DATA / "Confeti-ex03-Fc3D-SBM.dat")
    p = rescaled(manufacture(base, 1.0, MIXES["mixed"], 0), lam, what)
    assert socp_cd.error(p, p.solution.r) < 1e-11
    assert np.allclose(p.velocity(p.solution.r), p.solution.u, rtol=1e-9,
                       atol=1e-12 * np.abs(p.solution.u).max())


def test_simulation_collections_join_the_evaluation_set(tmp_path):
    """Problems dumped by ``socp-cd simulate --fclib`` are read back as held-out cases."""
    from socp_cd.bench.evalset import collection_cases
    from socp_cd.scenes.simulate import simulate
    scene = tmp_path / "drop.toml"
    scene.write_text("""
[scene]
name = "Drop"
dim = 2
mu = 0.3
[simulation]
h = 2e-3
steps = 8
tol = 1e-10
[[obstacles]]
shape = "line"
[[generate]]
kind = "stack"
base = [0, 0]
count = 3
body = {shape = "disk", radius = 0.05}
""")
    s = simulate(scene, fclib=tmp_path / "drop", fclib_every=4, quiet=True)
    cases = collection_cases(tmp_path / "drop")
    assert [c.source for c in cases] == [f.name for f in s["fclib_files"]] and len(cases) == 2
    for c in cases:
        assert c.split == "holdout" and c.family == "drop" and not c.is_global
        p = c.problem()
        assert p.n_contacts == c.n_contacts == 3
        assert socp_cd.error(p, p.solution.r) <= 1e-10


@pytest.mark.parametrize("dim", [2, 3])
def test_contact_map_is_orthogonal_and_keeps_the_cone(dim):
    rng = np.random.default_rng(0)
    nc = 7
    perm, angles = rng.permutation(nc), rng.uniform(0.0, 2.0 * np.pi, nc)
    T = contact_map(perm, angles, dim).toarray()
    assert np.allclose(T.T @ T, np.eye(nc * dim), atol=1e-15)
    r = rng.standard_normal(nc * dim)
    Tr = T @ r
    for k in range(nc):           # new contact k is old contact perm[k], normal kept, |r_T| kept
        old, new = r[perm[k] * dim:(perm[k] + 1) * dim], Tr[k * dim:(k + 1) * dim]
        assert new[0] == old[0]
        assert np.isclose(np.linalg.norm(new[1:]), np.linalg.norm(old[1:]), rtol=1e-14)
    if dim == 3:                  # a turn, not a reflection: det +1 per block
        assert np.isclose(np.linalg.det(T[1:3, perm[0] * 3 + 1:perm[0] * 3 + 3]), 1.0)
    with pytest.raises(ValueError):
        contact_map([0, 0, 1], np.zeros(3), dim)


@pytest.mark.parametrize("name", ["Capsules-i122-1617.dat", "GFC3D_TwoRods1.dat",
                                  "fc2d_granularflowonwall_00667_00000.dat"])
@pytest.mark.parametrize("how", REFRAMINGS)
def test_reframed_copies_keep_the_exact_solution(name, how):
    base = manufacture(socp_cd.read_problem(DATA / name), 2.0, MIXES["sliding"], 2)
    p = reframe(base, how, seed=11)
    assert p.is_global == base.is_global and p.n_contacts == base.n_contacts
    assert socp_cd.error(p, p.solution.r) < 1e-12
    assert exact_error(p, p.solution.r) < 1e-12
    perm, angles = reframing(p.n_contacts, how, 11)
    tr = ("reframed", contact_map(perm, angles, p.dim))
    assert np.allclose(velocity_back(p.solution.u, tr), base.solution.u, rtol=0, atol=1e-14)
    # a copy, not the base: the data differ (order or frames), mu follows the contacts
    q, q0 = (p.w, base.w) if p.is_global else (p.q, base.q)
    assert not np.allclose(q, q0)
    assert np.array_equal(p.mu, base.mu[perm])
    with pytest.raises(InvalidProblemError):
        reframe(base, "mirror", 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_reframed_copy_permutes_mu_and_keeps_guesses(dim):
    """One ``mu`` per contact (the manufactured families use one for all): the copy's law holds
    for the mapped solution only with ``mu`` renumbered alike; guesses map as the solution."""
    from socp_cd.bench.generators import manufactured
    from socp_cd.bench.transforms import reframed
    from socp_cd.problem import Solution
    base = manufactured(8, dim, mu=np.linspace(0.1, 1.5, 8), seed=4,
                        mix=(0.1, 0.1, 0.8, 0.0))                  # mostly sliding: mu matters
    base.guesses = [Solution(r=base.solution.r * 0.5, u=base.solution.u)]
    rng = np.random.default_rng(2)
    perm, angles = rng.permutation(8), rng.uniform(0.0, 2.0 * np.pi, 8)
    p, tr = reframed(base, perm, angles)
    assert np.array_equal(p.mu, base.mu[perm])
    assert socp_cd.error(p, p.solution.r) < 1e-12
    T = tr[1]
    np.testing.assert_allclose(T.T @ p.guesses[0].r, base.guesses[0].r, atol=1e-15)


def test_reframed_global_copy_keeps_v():
    base = manufacture(socp_cd.read_problem(DATA / "GFC3D_TwoRods1.dat"), 1.0, MIXES["mixed"], 1)
    p = reframe(base, "frames", seed=3)
    assert p.solution.v is not None and np.array_equal(p.solution.v, base.solution.v)
    np.testing.assert_allclose(p.global_velocity(p.solution.r), p.solution.v,
                               atol=1e-12 * np.abs(p.solution.v).max())


def test_reframed_cases_name_their_base_and_take_its_split(cases):
    copies = reframed_cases(DATA, max_contacts=100)
    ids = {c.case_id for c in cases}
    assert len(copies) == len({c.case_id for c in copies})
    assert all(c.params["base"] in ids and c.family == "real-reframed" for c in copies)
    # a copy is in its base case's split: tuning on a copy is tuning on the case it copies
    assert all(c.split == split_of(c.params["base"]) == case_split(c.case_id) for c in copies)
    assert all(case_split(c.case_id) == c.split for c in cases)
    assert {c.split for c in copies} == {"tune", "holdout"}
    assert {c.params["how"] for c in copies} == set(REFRAMINGS)
    assert {c.source for c in copies} == {c.source for c in cases}
    # the draw is the case's own: rebuilding gives the same problem
    c = copies[5]
    a, b = c.problem(), c.problem()
    qa, qb = (a.w, b.w) if a.is_global else (a.q, b.q)
    assert np.array_equal(qa, qb)
