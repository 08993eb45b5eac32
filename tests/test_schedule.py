"""socp_cd.bench.schedule (the interleaved order) and campaign.run_tasks following it."""
from __future__ import annotations

import pytest

from socp_cd.bench import campaign
from socp_cd.bench.problem_refs import generated_problems
from socp_cd.bench.schedule import interleaved
from socp_cd.bench.tasks import base_record, make_tasks


def test_interleaved_covers_each_problem_once_and_alternates_the_first_side():
    order = interleaved(23, 5)
    assert [k for part, _ in order for k in part] == list(range(23))
    assert [len(part) for part, _ in order] == [5, 5, 5, 5, 3]
    assert [first for _, first in order] == ["ours", "peer", "ours", "peer", "ours"]
    assert interleaved(0, 5) == []
    assert interleaved(3, 10) == [([0, 1, 2], "ours")]
    with pytest.raises(ValueError, match="chunk size"):
        interleaved(3, 0)
    with pytest.raises(ValueError, match="at least 0"):
        interleaved(-1, 3)


def test_run_tasks_runs_both_sides_chunk_by_chunk(monkeypatch):
    # five problems, one native and one Siconos solver, two tolerances, chunks of 2 problems:
    # per level, chunk {p0, p1} ours then Siconos, {p2, p3} Siconos then ours, {p4} ours then
    # Siconos; a pair that hit the time limit at 1e-4 is not run at 1e-8
    problems = generated_problems("manufactured", sizes=(2,), dims=(3,), seeds=(0, 1, 2, 3, 4))
    tasks = make_tasks(problems, ["nsgs", "siconos:nsgs"], [1e-4, 1e-8], time_limit=1.0)
    names = sorted({t.problem.name for t in tasks})
    calls = []

    def native(task, isolation=None):
        calls.append(("ours", task.tol, task.problem.name))
        status = "time_limit" if task.problem.name == names[0] else "converged"
        return base_record(task, status=status)

    def peer(batch):
        calls.append(("peer", batch[0].tol, tuple(t.problem.name for t in batch)))
        return [base_record(t, status="converged") for t in batch]

    monkeypatch.setattr(campaign, "run_one", native)
    monkeypatch.setattr(campaign, "run_siconos_batch", peer)
    recs = campaign.run_tasks(tasks, chunk=2)
    expected = []
    for tol in (1e-4, 1e-8):
        for part, first in (((0, 1), "ours"), ((2, 3), "peer"), ((4,), "ours")):
            mine = [("ours", tol, names[k]) for k in part if not (tol == 1e-8 and k == 0)]
            theirs = [("peer", tol, tuple(names[k] for k in part))]
            expected += mine + theirs if first == "ours" else theirs + mine
    assert calls == expected
    # one record per task, in task order, each for its own task
    assert [(r["problem"], r["tol"]) for r in recs] == [(t.problem.name, t.tol) for t in tasks]
    skipped = [r for r, t in zip(recs, tasks) if t.tol == 1e-8 and t.problem.name == names[0]
               and not t.solver.is_siconos]
    assert len(skipped) == 1 and skipped[0]["status"] == "time_limit"


def test_run_tasks_runs_a_siconos_task_its_batch_left_without_a_record(monkeypatch):
    # a Siconos worker that answers for fewer tasks than it was given (a batch cut short):
    # the tasks left without a record are run one by one (run_one), once each, at the end
    # of their level, and every task still gets exactly one record, its own
    problems = generated_problems("manufactured", sizes=(2,), dims=(3,), seeds=(0, 1, 2))
    tasks = make_tasks(problems, ["nsgs", "siconos:nsgs"], [1e-6], time_limit=1.0)
    single = []

    def native(task, isolation=None):
        if task.solver.is_siconos:
            single.append(task.problem.name)
        return base_record(task, status="converged")

    def short_peer(batch):
        return [base_record(t, status="converged") for t in batch[:-1]]

    monkeypatch.setattr(campaign, "run_one", native)
    monkeypatch.setattr(campaign, "run_siconos_batch", short_peer)
    recs = campaign.run_tasks(tasks, chunk=2)
    sic = sorted(t.problem.name for t in tasks if t.solver.is_siconos)
    assert single == [sic[1], sic[2]]   # the last of each chunk's batch ({0, 1}, then {2})
    assert [(r["problem"], r["solver"]) for r in recs] == [(t.problem.name, t.solver.label)
                                                            for t in tasks]
