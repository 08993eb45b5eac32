"""Cheap validation cases (short runs) must meet their stated tolerances."""
import pytest

from socp_cd.dynamics.cases import CASES

NSGS_CASES = ["pushed_particle", "block_incline", "sweeping", "bouncing_ball", "sliding_disk",
              "sliding_sphere", "rolling_incline", "box_stack", "newton_cradle", "block_incline_3d",
              "box_stack_3d", "tipping_box"]
CLARABEL_CASES = ["pushed_particle", "block_incline", "rolling_incline", "box_stack", "newton_cradle",
                  "box_stack_3d"]


def _check(rows):
    assert rows
    bad = [(r.case, r.quantity, r.exact, r.computed, r.error, r.tol) for r in rows if not r.passed]
    assert not bad, bad


@pytest.mark.parametrize("name", NSGS_CASES)
def test_case_nsgs(name):
    _check(CASES[name]("nsgs", quick=True))


@pytest.mark.parametrize("name", CLARABEL_CASES)
def test_case_clarabel(name):
    _check(CASES[name]("clarabel", quick=True))


def test_sticking_really_sticks_and_slipping_slips():
    # the exact values differ by construction: a wrong regime cannot pass
    rows = CASES["block_incline"]("nsgs", quick=True)
    stick, slip = rows
    assert stick.exact == 0.0 and abs(stick.computed) < 1e-8
    assert slip.exact > 1.0 and slip.passed


def test_tipping_box_topples_only_above_the_criterion():
    rows = CASES["tipping_box"]("nsgs", quick=True)
    rests = [r for r in rows if "rests" in r.case]
    topples = [r for r in rows if "topples" in r.case]
    assert len(rests) == len(topples) == 2
    assert all(abs(r.computed) < 1e-8 for r in rests)
    assert all(r.computed > 0.1 and r.passed for r in topples)
