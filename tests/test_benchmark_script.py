"""validation/newton_vs_siconos.py's run order: both sides interleaved by chunks of problems."""
from __future__ import annotations

import pytest

from socp_cd.bench.generators import manufactured

@pytest.fixture()
def script(validation_script):
    return validation_script("newton_vs_siconos")


#: what a stubbed run of ours returns
REC = dict(error=1e-12, status="converged", time=1e-5, claimed=True, guard=1e-12, path="")


def _offline(script, monkeypatch, n):
    """``n`` one-contact problems as the script's problem set, its warm-ups and calls of
    ``solve`` outside the timed runs stubbed out."""
    items = [dict(set="shared", id=f"p{k}", split="shared", kind="local3", nc=1,
                  problem=manufactured(1, 3, mu=0.5, seed=k)) for k in range(n)]
    monkeypatch.setattr(script, "problem_set", lambda args: items)
    monkeypatch.setattr(script.socp_cd, "warmup", lambda: 0.0)
    monkeypatch.setattr(script.socp_cd, "solve", lambda *a, **k: None)


def test_main_runs_both_sides_on_each_chunk_before_the_next(script, monkeypatch, tmp_path):
    # the two sides' calls, in the order main makes them: every chunk is done by both sides
    # (who goes first alternating) before the next starts, at every tolerance
    _offline(script, monkeypatch, 7)
    calls = []

    def ours(item, solver, tol, args):
        calls.append(("ours", tol, item["id"]))
        return dict(REC)

    picked = {}

    def theirs(sub, solvers_for, tol, args):
        calls.append(("siconos", tol, tuple(it["id"] for it in sub)))
        picked.setdefault(tol, set()).update(s for it in sub for s in solvers_for(it["kind"]))
        return {(j, "nsgs"): dict(REC, status="ok") for j in range(len(sub))}

    def calibration():
        calls.append(("calibration",))
        return 5.0

    monkeypatch.setattr(script, "run_ours", ours)
    monkeypatch.setattr(script, "run_siconos", theirs)
    monkeypatch.setattr(script, "siconos_available", lambda: True)
    monkeypatch.setattr(script, "calibration_call", calibration)
    monkeypatch.setattr(script, "write", lambda rows, args, have_sic: calls.append(("write", rows)))
    script.main(["--ours", "auto", "--chunk", "3", "--sweep", "1e-4", "--out", str(tmp_path)])
    rows = calls.pop()[1]
    expected = []
    for tol in (1e-8, 1e-4):
        for part, first in ((("p0", "p1", "p2"), "ours"), (("p3", "p4", "p5"), "siconos"),
                            (("p6",), "ours")):
            mine = [("ours", tol, p) for p in part]
            theirs_ = [("siconos", tol, part)]
            # the machine's speed read before each chunk of the main tolerance
            expected += [("calibration",)] if tol == 1e-8 else []
            expected += mine + theirs_ if first == "ours" else theirs_ + mine
        expected += [("calibration",)] if tol == 1e-8 else []      # and at its end
    assert calls == expected
    # every Siconos 3D local solver at the main tolerance, the strong ones on the sweep
    assert picked[1e-8] == set(script.SICONOS_SOLVERS["local3"])
    assert picked[1e-4] == {"prox", "nsn_ac", "nsn_fb", "nsgs"}
    # one row per problem, side and tolerance, each labelled with its own problem
    keys = sorted((r["tol"], r["problem"], r["side"]) for r in rows)
    assert keys == sorted((t, f"p{k}", side) for t in (1e-8, 1e-4) for k in range(7)
                          for side in ("ours", "siconos"))


def test_main_with_siconos_from_runs_ours_only_and_takes_their_rows(script, monkeypatch,
                                                                     tmp_path):
    # --siconos-from: our side alone, in the same chunks, then the previous run's Siconos
    # rows at --tol for the same problems (others and other tolerances left out)
    _offline(script, monkeypatch, 4)
    calls, written = [], []
    previous = [dict(tol=1e-8, set="shared", problem="p1", side="siconos", solver="siconos:nsgs"),
                dict(tol=1e-4, set="shared", problem="p1", side="siconos", solver="siconos:nsgs"),
                dict(tol=1e-8, set="shared", problem="elsewhere", side="siconos",
                     solver="siconos:nsgs"),
                dict(tol=1e-8, set="shared", problem="p2", side="ours", solver="auto")]
    monkeypatch.setattr(script, "run_ours",
                        lambda it, s, tol, args: calls.append(it["id"]) or dict(REC))
    monkeypatch.setattr(script, "run_siconos", lambda *a: pytest.fail("Siconos must not run"))
    monkeypatch.setattr(script, "read_rows", lambda path: previous)
    monkeypatch.setattr(script, "calibration_call", lambda: 5.0)
    monkeypatch.setattr(script, "write",
                        lambda rows, args, have_sic: written.append((rows, have_sic)))
    script.main(["--ours", "auto", "--chunk", "3", "--sweep", "--siconos-from",
                 str(tmp_path / "x.csv"), "--out", str(tmp_path)])
    assert calls == ["p0", "p1", "p2", "p3"]
    rows, have_sic = written[0]
    assert have_sic
    assert [(r["side"], r["problem"]) for r in rows if r["side"] == "siconos"] == [
        ("siconos", "p1")]


def test_chunk_below_one_is_refused_before_any_work(script, monkeypatch):
    monkeypatch.setattr(script, "problem_set", lambda args: pytest.fail("no work"))
    with pytest.raises(SystemExit):
        script.main(["--chunk", "0"])


def test_an_answer_past_the_budget_is_not_solved(script):
    # both sides have the same budget: within tol but later than time_limit (plus the slack
    # for either side's stop granularity) is not solved; the error alone still decides claims
    late = dict(error=1e-9, time=1.0 + 2 * script.BUDGET_SLACK)
    on_time = dict(error=1e-9, time=1.0 + 0.5 * script.BUDGET_SLACK)
    assert script.solved(late, 1e-8) and not script.solved(late, 1e-8, 1.0)
    assert script.solved(on_time, 1e-8, 1.0)
    assert script.past_budget(late, 1e-8, 1.0) and not script.past_budget(on_time, 1e-8, 1.0)
    assert not script.past_budget(dict(error=1e-7, time=5.0), 1e-8, 1.0)


def test_the_report_counts_a_late_siconos_answer_as_a_failure(script, tmp_path):
    import argparse
    base = dict(tol=1e-8, set="shared", split="shared", kind="local3", nc=3, guard=1e-9,
                path="")
    rows = [dict(base, problem="p0", solver="auto", side="ours", error=3e-8,
                 status="time_limit", claimed=False, time=1.0),
            dict(base, problem="p0", solver="siconos:prox", side="siconos", error=1e-9,
                 status="ok", claimed=True, time=1.17),
            dict(base, problem="p1", solver="auto", side="ours", error=1e-9,
                 status="converged", claimed=True, time=0.01),
            dict(base, problem="p1", solver="siconos:prox", side="siconos", error=1e-9,
                 status="ok", claimed=True, time=0.02)]
    args = argparse.Namespace(out=tmp_path, tol=1e-8, time_limit=1.0, quick=False, repeats=3,
                              repeats_small=200, calibration={"chunk 0 (problems 0-1)": 6.25})
    script.write(rows, args, have_sic=True)
    report = (tmp_path / "newton_vs_siconos.md").read_text()
    assert "Solved by at least one Siconos solver: 1/2." in report
    assert "siconos:prox on p0 (1.17 s)" in report
    assert "| siconos:prox | 1 | 1/2 |" in report
    assert "- `auto` misses 0 of them" in report
    # rewritten from its CSV, the run is judged against its own limit (recorded in the JSON),
    # not the option's default of 5 s; without the record the limit must be given
    again = tmp_path / "again"
    script.main(["--from-csv", str(tmp_path / "newton_vs_siconos.csv"), "--out", str(again)])
    rewritten = (again / "newton_vs_siconos.md").read_text()
    assert "Solved by at least one Siconos solver: 1/2." in rewritten
    assert "chunk 0 (problems 0-1) 6.25" in rewritten        # the run's calibration readings
    (tmp_path / "newton_vs_siconos.json").unlink()
    with pytest.raises(SystemExit):
        script.main(["--from-csv", str(tmp_path / "newton_vs_siconos.csv"), "--out", str(again)])
