"""validation/newton_vs_siconos.py's run order: both sides interleaved by chunks of problems."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

from socp_cd.bench.generators import manufactured

VALIDATION = Path(__file__).resolve().parents[1] / "validation"


@pytest.fixture()
def script():
    sys.path.insert(0, str(VALIDATION))
    try:
        import newton_vs_siconos
        yield newton_vs_siconos
    finally:
        sys.path.remove(str(VALIDATION))


def test_interleaved_covers_each_problem_once_and_alternates_the_first_side(script):
    order = script.interleaved(23, 5)
    assert [k for part, _ in order for k in part] == list(range(23))
    assert [len(part) for part, _ in order] == [5, 5, 5, 5, 3]
    assert [first for _, first in order] == ["ours", "siconos", "ours", "siconos", "ours"]
    assert script.interleaved(0, 5) == []
    with pytest.raises(ValueError, match="chunk size"):
        script.interleaved(3, 0)


def test_main_runs_both_sides_on_each_chunk_before_the_next(script, monkeypatch, tmp_path):
    # the two sides' calls, in the order main makes them: every chunk is done by both sides
    # (who goes first alternating) before the next starts, at every tolerance
    items = [dict(set="shared", id=f"p{k}", split="shared", kind="local3", nc=1,
                  problem=manufactured(1, 3, mu=0.5, seed=k)) for k in range(7)]
    calls = []
    rec = dict(error=1e-12, status="converged", time=1e-5, claimed=True, guard=1e-12, path="")

    def ours(item, solver, tol, args):
        calls.append(("ours", tol, item["id"]))
        return dict(rec)

    def theirs(sub, solvers_for, tol, args):
        calls.append(("siconos", tol, tuple(it["id"] for it in sub)))
        return {(j, "nsgs"): dict(rec, status="ok") for j in range(len(sub))}

    monkeypatch.setattr(script, "problem_set", lambda args: items)
    monkeypatch.setattr(script, "run_ours", ours)
    monkeypatch.setattr(script, "run_siconos", theirs)
    monkeypatch.setattr(script, "siconos_available", lambda: True)
    monkeypatch.setattr(script, "calibration_call", lambda: 5.0)
    monkeypatch.setattr(script.newton, "warmup", lambda: None)
    monkeypatch.setattr(script.nsgs, "warmup", lambda: None)
    monkeypatch.setattr(script.socp_cd, "solve", lambda *a, **k: None)
    monkeypatch.setattr(script, "write", lambda rows, args, have_sic: calls.append(("write", rows)))
    script.main(["--ours", "auto", "--chunk", "3", "--sweep", "1e-4", "--out", str(tmp_path)])
    rows = calls.pop()[1]
    expected = []
    for tol in (1e-8, 1e-4):
        for part, first in ((("p0", "p1", "p2"), "ours"), (("p3", "p4", "p5"), "siconos"),
                            (("p6",), "ours")):
            mine = [("ours", tol, p) for p in part]
            theirs_ = [("siconos", tol, part)]
            expected += mine + theirs_ if first == "ours" else theirs_ + mine
    assert calls == expected
    # one row per problem, side and tolerance, each labelled with its own problem
    keys = sorted((r["tol"], r["problem"], r["side"]) for r in rows)
    assert keys == sorted((t, f"p{k}", side) for t in (1e-8, 1e-4) for k in range(7)
                          for side in ("ours", "siconos"))
