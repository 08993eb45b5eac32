"""Agreement with Siconos numerics 4.4, the C peer (skipped without Siconos).

Everything Siconos computes here comes from ONE worker process (a
module-scoped batch): its relative error ``fc3d_compute_error`` (2D: the C
``fc2d_compute_error``) on several reactions per shared local problem, its own
reader on every ``.dat`` local problem, and a few solves that check the bridge
(r/u returned, crash isolation, time limit).

Siconos 4.4 divides the natural-map residual by ``max(norm, ||r||, ||u||)``
where ``norm`` is the caller's ``||q||`` (absolute when that maximum is below
machine epsilon); the reactions below are chosen so that each of ``||q||``,
``||r||`` and ``||u||`` is the maximum somewhere.
"""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd.bench.siconos_peer import siconos_available, siconos_batch
from socp_cd.data import shared_problems

pytestmark = [
    pytest.mark.siconos,
    pytest.mark.skipif(not siconos_available(), reason="Siconos numerics not importable"),
]

#: Required relative agreement of the errors (observed: <= 10 ulps, 1.3e-15).
ERR_RTOL = 1e-12
#: Required relative agreement of W, q, mu between the two readers.
READ_RTOL = 1e-15
#: Problems small enough for a dense SVD (used to build reactions along singular vectors).
SVD_LIMIT = 400

LOCAL = shared_problems(kind="local")
if not LOCAL:
    pytest.skip("shared problem data not found", allow_module_level=True)
DAT_LOCAL = [p for p in LOCAL if p.format.startswith("siconos-dat")]


def _reactions(problem, rng):
    """Reactions exercising every branch of the normalization max(||q||, ||r||, ||u||)."""
    m, nq = problem.m, float(np.linalg.norm(problem.q))
    scale = nq if nq > 0 else 1.0
    z = rng.standard_normal(m)
    z /= np.linalg.norm(z)
    rs = [np.zeros(m),                    # r = 0: u = q, ||q|| is the max
          1e-3 * scale * z,               # small r: ||q|| ~ ||u|| dominate
          scale * z,
          1e3 * scale * z]                # large r: ||r|| or ||u|| dominates
    if m <= SVD_LIMIT:
        _, s, vt = np.linalg.svd(problem.W.toarray())
        rs.append(1e4 * scale * vt[-1])   # smallest singular direction: ||r|| dominates if s_min < 1
        rs.append(1e4 * scale * vt[0])    # largest: ||u|| dominates if s_max > 1
    # a feasible r (inside K_mu, positive normals) and the stored solution if any
    R = np.abs(rng.standard_normal((problem.n_contacts, problem.dim)))
    R[:, 1:] *= 0.5 * problem.mu[:, None] / np.sqrt(problem.dim - 1)
    rs.append(scale * R.ravel())
    if problem.solution is not None and problem.solution.r is not None:
        rs.append(np.asarray(problem.solution.r, dtype=float))
    return np.array(rs)


def _tiny(problem):
    """The same W with q scaled down so that all norms fall below machine epsilon."""
    return problem.with_(q=problem.q * (1e-18 / max(np.linalg.norm(problem.q), 1e-300)))


@pytest.fixture(scope="module")
def siconos():
    """One worker process for the whole module."""
    rng = np.random.default_rng(20261121)
    cases, tasks = [], []
    for entry in LOCAL:
        problem = socp_cd.read_problem(entry.path)
        rs = _reactions(problem, rng)
        cases.append((entry.file, problem, rs))
        tasks.append({"task": "error", "problem": entry.path, "rs": rs})
    # absolute regime (every norm < DBL_EPSILON), shipped as arrays, not a file
    rover = socp_cd.read_problem(next(p.path for p in LOCAL if p.file == "Rover1039.dat"))
    tiny = _tiny(rover)
    rs_tiny = np.array([np.zeros(tiny.m), 1e-19 * rng.standard_normal(tiny.m)])
    cases.append(("tiny-q", tiny, rs_tiny))
    tasks.append({"task": "error", "problem": tiny, "rs": rs_tiny})
    n_err = len(tasks)
    tasks += [{"task": "load", "problem": p.path} for p in DAT_LOCAL]
    n_load = len(tasks)
    solves = {
        "nsgs": {"task": "solve", "problem": rover, "solver": "nsgs", "tol": 1e-12,
                 "max_iter": 1000},
        "nsgs2d": {"task": "solve", "problem": next(p.path for p in LOCAL
                                                    if p.file == "FrictionContactProblem00071.dat"),
                   "solver": "nsgs", "tol": 1e-10, "max_iter": 2000},
        "global": {"task": "solve", "problem": next(
            p.path for p in shared_problems(kind="global") if p.file == "GFC3D_TwoRods1.dat"),
            "solver": "nsgs", "tol": 1e-10, "max_iter": 1000},
        "bogus": {"task": "solve", "problem": rover, "solver": "no_such_solver"},
        # W's storage: PFP runs on sparse-block storage only; every storage gives NSGS
        # the same answer; SOCLCP rewrites its options, so each repeat needs new ones
        **{f"{s}-{st}": {"task": "solve", "problem": rover, "solver": s, "tol": 1e-8,
                         "max_iter": 1000, "storage": st, "repeat": 3, "time_limit": 20}
           for s in ("nsgs", "pfp") for st in ("dense", "sbm", "csc")},
        "soclcp-repeat": {"task": "solve", "problem": rover, "solver": "soclcp", "tol": 1e-8,
                          "max_iter": 1000, "repeat": 3, "time_limit": 20},
        "abort": {"task": "_abort"},
        "slow": {"task": "solve", "problem": next(
            p.path for p in LOCAL if p.file == "KaplasTower-i1061-4.hdf5.dat"),
            "solver": "aclmfp", "tol": 1e-14, "max_iter": 100000, "time_limit": 0.5},
    }
    tasks += list(solves.values())
    results = siconos_batch(tasks, timeout=600)
    return {
        "errors": list(zip(cases, results[:n_err])),
        "loads": list(zip(DAT_LOCAL, results[n_err:n_load])),
        "solves": dict(zip(solves, results[n_load:])),
        "rover": rover,
    }


def _dominant(problem, r):
    norms = [np.linalg.norm(problem.q), np.linalg.norm(r), np.linalg.norm(problem.velocity(r))]
    return "qru"[int(np.argmax(norms))]


def test_error_agrees_with_fc3d_compute_error(siconos):
    worst = 0.0
    for (name, problem, rs), res in siconos["errors"]:
        assert res["status"] == "ok", (name, res)
        theirs = np.asarray(res["errors"])
        ours = np.array([socp_cd.error(problem, r) for r in rs])
        assert np.all(np.isfinite(ours))
        rel = np.abs(ours - theirs) / np.maximum(np.abs(theirs), np.finfo(float).tiny)
        worst = max(worst, float(rel.max()))
        assert rel.max() <= ERR_RTOL, (name, ours, theirs)
    assert worst <= ERR_RTOL


def test_every_normalization_branch_is_exercised(siconos):
    seen = set()
    for (name, problem, rs), _res in siconos["errors"]:
        if name == "tiny-q":
            continue
        seen.update(_dominant(problem, r) for r in rs)
    assert seen == {"q", "r", "u"}


def test_absolute_regime_below_machine_epsilon(siconos):
    (name, problem, rs), res = siconos["errors"][-1]
    assert name == "tiny-q"
    for r, theirs in zip(rs, res["errors"]):
        norm = max(np.linalg.norm(problem.q), np.linalg.norm(r),
                   np.linalg.norm(problem.velocity(r)))
        assert norm < np.finfo(float).eps
        absolute = socp_cd.absolute_error(problem, r)
        assert absolute > 0
        # Siconos does not divide: the value is the absolute residual
        assert theirs == pytest.approx(absolute, rel=ERR_RTOL)
        assert socp_cd.error(problem, r) == pytest.approx(theirs, rel=ERR_RTOL)


def test_siconos_recomputes_the_same_velocity(siconos):
    for (name, problem, rs), res in siconos["errors"]:
        us = np.asarray(res["us"])
        for r, u in zip(rs, us):
            ours = problem.velocity(r)
            scale = max(1.0, np.abs(ours).max(), np.abs(r).max() * abs(problem.W).max())
            assert np.abs(ours - u).max() <= 1e-13 * scale, name


def test_reader_agrees_with_siconos(siconos):
    assert siconos["loads"], "no .dat local problem"
    for entry, res in siconos["loads"]:
        assert res["status"] == "ok", (entry.file, res)
        ours = socp_cd.read_problem(entry.path)
        assert res["dim"] == ours.dim and res["n_contacts"] == ours.n_contacts
        Wo, Ws = ours.W.toarray(), res["W"].toarray()
        assert Wo.shape == Ws.shape
        scale = max(np.abs(Ws).max(), np.finfo(float).tiny)
        assert np.abs(Wo - Ws).max() <= READ_RTOL * scale, entry.file
        qs = np.asarray(res["q"])
        assert np.abs(ours.q - qs).max() <= READ_RTOL * max(np.abs(qs).max(), np.finfo(float).tiny)
        np.testing.assert_allclose(ours.mu, res["mu"], rtol=READ_RTOL, atol=0)


def test_bridge_returns_siconos_solution(siconos):
    rover = siconos["rover"]
    res = siconos["solves"]["nsgs"]
    assert res["status"] == "ok" and res["solver_name"] == "FC3D_NSGS"
    assert res["info"] == 0 and res["residual"] <= 1e-12
    assert 0 < res["iterations"] <= 1000
    assert res["time"] > 0 and res["wall_time"] >= res["time"]
    # the r that came back through the npz is the one Siconos judged
    assert socp_cd.error(rover, res["r"]) == pytest.approx(res["error"], rel=1e-9, abs=1e-15)
    assert socp_cd.error(rover, res["r"]) <= 1e-11
    np.testing.assert_allclose(res["u"], rover.velocity(res["r"]), atol=1e-12)


def test_bridge_2d_nsgs(siconos):
    res = siconos["solves"]["nsgs2d"]
    assert res["status"] == "ok" and res["dim"] == 2 and res["solver_name"] == "F2D_NSGS"
    problem = socp_cd.read_problem(next(p.path for p in LOCAL
                                        if p.file == "FrictionContactProblem00071.dat"))
    assert res["info"] == 0
    assert socp_cd.error(problem, res["r"]) == pytest.approx(res["error"], rel=1e-9)
    assert socp_cd.error(problem, res["r"]) <= 1e-8


def test_bridge_global_conventions(siconos):
    """Siconos' (q, b) are FCLib's (f, w): its global solution solves our problem.

    (Global NSGS; Siconos 4.4's ``nsgs_wr`` returns an r that solves the problem
    but a v, u not recomputed from it, so it is not used for this check.)
    """
    res = siconos["solves"]["global"]
    assert res["status"] == "ok" and res["kind"] == "global" and res["info"] == 0
    entry = next(p for p in shared_problems(kind="global") if p.file == "GFC3D_TwoRods1.dat")
    problem = socp_cd.read_problem(entry.path)
    np.testing.assert_allclose(res["v"], problem.global_velocity(res["r"]), atol=1e-9)
    np.testing.assert_allclose(res["u"], problem.velocity(res["r"]), atol=1e-9)
    assert socp_cd.error(problem, res["r"]) <= 1e-8


def test_bridge_failures_are_data(siconos):
    s = siconos["solves"]
    assert s["bogus"]["status"] == "error" and "no_such_solver" in s["bogus"]["message"]
    assert s["abort"]["status"] == "crashed" and s["abort"]["exitcode"] < 0
    assert s["slow"]["status"] == "time_limit"
    assert s["slow"]["wall_time"] < 60


def test_bridge_storage_of_w(siconos):
    """The worker stores W as asked; each storage reaches the same NSGS answer, PFP needs
    sparse-block storage (dense or CSparse abort it in Siconos 4.4)."""
    s, rover = siconos["solves"], siconos["rover"]
    ref = s["nsgs-csc"]
    assert ref["status"] == "ok" and ref["info"] == 0
    for st in ("dense", "sbm"):
        res = s[f"nsgs-{st}"]
        assert res["status"] == "ok" and res["iterations"] == ref["iterations"]
        np.testing.assert_allclose(res["r"], ref["r"], rtol=1e-10, atol=1e-14)
    pfp = s["pfp-sbm"]
    assert pfp["status"] == "ok" and pfp["solver_name"] == "FC3D_PFP"
    assert socp_cd.error(rover, pfp["r"]) <= 1e-8
    assert s["pfp-dense"]["status"] == "crashed" and s["pfp-csc"]["status"] == "crashed"


def test_bridge_repeats_with_new_options(siconos):
    """A driver that rewrites its options (SOCLCP) is repeated with new ones: its answer
    is returned, not an "Unknown solver" error from the second call."""
    res = siconos["solves"]["soclcp-repeat"]
    assert res["status"] == "ok", res.get("message")
    assert np.all(np.isfinite(res["r"])) and res["iterations"] >= 1
