"""Benchmark machinery: records, summaries, profiles, isolation, CLI, dask."""
from __future__ import annotations

import csv
import math
import os
import time

import numpy as np
import pytest

import socp_cd
from socp_cd import bench as C
from socp_cd.bench import records as R
from socp_cd.bench import reports as P
from socp_cd.bench.generators import generate
from socp_cd.solvers import registry
from socp_cd.solvers.result import SolverResult


# ------------------------------------------------------------------ fake solvers
_FAKES: dict = {}


def _fake(name):
    """Mark a test backend; the fixture registers it for this module only."""
    def deco(fn):
        _FAKES[name] = fn
        return fn
    return deco


@_fake("t_exact")
def _exact(problem, formulation, *, tol, max_iter, r0, history, **opt):
    """Returns the manufactured exact solution (claims convergence)."""
    return SolverResult(r=problem.solution.r.copy(), status="converged", iterations=1)


@_fake("t_slow")
def _slow(problem, formulation, *, tol, max_iter, r0, history, **opt):
    time.sleep(30.0)
    return SolverResult(r=np.zeros(problem.m), status="converged")


@_fake("t_nan")
def _nan(problem, formulation, *, tol, max_iter, r0, history, **opt):
    return SolverResult(r=np.full(problem.m, np.nan), status="converged")


@_fake("t_raise")
def _raise(problem, formulation, *, tol, max_iter, r0, history, **opt):
    raise RuntimeError("boom")


@_fake("t_die")
def _die(problem, formulation, *, tol, max_iter, r0, history, **opt):
    os._exit(7)


@_fake("t_liar")
def _liar(problem, formulation, *, tol, max_iter, r0, history, **opt):
    """Claims convergence with r = 0 (wrong unless q >= 0 contact-wise)."""
    return SolverResult(r=np.zeros(problem.m), status="converged")


@pytest.fixture(scope="module", autouse=True)
def _registered_fakes():
    for name, fn in _FAKES.items():
        registry.register(name, ("coulomb",), description="test double")(fn)
    yield
    for name in _FAKES:
        registry.unregister(name)


def _ref(n=3, dim=3, seed=0):
    return C.generated_problems("manufactured", sizes=(n,), dims=(dim,), seeds=(seed,))[0]


def _rec(**kw):
    base = dict(suite="s", problem="p", family="F", solver="A", formulation="coulomb", tol=1e-4,
                time_limit=1.0, status="converged", success=True, error=1e-5, time=0.1)
    base.update(kw)
    return R.new_record(**base)


# ------------------------------------------------------------------ records
def test_record_schema_and_roundtrip(tmp_path):
    rec = _rec(error=math.inf, law_error=math.nan, iterations=12, nan=True, message="a, \"b\"")
    assert tuple(rec) == R.FIELDS
    with pytest.raises(ValueError):
        R.new_record(status="exploded")
    with pytest.raises(KeyError):
        R.new_record(colour="red")
    path = R.write_records(tmp_path / "r.csv", [rec])
    back = R.read_records(path)[0]
    assert back["error"] == math.inf and math.isnan(back["law_error"])
    assert back["iterations"] == 12 and back["nan"] is True and back["success"] is True
    assert back["message"] == "a, \"b\"" and back["tol"] == 1e-4
    with open(path) as fh:
        assert next(csv.reader(fh)) == list(R.FIELDS)


def test_append_dedupes_on_key(tmp_path):
    path = tmp_path / "r.csv"
    R.append_records(path, [_rec(problem="p1"), _rec(problem="p2")])
    table = R.append_records(path, [_rec(problem="p1", error=3e-6), _rec(problem="p1", tol=1e-6)])
    assert len(table) == 3
    by = {(r["problem"], r["tol"]): r for r in R.read_records(path)}
    assert set(by) == {("p1", 1e-4), ("p2", 1e-4), ("p1", 1e-6)}
    assert by[("p1", 1e-4)]["error"] == 3e-6          # the newer run replaced the old one
    # settings are part of the key: same run with an option is a different run
    R.append_records(path, [_rec(problem="p2", settings=R.settings_string({"omega": 1.5}))])
    assert len(R.read_records(path)) == 4


# ------------------------------------------------------------------ statistics
def test_shifted_geometric_mean_by_hand():
    # (0 + .01)(.09 + .01)(.99 + .01) = 1e-3, cube root 0.1, minus the shift 0.01
    assert P.shifted_geometric_mean([0.0, 0.09, 0.99]) == pytest.approx(0.09, rel=1e-12)
    # shift 1: sqrt((1+1)(7+1)) - 1 = 3
    assert P.shifted_geometric_mean([1.0, 7.0], shift=1.0) == pytest.approx(3.0, rel=1e-12)


def test_summary_table_charges_failures_the_time_limit():
    recs = [_rec(problem="p1", solver="A", time=0.09),
            _rec(problem="p2", solver="A", status="time_limit", success=False, time=math.nan,
                 time_limit=0.99),
            _rec(problem="p1", solver="B", time=0.0),
            _rec(problem="p2", solver="B", time=0.0),
            _rec(problem="p3", solver="B", status="rejected", success=False)]
    rows = {r["solver"]: r for r in P.summary_table(recs, {"low": 1e-4})}
    # A: sqrt((0.09+0.01)(0.99+0.01)) - 0.01 = 0.3062...
    assert rows["A"]["success_rate"] == 0.5 and rows["A"]["time_limit"] == 1
    assert rows["A"]["sgm_time"] == pytest.approx(math.sqrt(0.1) - 0.01, rel=1e-12)
    assert rows["B"]["success_rate"] == 1.0 and rows["B"]["problems"] == 2  # rejected excluded
    assert rows["B"]["sgm_time"] == pytest.approx(0.0, abs=1e-15)


def test_readme_section_is_rewritten_between_markers(tmp_path):
    recs = [_rec(problem="p1", solver="A", time=0.09),
            _rec(problem="p2", solver="A", status="time_limit", success=False, time=math.nan,
                 time_limit=0.99)]
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{P.README_BEGIN}\nold table\n{P.README_END}\noutro\n")
    assert P.update_readme(readme, recs, {"low": 1e-4})
    text = readme.read_text()
    assert "old table" not in text and text.startswith("intro\n") and text.endswith(f"{P.README_END}\noutro\n")
    # A solved 1 of 2; SGM = sqrt(0.1) - 0.01 = 0.306 (see the test above)
    assert "| A | 1/2, 0.31 |" in text
    plain = tmp_path / "NOMARKERS.md"
    plain.write_text("no markers here\n")
    assert not P.update_readme(plain, recs, {"low": 1e-4})
    assert plain.read_text() == "no markers here\n"


def test_virtual_best_siconos_picks_the_fastest_success_else_the_smallest_error():
    S = "siconos:"
    recs = [_rec(problem="p1", solver=S + "a", time=0.5),
            _rec(problem="p1", solver=S + "b", time=0.2),
            _rec(problem="p1", solver=S + "c", time=0.01, status="max_iter", success=False),
            _rec(problem="p2", solver=S + "a", status="max_iter", success=False, error=1e-3),
            _rec(problem="p2", solver=S + "b", status="max_iter", success=False, error=1e-5),
            _rec(problem="p3", solver=S + "a", status="unsupported", success=False),
            _rec(problem="p1", solver="ours", time=0.1),
            _rec(problem="p1", solver=S + "a", tol=1e-8, status="max_iter", success=False)]
    best = {(r["problem"], r["tol"]): r for r in P.virtual_best(recs)}
    assert set(best) == {("p1", 1e-4), ("p2", 1e-4), ("p1", 1e-8)}   # p3: nobody ran
    assert best[("p1", 1e-4)]["time"] == 0.2 and best[("p1", 1e-4)]["success"]
    assert best[("p1", 1e-4)]["message"].startswith(S + "b")
    assert not best[("p2", 1e-4)]["success"] and best[("p2", 1e-4)]["error"] == 1e-5
    assert not best[("p1", 1e-8)]["success"]
    assert all(r["solver"] == P.SICONOS_BEST for r in best.values())
    # in the summaries: a row of its own, counted over the problems of the preset
    rows = {r["solver"]: r for r in P.summary_table(P.with_virtual_best(recs), {"low": 1e-4})}
    assert rows[P.SICONOS_BEST]["success"] == 1 and rows[P.SICONOS_BEST]["problems"] == 2
    assert f"| {P.SICONOS_BEST} | " in P.readme_table(recs, {"low": 1e-4})
    assert P.virtual_best([_rec(problem="p1", solver="ours")]) == []


def test_campaign_siconos_peers_are_every_solver_of_every_family():
    from socp_cd.bench import siconos_peer, tasks
    every = {n for names in siconos_peer.SOLVERS.values() for n in names}
    assert set(tasks.SICONOS_SOLVERS) == every - set(tasks.SICONOS_LEFT_OUT)
    assert {"prox", "nsn_fb", "nsn_ac", "prox_wr", "cpg", "lemke"} <= set(tasks.SICONOS_SOLVERS)


def test_siconos_solver_of_another_family_is_unsupported_without_running():
    from socp_cd.bench.siconos_runs import run_siconos_batch, siconos_unsupported_reason
    ref2 = _ref(3, dim=2)
    task = C.make_tasks([ref2], ["siconos:prox"], [1e-6])[0]
    why = siconos_unsupported_reason(task, ref2.load())
    assert "'prox'" in why and "local2" in why and "cpg" in why
    # no worker is started for it (this runs without Siconos too)
    rec, = run_siconos_batch([task])
    assert rec["status"] == "unsupported" and not rec["success"] and "local2" in rec["message"]
    task3 = C.make_tasks([_ref(3, dim=3)], ["siconos:prox"], [1e-6])[0]
    assert siconos_unsupported_reason(task3, task3.problem.load()) is None


def test_performance_profile_by_hand():
    inf = math.inf
    table = {"p1": {"A": 1.0, "B": 2.0}, "p2": {"A": 4.0, "B": 2.0},
             "p3": {"A": inf, "B": 3.0}, "p4": {"A": inf, "B": inf}}
    ratios = P.performance_ratios(table)
    assert ratios["A"] == [1.0, 2.0, inf, inf] and ratios["B"] == [2.0, 1.0, 1.0, inf]
    taus, rho = P.performance_profile(table, taus=[1.0, 1.5, 2.0, 100.0])
    np.testing.assert_allclose(rho["A"], [0.25, 0.25, 0.5, 0.5])
    np.testing.assert_allclose(rho["B"], [0.5, 0.5, 0.75, 0.75])
    # a solver missing from a row counts as a failure there
    assert P.performance_ratios({"p": {"A": 1.0}, "q": {"A": 1.0, "B": 1.0}})["B"] == [inf, 1.0]


def test_work_precision_extraction():
    recs = [_rec(problem="p1", tol=1e-4, time=0.09, error=1e-5),
            _rec(problem="p2", tol=1e-4, time=0.99, error=1e-7),
            _rec(problem="p1", tol=1e-8, time=0.49, error=1e-9),
            _rec(problem="p2", tol=1e-8, status="time_limit", success=False, time=math.nan,
                 error=math.nan, time_limit=1.99),
            _rec(problem="p1", tol=1e-8, solver="U", status="unsupported", success=False)]
    data = P.work_precision_data(recs)
    assert list(data) == ["F"] and list(data["F"]) == ["A"]   # unsupported runs are no points
    loose, tight = data["F"]["A"]
    assert loose["tol"] == 1e-4 and tight["tol"] == 1e-8
    assert loose["time"] == pytest.approx(math.sqrt(0.1 * 1.0) - 0.01, rel=1e-12)
    assert loose["error"] == pytest.approx(1e-6, rel=1e-12) and loose["solved"] == 2
    assert tight["time"] == pytest.approx(math.sqrt(0.5 * 2.0) - 0.01, rel=1e-12)
    assert tight["error"] == pytest.approx(1e-9, rel=1e-12)
    assert (tight["solved"], tight["runs"]) == (1, 2)


# ------------------------------------------------------------------ isolation
def _run(solver, tol=1e-6, time_limit=20.0, ref=None):
    return C.run_one(C.RunTask(ref or _ref(), C.parse_solver(solver), tol, time_limit))


def test_time_limit_is_enforced():
    rec = _run("t_slow", time_limit=0.5)
    assert rec["status"] == "time_limit" and not rec["success"]
    assert rec["wall_time"] < 25.0   # killed, not waited for (30 s sleep)


def test_failures_are_recorded_not_raised():
    nan = _run("t_nan")
    assert nan["status"] == "numerical_error" and nan["nan"] and not nan["success"]
    raised = _run("t_raise")
    assert raised["status"] == "crashed" and "boom" in raised["message"]
    died = _run("t_die")
    assert died["status"] == "crashed" and "exit code 7" in died["message"]
    missing = _run("no_such_solver")
    assert missing["status"] == "unsupported"


def test_exact_and_lying_solvers_are_judged_by_recomputed_error():
    ref = _ref(10)
    p = ref.load()
    exact = _run("t_exact", ref=ref)
    assert exact["status"] == "converged" and exact["success"]
    assert exact["error"] == pytest.approx(socp_cd.error(p, p.solution.r), abs=1e-15)
    assert exact["u_error"] < 1e-14 and exact["r_error"] < 1e-14
    assert (exact["contacts"], exact["dim"], exact["nnz"]) == (10, 3, p.W.nnz)
    liar = _run("t_liar", ref=ref)
    assert liar["error"] == pytest.approx(socp_cd.error(p, np.zeros(p.m)), rel=1e-12)
    assert liar["error"] > 1e-6 and not liar["success"] and liar["status"] != "converged"


def test_solver_spec_parsing():
    s = C.parse_solver("nsgs:tresca,omega=1.5,ordering=shuffled")
    assert (s.name, s.formulation, dict(s.options)) == ("nsgs", "tresca", {"omega": 1.5, "ordering": "shuffled"})
    assert C.parse_solver("siconos:NSN_AC").name == "siconos:nsn_ac"
    assert C.resolve_tolerances(["mid", "sweep"])[0] == 1e-2 and len(C.resolve_tolerances("sweep")) == 9
    assert C.resolve_tolerances("all") == [1e-2, 1e-4, 1e-6, 1e-8, 1e-10]
    assert C.resolve_tolerances(None) == [1e-4, 1e-6, 1e-8]


# ------------------------------------------------------------------ CLI
def test_cli_smoke_writes_csv_and_reports(tmp_path):
    from socp_cd.bench.cli import main
    solvers = ["t_exact", "t_liar"]
    if "nsgs" in socp_cd.solvers():
        solvers.append("nsgs")
    code = main(["--family", "manufactured", "--sizes", "2,4", "--dims", "3", "--solvers",
                 ",".join(solvers), "--tol", "1e-6", "--tol", "1e-3", "--time-limit", "30",
                 "--out", str(tmp_path), "--quiet"])
    assert code == 0
    rows = R.read_records(tmp_path / "records.csv")
    assert len(rows) == 2 * len(solvers) * 2
    assert {r["problem"] for r in rows} == {"manufactured-3d-2-s0", "manufactured-3d-4-s0"}
    assert {r["solver"] for r in rows} == set(solvers)
    for r in rows:
        assert r["status"] in R.RUN_STATUSES
        assert r["success"] == (r["error"] <= r["tol"])
        p = generate("manufactured", int(r["problem"].split("-")[2]), 3, seed=0)
        assert (r["contacts"], r["nnz"]) == (p.n_contacts, p.W.nnz)
        if r["solver"] == "t_exact":
            assert r["success"] and r["u_error"] < 1e-13
        if r["solver"] == "t_liar":
            assert r["error"] == pytest.approx(socp_cd.error(p, np.zeros(p.m)), rel=1e-12)
    summary = (tmp_path / "summary.md").read_text()
    assert "t_exact | 100.0% | 2/2" in summary
    assert (tmp_path / "work_precision.png").stat().st_size > 1000
    assert (tmp_path / "performance_profile.png").stat().st_size > 1000
    # a second run appends, deduplicating on the key (no new rows)
    assert main(["--family", "manufactured", "--sizes", "2", "--dims", "3", "--solvers", "t_exact",
                 "--tol", "1e-6", "--out", str(tmp_path), "--quiet", "--no-report"]) == 0
    assert len(R.read_records(tmp_path / "records.csv")) == len(rows)


# ------------------------------------------------------------------ dask
def test_dask_matches_serial():
    pytest.importorskip("dask.distributed")
    real = [s for s in ("nsgs", "clarabel") if s in socp_cd.solvers()]
    if not real:
        pytest.skip("no real solver registered")
    probs = C.generated_problems("manufactured", sizes=(3,), dims=(2, 3))
    serial = C.run_campaign(probs, real, [1e-6], 60.0)
    par = C.run_campaign(probs, real, [1e-6], 60.0, dask=True)   # LocalCluster, 2 worker processes
    assert len(serial) == len(par) == len(probs) * len(real)
    key = lambda r: (r["problem"], r["solver"])  # noqa: E731
    for a, b in zip(sorted(serial, key=key), sorted(par, key=key)):
        assert R.strip_timing(a) == R.strip_timing(b)


# ------------------------------------------------------------------ Siconos peer
def _siconos():
    return C.siconos_ready()


@pytest.mark.siconos
def test_siconos_peer_in_campaign():
    if not _siconos():
        pytest.skip("Siconos numerics not available")
    ref = _ref(10)
    p = ref.load()
    recs = C.run_campaign([ref], ["siconos:nsgs", "siconos:nsn_ac"], [1e-6], 60.0)
    assert {r["solver"] for r in recs} == {"siconos:nsgs", "siconos:nsn_ac"}
    for r in recs:
        assert r["status"] in R.RUN_STATUSES and r["contacts"] == 10
        assert r["success"] == (r["error"] <= 1e-6)
    nsgs = next(r for r in recs if r["solver"] == "siconos:nsgs")
    assert nsgs["success"] and nsgs["u_error"] < 1e-3   # SPD W: u* is recovered
    assert p.n_contacts == 10


def test_resume_skips_recorded_runs(tmp_path):
    csv_path = tmp_path / "r.csv"
    refs = [_ref(2), _ref(3)]
    first = C.run_campaign(refs, ["t_exact"], [1e-4, 1e-6], 20.0, csv_path=csv_path)
    assert len(first) == 4
    again = C.run_campaign(refs + [_ref(4)], ["t_exact"], [1e-4, 1e-6], 20.0, csv_path=csv_path,
                           resume=True)
    assert {r["problem"] for r in again} == {"manufactured-3d-4-s0"} and len(again) == 2
    assert len(R.read_records(csv_path)) == 6


def test_variant_comparison_charges_failures_and_finds_disagreements():
    from socp_cd.bench.reports import (shifted_geometric_mean, variant_comparison,
                                       variant_comparison_by, variant_disagreements)
    rows = [dict(case="a", kind="x", v="p", solved=True, time=0.1),
            dict(case="a", kind="x", v="q", solved=True, time=0.2),
            dict(case="b", kind="y", v="p", solved=False, time=0.3),
            dict(case="b", kind="y", v="q", solved=True, time=0.4)]
    c = variant_comparison(rows, "v", ["p", "q"], time_limit=5.0)
    assert c["p"]["solved"] == 1 and c["q"]["solved"] == 2
    assert c["p"]["sgm"] == pytest.approx(shifted_geometric_mean([0.1, 5.0]))   # failure charged
    assert c["p"]["n_common"] == c["q"]["n_common"] == 1                     # only "a" is common
    assert c["q"]["sgm_common"] == pytest.approx(shifted_geometric_mean([0.2]))
    groups = [(g, v) for g, v, _ in variant_comparison_by(rows, "kind", "v", ["p", "q"], 5.0)]
    assert groups == [("x", "p"), ("x", "q"), ("y", "p"), ("y", "q"), ("all", "p"), ("all", "q")]
    assert [cid for cid, _ in variant_disagreements(rows, "v")] == ["b"]


def test_our_runs_follow_the_siconos_worker_repeat_rule(monkeypatch):
    # a fast solve is repeated on new problem objects (shallow copies: no cache carries over)
    # and the fastest call is reported, as the Siconos worker reports its driver's
    from socp_cd.bench import isolation
    ref = _ref(3)
    p = ref.load()
    seen = []
    real = isolation.solve

    def spy(problem, **kw):
        seen.append(problem)
        return real(problem, **kw)
    monkeypatch.setattr(isolation, "solve", spy)
    task = C.make_tasks([ref], ["nsgs"], [1e-8])[0]
    socp_cd.solve(ref.load(), "nsgs")       # compiled first: a slow first call is not repeated
    keys = set(vars(p))
    kind, out = isolation.solve_payload(task, p, repeat=7)
    assert kind == "ok" and out["calls"] == 7 and len(seen) == 7, out
    assert all(q is not p for q in seen) and len({id(q) for q in seen}) == 7
    assert set(vars(p)) == keys            # p itself is never solved: it caches nothing
    assert out["status"] == "converged" and out["time"] > 0.0
    # a run that does not converge is not repeated
    seen.clear()
    task = C.make_tasks([ref], ["nsgs,stall_window=1"], [1e-30])[0]
    kind, out = isolation.solve_payload(task, p, repeat=7)
    assert kind == "ok" and out["calls"] == 1 and out["status"] != "converged"


def test_a_short_first_call_is_always_repeated_once(monkeypatch):
    # past the budget, a first call under REPEAT_SECOND_BELOW still gets a second (warm) one;
    # one over it does not
    from socp_cd.bench import isolation
    ref = _ref(3)
    task = C.make_tasks([ref], ["nsgs"], [1e-8])[0]
    monkeypatch.setattr(isolation, "REPEAT_BUDGET", 0.0)
    # (every first call is short under an infinite bound: a clean clone's first call loads
    # the compiled kernels and can take longer than the real bound, 1 s)
    monkeypatch.setattr(isolation, "REPEAT_SECOND_BELOW", float("inf"))
    kind, out = isolation.solve_payload(task, ref.load(), repeat=50)
    assert kind == "ok" and out["calls"] == 2
    monkeypatch.setattr(isolation, "REPEAT_SECOND_BELOW", 0.0)
    kind, out = isolation.solve_payload(task, ref.load(), repeat=50)
    assert kind == "ok" and out["calls"] == 1
