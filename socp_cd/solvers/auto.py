"""``solver="auto"``: a portfolio that chains the built-in methods (the default of ``solve()``).

It models only what the problem requires and tries methods in an order chosen
from cheap problem features, handing the best iterate so far (the seed) to the next
method as its warm start (the De Saxcé fixed point only when that iterate is
close, :data:`WARM_MAX`) (rules and evidence: ``formulations/auto.md``):

* formulation ``"frictionless"``, or ``"coulomb"`` with every ``mu = 0``
  (then the two laws coincide): the QP of Signorini's law (Clarabel) when
  ``W`` is symmetric, else the LCP by projected Gauss–Seidel (NSGS); then
  Newton / NSGS on the law asked for;
* ``"associated"``: one SOCP (Clarabel), then NSGS;
* ``"tresca"``: NSGS, then Clarabel;
* ``"coulomb"`` (exact law): 2D local problems of at most :data:`LEMKE_MAX_NC` contacts,
  without ``r0``, first Lemke's method on the law's LCP (``"lemke"``,
  :mod:`socp_cd.solvers.lemke`; a refused answer of it is polished by Newton), then as
  below; local problems with at most :data:`SMALL_NC`
  contacts: NSGS (handing off after :func:`_handoff_cap` sweeps — or earlier,
  at the end of a window of :data:`HANDOFF_PREDICT` sweeps after which its rate
  predicts that the cap will not reach ``tol`` — to a trial of at most
  :data:`TRIAL_STEPS` plain Newton steps, then, on at most
  :data:`COLD_MAX_M` unknowns, plain Newton from ``r = 0`` for at most
  :data:`COLD_TRIAL_STEPS` steps (``"newton_trial_cold"``) and the proximal method from
  ``r = 0`` for at most :data:`COLD_PROX_STEPS` (``"newton_trial_prox"``), then going on from its
  own iterate when the trials fail: ``"newton_trial"``, after an early hand-off
  ``"nsgs_mid"`` up to the cap and a second trial, then ``"nsgs_rest"``), then the
  proximal semismooth Newton method
  (:mod:`socp_cd.solvers.newton`), plain Newton steps from its iterate and from
  ``r = 0``, the proximal method from ``r = 0`` with the proximal parameter
  :data:`ALT_ALPHA0` (``"newton_cold_alt"``), the Clarabel De Saxcé fixed point and
  Newton again (a proximal Newton stage that stops on a drift along the null space of
  ``W``, :data:`DRIFT_WINDOW`, is followed at once by the fixed point, from ``r = 0``:
  :data:`DRIFT_COLD`); larger local problems: an NSGS *probe* of
  :data:`PROBE_SWEEPS` sweeps first, going on up to :data:`PROBE_CAP` while
  NSGS's rate predicts ``tol`` (then Newton starts afresh unless the probe ended
  within :data:`WARM_MAX` without going on, :data:`PROBE_MISS_COLD`); 2D local
  problems of more than :data:`LARGE_2D_NC` contacts run the fixed point right after
  the probe, before Newton; 3D local ones whose contacts come in groups between the same two bodies
  (:func:`contact_redundancy` at least :data:`REDUNDANT_SHARE`: box faces) run a short
  fixed point (``"clarabel_first"``, at most :data:`REDUNDANT_FIRST_ITER` outer iterations)
  right after the probe, then the chain as without it; larger or global problems: Newton, then — ordered by friction
  range and dimension — NSGS and the fixed point, then Newton again from the
  best iterate when an earlier stage improved it.  When the order runs out without
  meeting ``tol`` on the exact law, *rounds* of :data:`ROUND` follow from the best iterate
  (a stage that starts from ``r = 0`` runs once) while each cuts the best error by
  :data:`ROUND_GAIN` (at most :data:`MAX_ROUNDS`, within the time budget; ``info["rounds"]``).
  When the rounds end too, a local exact-Coulomb problem gets a *last resort* with the time
  left (:data:`LAST_RESORT`): Siconos PROX's proximal point from ``r = 0``
  (``"newton_prox_error"``, newton's ``policy="prox_error"``).

The chain stops at the first stage whose error, recomputed from its ``r``
(compiled kernel :func:`~socp_cd.solvers.kernels.cone.siconos_error` for the
local Coulomb law, the NumPy law residual otherwise), meets ``tol`` and whose
units guard (:func:`socp_cd.residuals.guard`, the dispatcher's second test)
does too (on a local Coulomb problem, with Siconos' error of the problem as
written: the chain runs on the dispatcher's balanced copy, and the dispatcher
judges by that error first); after a stage that met the first and not the second, that stage runs
once more from the seed (:data:`RETRY_REFUSED`; after a Newton-family stage, and on the exact
Coulomb law after ``"lemke"``, ``"clarabel_first"`` and ``"clarabel"``, the warm proximal Newton
method:
:data:`REDUNDANT_RETRY`, :data:`CLARABEL_RETRY`) and the later stages aim at
the dispatcher's retry tolerance
(:func:`~socp_cd.solvers.options.tightened_tolerance`), a Newton stage among them stopping at
the first iterate that meets both (:data:`ACCEPT_STOP`).  The dispatcher
recomputes both once more independently.  Later stages start from the *seed*
(:data:`SEED_BY_GUARD`): the best iterate by the error, except that one within
``tol`` by the error ranks by the larger of the error and the guard, so an answer
the guard refuses by far is not a start; the chain also stops at a seed that meets
both measures.  The returned ``r`` is that seed when the chain converged, else the
best iterate of all stages by the error (never worse than any stage).

Options
-------
methods : sequence of str, optional
    Explicit stage order (names among ``"newton"``, ``"newton_plain"``,
    ``"newton_plain_cold"``, ``"newton_plain_cold_split"``, ``"newton_trial"``,
    ``"newton_trial_cold"``, ``"newton_trial_prox"``, ``"newton_cold_alt"``,
    ``"newton_prox_error"``, ``"nsgs"``,
    ``"nsgs_probe"``, ``"lemke"`` (2D, or the frictionless law), ``"clarabel"``
    and ``"clarabel_qp"`` (Clarabel on the frictionless QP))
    instead of the feature-based one (no hand-off then).

Common options (:mod:`socp_cd.solvers.options`): ``tol``; ``max_iter`` caps
*each* stage, in that stage's own units (Newton outer iterations, NSGS sweeps,
fixed-point outer iterations; None: each method's default); ``time_limit`` is
a *total* budget in seconds: each stage receives a share of what remains (the
last stage all of it) and no stage starts once it is spent; ``r0`` is the
warm start of the first stage (a small 2D problem's chain then starts with NSGS, not Lemke's
method, which has no warm start); ``inner_settings`` does not apply (stages run
with their own defaults) and is rejected when non-empty.  ``info["path"]``
lists every stage: ``{"method", "formulation", "iterations", "time", "error",
"status"}``; ``info["features"]`` the features the order was chosen from.
"""
from __future__ import annotations

import sys
import time
import types

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from ..laws import LAW_RESIDUALS, law_parameters
from ..problem import kernel_array
from ..residuals import guard
from . import checks, clarabel_backend, lemke, newton, nsgs, nsgs_route
from .kernels.cone import siconos_error
from .kernels.dense import csr_matvec_add
from .kernels.patterns import KEY_MULTIPLIER, pattern_redundancy
from .kernels.scaling import GUARD_KEYS, balanced_guard, origin_error
from .nsgs_route import (ERROR, GUARD_VALUE, INTERNAL_ERROR, MU_MAX, START_ERROR, SWEEPS,
                         ZERO_ERROR, guard_record, scaling_record)
from .options import MAX_ITER, tightened_tolerance
from .result import LazyInfo, SolverResult
from .scaling import balanced, origin
from .spec import SolverSpec

#: the message of a chain stopped by its time budget (without the budget's figure: after a
#: compiled route the chain runs on what the route left, which can be below zero)
BUDGET_SPENT = "time budget spent"
#: the clock of the time budget (a module attribute so tests can drive it)
_clock = time.perf_counter
#: :func:`plain`'s names for its kernel call, bound once (a module attribute's look-up costs
#: ~20 ns of a 5 µs call; ``_CLOCK`` is the compiled clock's module, read on each call; the
#: others are constants of their modules, which nothing sets: a study that did would have to
#: set these too)
_empty, _INF, _CLOCK = np.empty, float("inf"), nsgs_route.clock
_FLAT_ENTRIES, _N_OUT = nsgs_route.FLAT_ENTRIES, nsgs_route.N_OUT
_NSGS_MAX_ITER, _TIME_CHECK_SWEEPS = nsgs.DEFAULT_MAX_ITER, nsgs_route.TIME_CHECK_SWEEPS
_SWEEPS_OK = nsgs.DEFAULT_MAX_ITER <= MAX_ITER
#: local problems with at most this many contacts start with NSGS (2D ones of at most
#: LEMKE_MAX_NC, cold, with Lemke's method)
SMALL_NC = 100
#: 2D local exact-Coulomb problems with friction of at most this many contacts start a cold
#: call (no ``r0``: pivoting has no warm start; from an ``r0`` NSGS starts, as before) with
#: Lemke's method on the law's LCP (stage ``"lemke"``, :mod:`socp_cd.solvers.lemke`; session
#: 46, formulations/auto.md "Lemke's method first on small 2D problems"), then the small
#: chain; None or 0 (or less): off.  Its dense tableau costs ``O(nc²)`` a pivot and ~3 nc pivots
LEMKE_MAX_NC = 8
#: (a study knob, session 33; None: off) local exact-Coulomb problems of more than
#: NEWTON_FIRST_MIN_NC and at most SMALL_NC contacts whose ``W`` stores at least this many
#: ``dim x dim`` blocks per contact (``nnz(W) / (n_contacts dim²)``, :func:`_newton_first`)
#: start with the proximal Newton method capped at NEWTON_FIRST_STEPS outer iterations and
#: stopped after NEWTON_FIRST_STALL without a 10 % drop of the error (``"newton_first"``);
#: when it misses ``tol`` its iterate is kept as the best so far (the answer when nothing
#: else does better) but is not the seed: the small chain (NSGS, the hand-off, ...) starts
#: as without it (with half the time budget left, and the rounds' gain test reading a best
#: error that may be this stage's).
#: Session 32's feature study (validation/small_chain_features.py) estimated a gain on box
#: stacks; measured in session 33 on the tune split, 3D 11-100 contacts (151 cases, the 76 the
#: rule does not take at their times without it, unsolved as 2 s): sgm 0.00329 -> 0.00354 s;
#: of the 75 it takes, 27 slower than x1.2, 15 faster than x0.8; not adopted
#: (formulations/auto.md, "Newton first on box-stack-like problems")
NEWTON_FIRST_BLOCKS = None
NEWTON_FIRST_MIN_NC = 10
NEWTON_FIRST_STEPS = 10
NEWTON_FIRST_STALL = 2
#: friction coefficient from which the fixed point is tried before NSGS
HIGH_MU = 1.0
#: share of the remaining time budget a stage receives (the last stage: all)
STAGE_SHARE = 0.5
#: 3D local problems of more than SMALL_NC contacts, at least this share of which couple to
#: exactly the contacts another contact couples to (:func:`contact_redundancy`: several
#: contact points between the same two bodies, box faces), run the Clarabel fixed point first
#: (None: off).  Walls and towers of boxes at rest: ``q`` is off the range of the singular
#: ``W`` by 1e-7 ... 1e-6 (gaps), so which corner of a face opens is decided at that scale;
#: the interior point finds it where the Newton stages stall near ``tol`` or are refused by
#: the units guard.  Session 41, tune (``build_sim_collections.py --kinds --tune``, 1 s):
#: solved 24 -> 31 of 33, lost 1; formulations/auto.md, "Redundant contacts: the fixed
#: point first"
REDUNDANT_SHARE = 0.9
#: ... that stage (``"clarabel_first"``) stops after this many outer iterations of the fixed
#: point (on the tune walls and towers it solves in 1 or 2: 29 of 32; 3 took 10; on the Kapla
#: tower's manufactured cases, which it does not solve, a stage of half a 10 s budget made 17
#: at 1.7 s each); when it misses ``tol`` its iterate is not the seed (as ``newton_first``'s):
#: the chain after it starts as without it (Newton from its iterate at 4e-6 failed on a Kapla
#: case Newton solves from zero in 1.2 s)
REDUNDANT_FIRST_ITER = 2
#: 2D local problems with more contacts than this run the Clarabel fixed point right after
#: the NSGS probe, before Newton (granular deposits: ``validation/results/auto_order2d_tune.md``)
LARGE_2D_NC = 1000

#: ``"newton_plain"`` stages (Siconos NSN_AC's globalization, ``policy="plain"``): stop
#: after this many steps without a 10 % drop of the best error ...
PLAIN_STALL = 50
#: ... on problems outside the small local chain (more than SMALL_NC contacts, or global),
#: this many (a study knob, session 26: see formulations/auto.md, "The plain stages' stall
#: window"; None: PLAIN_STALL)
PLAIN_STALL_LARGE = None
#: ... and for ``"newton_plain_cold"`` alone on those problems, this many (None: as
#: ``"newton_plain"``).  Plain Newton from ``r = 0`` wanders among the contact branches, its
#: best error flat, before it converges, and how long depends on rounding (Capsules-i122
#: ``q x 1e-6``: 146 steps; copies with ``q`` perturbed by 1e-13: 51-258, or not in 300;
#: validation/results/cold_plain_lottery_s30.md).  200, the
#: cap: tune won 3 lost 0 at 10 s (none at 1 s), held out none won or lost, 3D sgm +1.3-1.6 %
#: (session 30; formulations/auto.md, "The cold plain stage's stall window")
COLD_PLAIN_STALL_LARGE = 200
#: outside the small local chain, after ``"newton_plain_cold"``, the same stage with the
#: Alart-Curnier parameters ``rho="split"`` (``"newton_plain_cold_split"``: a second draw of
#: the same method from ``r = 0``; False: off).  Session 30, tune: won 3 lost 1 at 1 s, won 2
#: lost 2 at 10 s, its losses a guard-refused answer that became the seed of later stages;
#: session 31, with SEED_BY_GUARD: won 3 lost 0 and won 3 lost 2 at 1 s (the two under a
#: loaded machine), won 2 lost 1 at 10 s (a Kapla case at the budget's edge); adopted
#: (formulations/auto.md, "Two iterates")
COLD_SPLIT = True
#: the iterate later stages start from (the *seed*): False, the best iterate by the stage
#: judge's error (Siconos' error), the one returned when no stage meets ``tol``; True, the
#: same, except that an iterate within ``tol`` by that error ranks by the larger of the error
#: and the units guard's value.  On a rank-deficient ``W`` a stage can end at a tiny error
#: with an impulse large in ``W``'s null space, which the guard refuses: ranked by the error
#: alone it became every later stage's start (Capsules-i125 μ = 2 mixed, session 30).  With
#: the knob the chain also stops at a seed that meets both measures, and returns it
#: (formulations/auto.md, "Two iterates")
SEED_BY_GUARD = True
#: (a study knob, session 31's review; False: off) after a refused answer, tighten the later
#: stages' tolerance only when that answer is the seed they start from
TIGHTEN_FROM_SEED = False
#: ... and after at most this many steps (unless ``max_iter`` is given)
PLAIN_MAX_ITER = 200
#: local exact-Coulomb problems with more than SMALL_NC contacts start with an NSGS
#: *probe* of at most this many sweeps (0: no probe); problems dumped from simulations
#: are often solved by NSGS in a few sweeps, where Newton's set-up and factorizations
#: cost 10x more (formulations/auto.md)
PROBE_SWEEPS = 30
#: the probe goes on past PROBE_SWEEPS, up to this cap, while NSGS's rate over the last
#: :data:`PROBE_PREDICT` sweeps predicts that the cap reaches ``tol`` (NSGS's option
#: ``predict_window``: the small chain's early hand-off turned around, there it stops NSGS
#: early, here it lets the probe run on; None: off, the probe's PROBE_SWEEPS alone; session
#: 45, formulations/auto.md "The probe goes on where NSGS's rate predicts tol")
PROBE_CAP = 300
#: ... the window of that prediction (two windows: the probe's first verdict comes at
#: PROBE_SWEEPS, so a probe the prediction stops is the probe as before)
PROBE_PREDICT = 15
#: ... and a probe that went on past PROBE_SWEEPS and missed ``tol`` counts as far (Newton
#: then starts afresh): NSGS slowed down where its rate had promised more, and Newton from
#: such an iterate took 17 instead of 7 steps on a capsule pile (False: the WARM_MAX rule)
PROBE_MISS_COLD = True
#: local exact-Coulomb problems with at most SMALL_NC contacts start with NSGS capped at
#: this many sweeps (None: NSGS's own default, 1000); NSGS runs again, uncapped, from the
#: best iterate as the chain's last stage (formulations/auto.md, "The first NSGS stage")
SMALL_SWEEPS = None
#: ... and with this stall window (NSGS's option: sweeps without a 1 % drop of the error
#: before it stops; None: NSGS's default, 5000, more than its 1000 sweeps)
SMALL_STALL = None
#: the NSGS hand-off on local exact-Coulomb problems of at most SMALL_NC contacts (None:
#: off): NSGS stops after this many sweeps; when it has not met ``tol``, a short trial of
#: plain Newton steps (at most TRIAL_STEPS, stopped after TRIAL_STALL steps without a 10 %
#: drop of the error) starts from its iterate, and when the trial fails NSGS goes on from
#: *its own* iterate for the rest of its sweeps (``"nsgs_rest"``), so the trial costs at most
#: TRIAL_STEPS Newton steps and NSGS loses nothing (formulations/auto.md, "The hand-off")
HANDOFF_SWEEPS = 200
#: ... and at least this many visits of stored entries of W (see _handoff_cap)
HANDOFF_WORK = 32000
TRIAL_STEPS = 6
TRIAL_STALL = 2
#: ... and NSGS hands over earlier, at the end of any window of this many sweeps after which
#: the error's mean rate over the window predicts that the hand-off's sweeps will not reach
#: ``tol`` (NSGS's option ``predict_window``; 0: off), on problems of at most
#: PREDICT_MAX_M unknowns (a compiled, cheap trial); when that early trial
#: fails, NSGS goes on from its own iterate to the cap (``"nsgs_mid"``) and a second trial
#: follows there, as without the prediction: a failed early trial costs its steps
HANDOFF_PREDICT = 20
#: a stage whose answer meets ``tol`` by the stages' measure and not by the units guard runs
#: once more (a Newton-family stage, and a fixed point's on the exact Coulomb law, as the warm
#: proximal Newton method: :data:`REDUNDANT_RETRY`, :data:`CLARABEL_RETRY`), from the seed
#: (that answer when it is refused by little enough to be the seed,
#: :data:`SEED_BY_GUARD`; else the run is skipped as already made from that start, unless
#: :data:`RERUN_TIGHTER` lets a fixed point go on), aiming at the tightened tolerance (the
#: dispatcher's retry,
#: :func:`~socp_cd.solvers.options.tightened_tolerance`, done by the chain itself)
RETRY_REFUSED = True
#: (measured, not adopted: ``validation/results/auto_chain_tune.md``) on small local problems,
#: Newton starts afresh (``r = 0``, cold proximal parameter) after NSGS's stages end farther
#: than ``WARM_MAX``, as after a far probe on larger ones: BoxesStack ×0.13-0.25, PerioBox
#: ×8-10 and one case lost on the tune split
FAR_NSGS_COLD = False
#: (measured, not adopted, same study) rate-prediction window of the hand-off's ``nsgs_rest``
#: stage (0: off): NSGS going on after a failed trial stopped early when its rate predicted
#: ``tol`` out of reach; NSGS's rate on PerioBox is not linear: two cases lost
REST_PREDICT = 0
#: after the hand-off's first trial fails on a problem of at most COLD_MAX_M
#: unknowns, plain Newton from ``r = 0`` (Siconos NSN_AC's method) for at most this many steps,
#: stopped after COLD_TRIAL_STALL steps without a 10 % drop of the error (0: off)
COLD_TRIAL_STEPS = 30
COLD_TRIAL_STALL = 10
#: the cold trials run on problems of at most this many unknowns (``m = dim * n_contacts``;
#: session 13: newton.COMPILED_LOOP_MAX_M = 72, where the whole Newton loop is compiled; 150
#: chosen on the tune split, 300 lost a case and cost PerioBox x3-12:
#: validation/results/auto_chain_tune_coldm.md, formulations/auto.md "Cold trials on larger
#: problems")
COLD_MAX_M = 150
#: the hand-off's rate prediction (HANDOFF_PREDICT) on problems of at most this many unknowns
#: (newton.COMPILED_LOOP_MAX_M of session 13, the compiled trials' bound then; 300 measured on
#: the tune split: no change, not adopted; session 24, 300 again with the tune box stacks
#: of validation/evalset_sim_small_tune: 3D 11-100 contacts 8 cases slower than ×1.2, 10
#: faster than ×0.8, sgm 10 ms shift ×1.02, 0.1 ms shift ×0.97, none won or lost, not
#: adopted: validation/results/auto_chain_tune_s24pred.md; session 52, 150: tune 3D sgm x0.98,
#: 9 faster / 4 slower, held out 3D x0.99, 11 / 10, 2D x0.86, none won or lost: not adopted,
#: formulations/auto.md "The hand-off's rate prediction up to 150 unknowns")
PREDICT_MAX_M = 72
#: ... and when that fails too, the proximal Newton method from ``r = 0`` for at most this many
#: outer iterations (same stall window; 0: off): box stacks with redundant contacts, where plain
#: Newton fails and the proximal method converges (formulations/auto.md, "The proximal cold
#: trial").  With session 20's looser subproblem test (not adopted: newton.INNER_GATE), an
#: outer iteration is ~1 LU instead of 2-3; 30 and 45 measured on the tune split with it:
#: no case won or lost, sgm within 0.5 % (validation/results/auto_chain_tune_s20prox.md)
COLD_PROX_STEPS = 15
#: the order of the two cold trials: False, plain Newton from ``r = 0`` first, then the
#: proximal method; True, the proximal method first (a study knob, see
#: :func:`_cold_trial_order`)
COLD_PROX_FIRST = False
#: study knob (None: off; session 52): after an *early* hand-off (the rate prediction stopped
#: NSGS before its cap) whose trial failed, on problems of more than this many unknowns the
#: cold trials wait: NSGS goes on to the cap (``"nsgs_mid"``) and its second trial runs first,
#: the cold trials after it when that fails too.  With PREDICT_MAX_M above 72 an early
#: iterate (errors 1e-3 ... 1e-2) fails its trial on some box stacks and dominoes steps where
#: NSGS's cap hands one trial a good iterate, and the cold trials from zero cost 2-11 ms there.
#: Tune split with PREDICT_MAX_M = 150 and 72 here: 3D sgm 0.01512 -> 0.01514 s, the 38-contact
#: stacks still x1.2-1.5 of the default chain's time: not adopted (formulations/auto.md, "The
#: hand-off's rate prediction up to 150 unknowns")
EARLY_COLD_MAX_M = None
#: stall window of the proximal Newton stages (None: the method's default, 50 outer iterations
#: without a 10 % drop of the error).  Measured, not adopted (validation/results/
#: auto_chain_{tune,holdout}_stall.md): 30 solved 2 more on tune and lost none, but held out
#: it won 2 (Capsules, time-limited) and lost 2 (BoxesStack1, PerioBox)
NEWTON_STALL = None
#: when the stage order ends without meeting ``tol`` on the exact Coulomb law and the best
#: error fell by at least ROUND_GAIN over the last ``len(ROUND)`` stages run, the chain goes on
#: with one more *round* of these stages from the best iterate, and again after each round
#: that cut the best error by that factor, at most MAX_ROUNDS rounds (0: off) and never past
#: the time budget: on manufactured Capsules cases the last stages were still cutting the
#: error by 10-30x when the order ran out with 80-90 % of a 10 s budget unspent
#: (formulations/auto.md, "Rounds"; chosen on the tune split,
#: validation/results/auto_rounds_tune.md: 1 s 115 -> 116 of 128 solved, 10 s 116 -> 118)
ROUND = ("nsgs", "newton", "clarabel", "newton")
#: after the plain stages of the exact-Coulomb order, the proximal Newton method once more
#: from ``r = 0`` with this relative proximal parameter (``"newton_cold_alt"``; None: off):
#: session 13's default, 1, where the order's Newton stages start warm or with
#: ``newton.COLD_ALPHA0`` (0.1 since session 14: more cases solved, not the same ones)
ALT_ALPHA0 = 1.0
ROUND_GAIN = 1.1
MAX_ROUNDS = 8
#: in the small local chain, the Clarabel fixed point right after the first proximal Newton
#: stage, before the plain and cold Newton stages (False: after them, as in the large
#: chain).  A study knob (session 48), measured and not adopted: on the toppled dominoes of
#: the fifth scene draw (``build_sim_collections.py --new-kinds``) the proximal stage stalls at
#: 2e-8 ... 3e-6 and the plain and cold stages cost 7-190 ms each before the fixed point; the
#: knob cut that draw's sgm by 11 % but won no case there, on the tune split or held out
#: (validation/results/auto_chain_{tune_s48newkinds,tune_s48early,holdout_s48early}.md)
SMALL_CLARABEL_EARLY = False
#: the proximal Newton stages (``"newton"``) of the small local chain stop after DRIFT_WINDOW
#: outer iterations in a row of null-space drift (newton's ``drift_window``: solved
#: subproblems, the error flat, steps in the null space of ``W``; ``formulations/newton.md``
#: §7; None: off), and a stage stopped so is followed by the Clarabel fixed point when the
#: order has it later (the stages between then follow it), started from ``r = 0`` when
#: DRIFT_COLD (else from the seed, as :func:`_starts_cold` says); DRIFT_ANY_SIZE: the stop
#: at any size, not only in the small chain.  Session 50 (formulations/auto.md, "The
#: null-space drift stop"): found on the toppled dominoes of the first new-kinds draw, where
#: the proximal stage drifted for 50-150 outer iterations and the fixed point from its seed
#: stalled at 1e-7 ... 3e-6 (from zero it met 1e-8).  On a fourth draw built before the rule
#: was run on it (``build_sim_collections.py --new-kinds-fresh3``; 3D, 11-100 contacts, 60
#: steps): solved 57 -> 58, sgm (10 ms) 0.0248 -> 0.0183 s; tune split and held out: no case
#: won or lost; at any size it cost up to x5 on held-out Capsules and pentagons (a drift that
#: would have converged after it), so it stays in the small chain
#: (validation/results/auto_chain_{tune,holdout}_s50*.md)
DRIFT_WINDOW = 5
DRIFT_ANY_SIZE = False
DRIFT_COLD = True
#: after a drift stop the fixed point runs next (from ``r = 0`` with DRIFT_COLD) and the
#: order's own fixed point also stays in its place, where it starts from the seed when that is
#: within WARM_MAX (False: moved, session 50's rule).  Session 52, adopted: the tune case
#: PerioBox mu = 0.1 mixed, lost at 1 s since the drift stop, solved in 0.57-0.77 s; held out
#: (504 problems of at most 100 contacts) no path changed, on three new-kinds draws (161) 4
#: paths changed, none won or lost (formulations/auto.md, "The PerioBox case lost since the
#: drift stop")
DRIFT_KEEP_WARM = True
#: in the small local chain (and in an explicit ``methods`` order on such a problem, as the
#: drift rule), a fixed point (exact Coulomb law) that started from an iterate and missed
#: ``tol`` is followed at once by the fixed point from ``r = 0``, once per call and only when no
#: fixed point has run from ``r = 0`` in it (False: off).  Found on a step of the dominoes scene
#: (validation/evalset_sim_newkinds/dominoes3d-16.toml, step 1369, warm-started by the stepper,
#: max_iter 3000) where NSGS, Newton and the warm fixed point all stall at 2.4e-6 (tol 1e-6)
#: and the fixed point from zero meets 2.4e-9 in 9 iterations; the scene's one unconverged
#: step is gone.  Session 52, adopted: tune (283 problems of at most 100 contacts) no path
#: changed; held out (665) one won (a dominoes step, unsolved at 1 s -> 0.36 s), none lost,
#: 5 paths changed
#: (formulations/auto.md, "A warm fixed point that missed tol: the cold one next")
FP_COLD_AFTER_WARM = True
#: the last resort of a local exact-Coulomb problem that the order and its rounds leave
#: unsolved with time left: Siconos PROX's proximal point (``"newton_prox_error"``, newton's
#: ``policy="prox_error"``) from ``r = 0``, with the rest of the budget, at most
#: PROX_ERROR_MAX_ITER outer iterations (PROX's default cap) and a stall window of
#: PROX_ERROR_STALL (False: off), once per call (when it cuts the best error without meeting
#: tol, a round may follow it, by the rounds' own rule).  A problem the order solves never
#: reaches it (same path and time); on the capsule piles the chain ended after 1-4 s of a
#: 10 s budget, stalled at 1e-8 ... 1e-6 or at answers the units guard refused, where
#: Siconos PROX solved them (formulations/auto.md, "The last resort")
LAST_RESORT = True
PROX_ERROR_MAX_ITER = 1000
PROX_ERROR_STALL = 100
#: study knob (False: off): on local problems of more than SMALL_NC contacts (3D, or 2D up to
#: LARGE_2D_NC), ``"newton_prox_error"`` right after the first Newton stage instead of only
#: as the last resort (formulations/auto.md, "The last resort")
PROX_EARLY = False
#: the stage a ``"clarabel_first"`` answer that meets ``tol`` by the error and not by the
#: units guard runs next (:data:`RETRY_REFUSED`): ``"newton"``, the warm proximal Newton
#: method from it, the chain's polish (with :data:`ACCEPT_STOP`); ``"clarabel"`` (until
#: session 43), the whole fixed point once more, an interior point that a warm start does not
#: shorten.  Session 43 (``validation/auto_chain.py``, 1 s, 3D local problems of more than 100
#: contacts, with ACCEPT_STOP; formulations/auto.md, "After a refused clarabel_first"): tune
#: 57 -> 58 solved of 65, held out 108 -> 112 of 142, of which the fourth draw of the kinds
#: (built before the rule was chosen, looked at after) 32 -> 34 of 35
REDUNDANT_RETRY = "newton"
#: the values :data:`REDUNDANT_RETRY` and :data:`CLARABEL_RETRY` may take
#: (``"newton+clarabel"``: the warm Newton stage, then, when it fails, the fixed point at the
#: tightened tolerance; after a refused ``"clarabel"`` answer that did not become the seed the
#: fixed point's retry has the start it already ran from, so it runs only with
#: :data:`RERUN_TIGHTER`)
REDUNDANT_RETRIES = ("newton", "clarabel", "newton+clarabel")
#: a stage is not run twice from the same start (the chain's ``ran`` record), unless it is
#: the fixed point (:data:`COLD_STAGES`) on the exact Coulomb law and its earlier run ended by
#: meeting a stage tolerance looser than the one the stages now aim at (tightened after a
#: guard refusal): a fixed point that stopped at ``tol`` with an answer the guard refused then
#: goes on to the tightened tolerance, once per start (a rerun is not rerun: each round could
#: otherwise tighten and rerun it again, up to the rounds' cap, on the whole budget) (False:
#: skipped as already run, until session 51; a Newton stage's rerun from a start it already
#: ran from stays skipped, as RETRY_REFUSED's tests hold; formulations/auto.md, "A refused
#: fixed point, retried at the tightened tolerance")
RERUN_TIGHTER = True
#: the same for an answer of the chain's own ``"clarabel"`` stage (the fixed point to its
#: end) refused by the units guard, on the exact Coulomb law: ``"newton"`` (since session 44),
#: or ``"clarabel"``, the fixed point once more at the tightened tolerance (other laws: always
#: that).  On 2D deposits at rest (the large-2D order: the fixed point right after the probe)
#: Clarabel's answers at 8e-11 ... 8e-9 were refused and the second interior point cost
#: 0.10-0.46 s; on the four tune deposits at rest it ended where the first had, and the Newton
#: stage after it was accepted after one outer iteration.  Session 44
#: (``validation/auto_chain.py``, 1 s; formulations/auto.md, "After a refused clarabel
#: answer"): tune deposits of 2 001-3 000 contacts sgm 0.73 -> 0.49 s (the 4 at rest
#: x0.39-0.42, none lost); held out, the benchmark's simulation collections: the 8 deposits at
#: rest x0.34-0.71, sgm of the 31 2D cases 0.35 -> 0.30 s; no other path changed, on tune or
#: held out
CLARABEL_RETRY = "newton"
#: a Newton-family stage aiming at a tolerance tightened after a guard refusal stops at the
#: first outer iterate the chain's judge accepts (both of the dispatcher's checks, newton's
#: ``accepted`` hook), instead of going on towards that tolerance, a stand-in for the checks
#: (on the towers of planks it ran 30-50 more outer iterations at its accuracy floor)
ACCEPT_STOP = True
#: stage name -> (spec, solver-specific options passed to it)
_STAGES = {
    "lemke": (lemke.SPEC, {}),
    "newton": (newton.SPEC, {}),
    "newton_first": (newton.SPEC, {}),     # + NEWTON_FIRST_STEPS (first, small dense W)
    "nsgs_probe": (nsgs.SPEC, {}),
    "newton_plain": (newton.SPEC, {"policy": "plain"}),     # + PLAIN_STALL, PLAIN_MAX_ITER
    "newton_plain_cold": (newton.SPEC, {"policy": "plain"}),    # (read when the stage runs)
    "newton_plain_cold_split": (newton.SPEC, {"policy": "plain", "rho": "split"}),
    "nsgs": (nsgs.SPEC, {}),
    "newton_trial": (newton.SPEC, {"policy": "plain"}),    # + TRIAL_STALL, TRIAL_STEPS
    "newton_trial_cold": (newton.SPEC, {"policy": "plain"}),   # + COLD_TRIAL_* (from r = 0)
    "newton_trial_prox": (newton.SPEC, {}),     # + COLD_PROX_STEPS, COLD_TRIAL_STALL (r = 0)
    "newton_cold_alt": (newton.SPEC, {}),       # + alpha0 = ALT_ALPHA0 (r = 0)
    "newton_prox_error": (newton.SPEC, {"policy": "prox_error"}),   # + PROX_ERROR_* (r = 0)
    "nsgs_mid": (nsgs.SPEC, {}),
    "nsgs_rest": (nsgs.SPEC, {}),
    "clarabel": (clarabel_backend.SPEC, {}),
    "clarabel_first": (clarabel_backend.SPEC, {}),     # + REDUNDANT_FIRST_ITER (first)
    "clarabel_qp": (clarabel_backend.SPEC, {}),
}
#: stages started cold unless the best iterate's error is at most WARM_MAX: the De
#: Saxcé fixed point's first shift from a far iterate (4e-4, 7e-3) cost accuracy on the
#: tune split, from a close one (4e-6) it helped (formulations/auto.md)
COLD_STAGES = ("clarabel", "clarabel_first", "clarabel_qp")
WARM_MAX = 1e-5
#: stages that cannot stop within a short time limit: Clarabel reads the clock between
#: interior-point iterations, and one iteration (or its set-up) of a large problem can take
#: seconds (a 7 177-contact 2D deposit: 3.6 s against a 0.05 s limit). Under a time budget,
#: such a stage does not start again when its earlier run in this call took longer than
#: all the time left (the refused stage's retry overran a 1 s budget by 4 s)
SLOW_TO_STOP = ("clarabel", "clarabel_first", "clarabel_qp")
#: ... and, before its first run in a call, such a stage does not start (after the first stage)
#: with less than this share of the budget left (0: off): its set-up and first iteration are
#: not interruptible (Kapla tower, 1710 unknowns: the fixed point started with 0.03 s of a 1 s
#: budget left and returned after 0.18 s).  Chosen on the tune split (266 local problems, up
#: to 2000 contacts): at 1 s, 0.1 lost no case and cut the Kapla case's 1.80 s to 1.05 s, 0.2
#: lost two Capsules cases the fixed point solved in the last 10-20 % of the budget; at 0.1 s
#: none lost (validation/results/auto_chain_tune_s22slow{,01}.md)
MIN_SLOW_START = 0.1
#: stages always started from ``r = 0`` (or the caller's ``r0`` when first)
ALWAYS_COLD = ("newton_plain_cold", "newton_plain_cold_split", "newton_trial_cold",
               "newton_trial_prox", "newton_cold_alt", "newton_prox_error")
#: the hand-off's cold trials (run only after a failed first trial, on m <= COLD_MAX_M)
_COLD_TRIALS = ("newton_trial_cold", "newton_trial_prox")
#: first stages whose iterate, when it misses ``tol``, is not the seed (the chain after them
#: runs as without them)
_FIRST_STAGES = ("newton_first", "clarabel_first", "lemke")
#: stages of the Newton method: a refused answer of one is retried as ``"newton"`` (warm)
_NEWTON_FAMILY = tuple(name for name, (spec, _) in _STAGES.items() if spec is newton.SPEC)
#: stages with their own stall window (:data:`PLAIN_STALL`, :data:`PLAIN_STALL_LARGE`) and,
#: when ``max_iter`` is None, iteration cap (:data:`PLAIN_MAX_ITER`), read when the stage runs
_CAPPED = ("newton_plain", "newton_plain_cold", "newton_plain_cold_split")
#: share of the remaining budget of the (cheap, trial) plain stages, instead of STAGE_SHARE
PLAIN_SHARE = 0.25
#: the least time limit a stage is given (:func:`_stage_limit`'s rule, written out in
#: :func:`plain`), seconds
_MIN_STAGE_LIMIT = 1e-6
#: (read-only: :func:`plain`'s plan keeps the NSGS stage's entry, or STAGE_SHARE)
_SHARES = types.MappingProxyType({"newton_plain": PLAIN_SHARE, "newton_plain_cold": PLAIN_SHARE,
                                  "newton_plain_cold_split": PLAIN_SHARE,
                                  "newton_trial": PLAIN_SHARE, "newton_trial_cold": PLAIN_SHARE,
                                  "newton_trial_prox": PLAIN_SHARE})

OPTIONS = {
    "methods": "explicit stage order, names among 'newton', 'newton_plain', 'newton_plain_cold', "
               "'newton_plain_cold_split', 'newton_trial', 'newton_trial_cold', 'newton_trial_prox', 'newton_cold_alt', 'newton_prox_error', "
               "'nsgs', 'nsgs_probe', 'lemke' (2D, or the frictionless law), "
               "'clarabel', 'clarabel_first' (the fixed point stopped after REDUNDANT_FIRST_ITER outer "
               "iterations; its iterate is not the seed when it misses tol), 'clarabel_qp' "
               "(default: chosen from the problem's features); a stage whose answer the units "
               "guard refuses is followed by its retry, which on the exact Coulomb law is 'newton' "
               "after a Newton-family, a fixed-point or the 'lemke' stage (RETRY_REFUSED), "
               "listed or not",
    "threshold": "Tresca threshold per contact (formulation 'tresca')",
}


def contact_redundancy(problem, compiled: bool = True) -> float:
    """Share of the contacts of a local problem whose coupling pattern looks like another's.

    Contact ``i`` *couples* to contact ``j`` when ``W`` stores a block ``W_ij`` (the two share
    a body).  Several contact points between the same two bodies (the corners of a box's face
    on another) couple to the same contacts; no two contacts of a sphere pile do.  A pattern
    is read from the first row of the contact in ``W``'s CSR form by its signature: the
    number of stored entries and the first, middle and last column, mixed into one key.
    Equal patterns have equal signatures; unequal ones rarely do (sphere piles: 0–0.2, box
    walls and towers: 1.0).  A contact coupled to every contact (a full row: a dense ``W``)
    is not counted.  ``O(n_contacts)``: no pass over the entries of ``W``.

    Parameters
    ----------
    problem : FrictionContactProblem
        A local problem (read: ``csr_parts``, ``dim``, ``n_contacts``).
    compiled : bool
        True: the compiled kernel (:func:`~.kernels.patterns.pattern_redundancy`); False:
        this NumPy reference (the same keys and share; ``tests/test_auto.py``).

    Returns
    -------
    float
        In ``[0, 1]``; 0 for fewer than two contacts or a contact with an empty row.
    """
    indptr, indices, _ = problem.csr_parts
    d, nc = problem.dim, problem.n_contacts
    if compiled:
        return pattern_redundancy(indptr, indices, nc, d)
    if nc < 2:
        return 0.0
    starts = indptr[0:nc * d:d].astype(np.int64)
    ends = indptr[1:nc * d + 1:d].astype(np.int64)
    lengths = ends - starts
    if np.any(lengths <= 0):
        return 0.0
    mult = np.uint64(KEY_MULTIPLIER)
    key = lengths.astype(np.uint64)
    for part in (indices[starts], indices[(starts + ends) // 2], indices[ends - 1]):
        key = key * mult + part.astype(np.uint64)
    counted = lengths < nc * d       # a full row says nothing about the contact's bodies
    if np.count_nonzero(counted) < 2:
        return 0.0
    _, inverse, repeats = np.unique(key[counted], return_inverse=True, return_counts=True)
    return float(np.count_nonzero(repeats[inverse] > 1)) / nc


def features(problem, formulation) -> dict:
    """Cheap features the stage order is chosen from (no allocation of size ``m``² or rank test).

    Returns
    -------
    dict
        ``dim``, ``n_contacts``, ``global``, ``mu_max``, ``frictionless``
        (every ``mu = 0``), ``structurally_rank_deficient`` (global problems
        with more contact unknowns than degrees of freedom, ``m > n``: then
        ``W = Hᵀ M⁻¹ H`` is singular; None for local problems, whose rank is not
        tested) and ``redundancy`` (:func:`contact_redundancy`, for 3D local problems of
        more than :data:`SMALL_NC` contacts when :data:`REDUNDANT_SHARE` is on; else None).
    """
    mu = problem.mu
    mu_max = float(mu.max()) if mu.shape[0] else 0.0
    glob = problem.is_global
    return {"dim": problem.dim, "n_contacts": problem.n_contacts, "global": glob,
            "mu_max": mu_max, "frictionless": formulation == "frictionless" or mu_max == 0.0,
            "structurally_rank_deficient": (problem.m > problem.n_dofs) if glob else None,
            "redundancy": _redundancy_feature(problem)}


def _redundancy_feature(problem):
    """:func:`features`' ``redundancy``: :func:`contact_redundancy` of a 3D local problem of
    more than :data:`SMALL_NC` contacts while :data:`REDUNDANT_SHARE` is on, else None."""
    if (problem.is_global or problem.dim != 3 or problem.n_contacts <= SMALL_NC
            or REDUNDANT_SHARE is None):
        return None
    return contact_redundancy(problem)


def lemke_bound() -> int:
    """The most contacts of a 2D local problem whose cold call starts with ``"lemke"``:
    :data:`LEMKE_MAX_NC` (None: 0), within :data:`SMALL_NC` (the small chain it heads) and the
    backend's bound (``lemke.MAX_UNKNOWNS``, four LCP unknowns a contact); the one test of
    :func:`stage_order`, :func:`route` and :func:`plain`."""
    bound = LEMKE_MAX_NC
    if bound is None:
        return 0
    if not isinstance(bound, (int, np.integer)) or isinstance(bound, bool):
        raise InvalidProblemError("auto.LEMKE_MAX_NC", f"must be an int or None, got {bound!r}")
    return max(0, min(int(bound), SMALL_NC, lemke.MAX_UNKNOWNS // 4))


def _lemke_sized(dim, nc) -> bool:
    """Whether a local problem of dimension ``dim`` with ``nc`` contacts is one whose cold
    chain starts with ``"lemke"``: 2D, at most :func:`lemke_bound` contacts (the test of
    :func:`_lemke_first`, :func:`route` and :func:`plain`)."""
    return dim == 2 and 0 < nc <= lemke_bound()


def _lemke_first(feats) -> bool:
    """Whether the chain of the problem of ``feats`` starts with ``"lemke"`` on a cold call:
    a local problem :func:`_lemke_sized` (with friction: the frictionless law's order comes
    first in :func:`stage_order`)."""
    return not feats["global"] and _lemke_sized(feats["dim"], feats["n_contacts"])


def _small_local(feats) -> bool:
    """Whether the problem of ``feats`` (:func:`features`) takes the small local chain: a
    local problem of at most :data:`SMALL_NC` contacts (NSGS first, the hand-off)."""
    return feats["n_contacts"] <= SMALL_NC and not feats["global"]


def _newton_first(problem) -> bool:
    """Whether the small local chain of ``problem`` starts with ``"newton_first"``
    (:data:`NEWTON_FIRST_BLOCKS`): more than :data:`NEWTON_FIRST_MIN_NC` and at most
    :data:`SMALL_NC` contacts, and at least that many stored ``dim x dim`` blocks of ``W`` per
    contact, counted as ``nnz(W) / (n_contacts dim²)`` (no pass over ``W``)."""
    blocks = NEWTON_FIRST_BLOCKS
    if blocks is None or problem.is_global:
        return False
    nc, d = problem.mu.shape[0], problem.dim
    return (NEWTON_FIRST_MIN_NC < nc <= SMALL_NC
            and int(problem.csr_parts[0][-1]) >= blocks * nc * d * d)


def _redundant(feats) -> bool:
    """Whether the large 3D local problem of ``feats`` (:func:`features`) has redundant contacts
    (:func:`contact_redundancy` at least :data:`REDUNDANT_SHARE`): its chain runs
    ``"clarabel_first"`` after the probe."""
    share = feats.get("redundancy")
    return share is not None and REDUNDANT_SHARE is not None and share >= REDUNDANT_SHARE


def stage_order(problem, formulation, feats) -> tuple:
    """Stage names ``(method, formulation)`` for ``problem`` (rules: ``formulations/auto.md``)."""
    if feats["frictionless"] and formulation in ("coulomb", "frictionless"):
        first = ("clarabel_qp", "frictionless") if problem.is_symmetric else ("nsgs", "frictionless")
        rest = ((("newton", "coulomb"), ("nsgs", "coulomb")) if formulation == "coulomb"
                else (("nsgs", "frictionless"),))
        return (first,) + tuple(s for s in rest if s != first)
    if formulation == "associated":
        return (("clarabel", "associated"), ("nsgs", "associated"))
    if formulation == "tresca":
        return (("nsgs", "tresca"), ("clarabel", "tresca"))
    # exact Coulomb law: Newton first (fastest and most robust on the tune split);
    # high friction or 2D: the fixed point before NSGS
    # right after the first (proximal) Newton stage: plain nonmonotone Newton steps from
    # its iterate, then from r = 0 (Siconos NSN_AC's method; formulations/auto.md)
    plain = (("newton_plain", "coulomb"), ("newton_plain_cold", "coulomb"))
    if COLD_SPLIT and not _small_local(feats):
        plain = plain + (("newton_plain_cold_split", "coulomb"),)
    if ALT_ALPHA0 is not None:
        plain = plain + (("newton_cold_alt", "coulomb"),)
    if _small_local(feats):
        # small local problems: NSGS first (one contact: one call of its local solver);
        # it costs a fraction of Newton's set-up and factorizations (formulations/auto.md)
        last = ((("nsgs", "coulomb"),) if (SMALL_SWEEPS, SMALL_STALL) != (None, None) else ())
        # the hand-off's stages: listed whenever it is on; auto_backend skips them when the
        # cap for this call (_handoff_cap with the caller's max_iter) leaves no sweeps to hand off
        # (nsgs_mid and the second trial run only after an early hand-off whose trial failed)
        cold = tuple((name, "coulomb") for name in _cold_trial_order())
        # (EARLY_COLD_MAX_M: listed again after the second trial, where they run when they
        # waited; else skipped there as already run from the same start)
        handoff = ((("newton_trial", "coulomb"),) + cold
                   + (("nsgs_mid", "coulomb"), ("newton_trial", "coulomb"))
                   + (cold if EARLY_COLD_MAX_M is not None else ())
                   + (("nsgs_rest", "coulomb"),)
                   if HANDOFF_SWEEPS is not None and not last else ())
        first = (("newton_first", "coulomb"),) if _newton_first(problem) else ()
        if _lemke_first(feats):
            first = (("lemke", "coulomb"),) + first
        fixed_point = (("clarabel", "coulomb"),)
        middle = fixed_point + plain if SMALL_CLARABEL_EARLY else plain + fixed_point
        return (first + (("nsgs", "coulomb"),) + handoff + (("newton", "coulomb"),) + middle
                + (("newton", "coulomb"),) + last)
    if feats["mu_max"] >= HIGH_MU or feats["dim"] == 2:
        middle = (("clarabel", "coulomb"), ("nsgs", "coulomb"))
    else:
        middle = (("nsgs", "coulomb"), ("clarabel", "coulomb"))
    probe = (("nsgs_probe", "coulomb"),) if PROBE_SWEEPS > 0 and not feats["global"] else ()
    if feats["dim"] == 2 and feats["n_contacts"] > LARGE_2D_NC and not feats["global"]:
        # large 2D local problems (granular deposits): Newton stalls on them for most of the
        # budget, the fixed point solves them (tuning deposit: 9 -> 15 of 20 at 1 s; 17 = 17
        # at 5 s, sgm 2.7 -> 0.74 s)
        return (probe + (("clarabel", "coulomb"), ("newton", "coulomb")) + plain
                + (("nsgs", "coulomb"), ("newton", "coulomb")))
    # redundant contacts (box faces): a short run of the fixed point right after the probe,
    # then the chain as without it ("Redundant contacts: the fixed point first")
    first = ((("clarabel_first", "coulomb"),) if _redundant(feats) else ())
    early = ((("newton_prox_error", "coulomb"),) if PROX_EARLY and not feats["global"]
             else ())
    return (probe + first + (("newton", "coulomb"),) + early + plain + middle
            + (("newton", "coulomb"),))


_GUARD_VALUE = GUARD_KEYS.index("value")


class _Judge:
    """Stage error of an ``r`` for the law asked for (compiled kernel on local Coulomb problems;
    on global ones the dispatcher's compiled checks, :mod:`socp_cd.solvers.checks`), and its
    units-guard value, the dispatcher's second test (:meth:`guard_value`)."""

    def __init__(self, problem, formulation, params, tol):
        self.problem, self.formulation, self.params, self.tol = problem, formulation, params, tol
        self.fast = formulation == "coulomb" and not problem.is_global
        if self.fast:
            self.q = kernel_array(problem.q)        # (the balanced copy's q is read-only)
            self.mu = np.ascontiguousarray(problem.mu, dtype=np.float64)
            self.norm_q = float(np.sqrt(np.dot(self.q, self.q)))
            self.origin = origin(problem)   # (a, b, ||q||) on the dispatcher's balanced copy
        # a global Coulomb problem reaches auto as written: the dispatcher's own checks, with the
        # unit factors it keeps on the problem (the NumPy guard cost 250 us a call, on a
        # one-contact problem more than the Newton stage); not when M is singular
        self.global_checks = False
        if formulation == "coulomb" and problem.is_global:
            try:
                balanced(problem)
                self.global_checks = True
            except InvalidProblemError:
                pass

    def _global_velocity(self, r):
        with np.errstate(all="ignore"):
            u = checks.velocity(self.problem, r)
        return u if np.all(np.isfinite(u)) else None

    def guard_value(self, r) -> float:
        """The units guard's value of ``r`` (:func:`socp_cd.residuals.guard`, the dispatcher's
        second test of an answer; ``inf`` when it cannot be evaluated).

        A local problem reaches ``auto`` in balanced units (the dispatcher's): its guard is
        the compiled one with unit factors 1.  Without this test a stage whose Siconos
        error met ``tol`` ended the chain with an answer the dispatcher then refused (a
        global 1-contact problem, ``W, q`` times 1e-6: error 3.6e-12, guard 2.3e-6).
        On the dispatcher's balanced copy (:func:`~socp_cd.solvers.scaling.origin`) the
        value is also at least the dispatcher's first test, Siconos' error of the problem as
        written (:func:`~socp_cd.solvers.kernels.scaling.origin_error`): a stage within
        ``tol`` in balanced units only is refused here, as the dispatcher would refuse it
        (and then run the whole chain once more).
        """
        if self.fast:
            indptr, indices, data = self.problem.csr_parts
            ones = np.ones(self.problem.m)
            u = csr_matvec_add(indptr, indices, data, r, self.q)
            finite, out = balanced_guard(r, u, ones, ones, self.mu, self.problem.dim, self.norm_q)
            if not finite:
                return np.inf
            value = float(out[_GUARD_VALUE])
            if self.origin is not None:
                a, b, q_norm = self.origin
                e = float(origin_error(r, u, a, b, self.mu, self.problem.dim, q_norm))
                value = e if not e <= value else value      # (NaN: not met)
            return value if np.isfinite(value) else np.inf
        if self.global_checks:
            u = self._global_velocity(r)
            value = np.inf if u is None else float(checks.coulomb_guard(self.problem, r,
                                                                        u)["value"])
            return value if np.isfinite(value) else np.inf
        with np.errstate(all="ignore"):
            value = float(guard(self.problem, r, law=LAW_RESIDUALS[self.formulation],
                                **self.params)["value"])
        return value if np.isfinite(value) else np.inf

    def __call__(self, r) -> float:
        if r is None or r.shape != (self.problem.m,) or not np.all(np.isfinite(r)):
            return np.inf
        if self.fast:       # compiled: an overflow ends as inf, silently
            indptr, indices, data = self.problem.csr_parts
            e = siconos_error(r, csr_matvec_add(indptr, indices, data, r, self.q), self.mu,
                              self.problem.dim, self.norm_q)
        elif self.global_checks:
            u = self._global_velocity(r)
            e = np.inf if u is None else checks.coulomb_error(self.problem, r, u)
        else:
            with np.errstate(all="ignore"):
                e = LAW_RESIDUALS[self.formulation](self.problem, r, None, **self.params)
        e = float(e)
        return e if np.isfinite(e) else np.inf

    def accepts(self, r) -> bool:
        """Whether ``r`` meets ``tol`` by both of the dispatcher's checks (the stage error and
        :meth:`guard_value`): a Newton stage's ``accepted`` hook (:data:`ACCEPT_STOP`)."""
        return self(r) <= self.tol and self.guard_value(r) <= self.tol


def check(problem, options, inner_settings) -> None:
    """Reject ``inner_settings`` (not applicable) and a bad ``methods`` list before any work."""
    if inner_settings:
        raise UnsupportedError("solver 'auto': inner_settings does not apply (each stage runs with "
                               "its own defaults); choose a solver to pass native settings")
    methods = options.get("methods")
    if methods is not None:
        if isinstance(methods, str) or not hasattr(methods, "__iter__"):
            raise InvalidProblemError("methods", f"must be a sequence of stage names, got {methods!r}")
        methods = tuple(methods)
        # (the hand-off's stages, and the study knob's first stage: not a user's stage)
        valid = sorted(set(_STAGES) - {"nsgs_mid", "nsgs_rest", "newton_first"})
        bad = [m for m in methods if m not in valid]
        if bad or not methods:
            raise InvalidProblemError("methods", f"stage names must be among {valid}, "
                                                 f"got {list(methods)!r}")


def _small_knobs():
    """``(SMALL_SWEEPS, SMALL_STALL)``, checked: None, or an int >= 1 (sweeps) / >= 0 (window)."""
    if SMALL_SWEEPS is None and SMALL_STALL is None:      # the default (the compiled route's path)
        return None, None
    for name, value, least in (("SMALL_SWEEPS", SMALL_SWEEPS, 1), ("SMALL_STALL", SMALL_STALL, 0)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                  or value < least):
            raise ValueError(f"socp_cd.solvers.auto.{name} must be None or an int >= {least}, "
                             f"got {value!r}")
    return SMALL_SWEEPS, SMALL_STALL


def _handoff_cap(problem, max_iter):
    """Sweeps of the first NSGS stage under the hand-off (None: off).

    At least :data:`HANDOFF_SWEEPS` sweeps and at least :data:`HANDOFF_WORK`
    visits of stored entries of ``W`` (``sweeps * nnz(W)``): on a problem of a
    few contacts a sweep costs well under a microsecond, and a Newton trial
    costs what thousands of them do.  Deterministic (no clock), so the compiled
    route and the general path hand off at the same sweep.
    """
    cap = HANDOFF_SWEEPS
    if cap is None or SMALL_SWEEPS is not None or SMALL_STALL is not None:
        return None
    if isinstance(cap, bool) or not isinstance(cap, int) or cap < 1:
        raise ValueError(f"socp_cd.solvers.auto.HANDOFF_SWEEPS must be None or an int >= 1, "
                         f"got {cap!r}")
    total = nsgs.DEFAULT_MAX_ITER if max_iter is None else max_iter
    m = problem.m
    if m * m * total <= HANDOFF_WORK:
        return None     # nnz(W) <= m^2: the cap would be at least ``total`` (one contact)
    nnz = max(int(problem.csr_parts[0][-1]), 1)
    cap = max(cap, -(-int(HANDOFF_WORK) // nnz))
    return cap if cap < total else None     # no sweeps left to hand off: NSGS as without it


def _predict_window(problem):
    """The hand-off's rate-prediction window for ``problem`` (:data:`HANDOFF_PREDICT`,
    checked: an int >= 0): 0 on problems of more than :data:`PREDICT_MAX_M` unknowns,
    where (until session 15) a Newton trial ran the Python loop and a failed early trial
    cost what hundreds of sweeps do."""
    w = HANDOFF_PREDICT
    if type(w) is not int or w < 0:         # (a bool is not an int here)
        raise ValueError(f"socp_cd.solvers.auto.HANDOFF_PREDICT must be an int >= 0, got {w!r}")
    return w if problem.m <= PREDICT_MAX_M else 0


def _cold_trial_order() -> tuple:
    """The hand-off's cold trials in the order they run (:data:`COLD_PROX_FIRST`); the stage
    order and the compiled route's trials (:func:`_compiled_trials`) both read it."""
    return tuple(reversed(_COLD_TRIALS)) if COLD_PROX_FIRST else _COLD_TRIALS


def _cold_steps(method):
    """Step cap of a cold trial stage (:data:`COLD_TRIAL_STEPS`, :data:`COLD_PROX_STEPS`; 0: off)."""
    return COLD_TRIAL_STEPS if method == "newton_trial_cold" else COLD_PROX_STEPS


def _cold_trials_wait(problem, status, sweeps, cap) -> bool:
    """Whether the cold trials wait for ``nsgs_mid``'s trial (:data:`EARLY_COLD_MAX_M`): the
    hand-off's first NSGS stage ended early (``status`` ``"max_iter"`` after ``sweeps`` of its
    ``cap``) on a problem of more than that many unknowns."""
    return (EARLY_COLD_MAX_M is not None and cap is not None and status == "max_iter"
            and sweeps < cap and problem.m > EARLY_COLD_MAX_M)


def _plain_stall(method, small):
    """Stall window of a plain stage (:data:`PLAIN_STALL`; outside the small local chain
    :data:`PLAIN_STALL_LARGE`, and :data:`COLD_PLAIN_STALL_LARGE` for the cold ones)."""
    if small:
        return PLAIN_STALL
    if method != "newton_plain" and COLD_PLAIN_STALL_LARGE is not None:
        return COLD_PLAIN_STALL_LARGE
    return PLAIN_STALL if PLAIN_STALL_LARGE is None else PLAIN_STALL_LARGE


def _small_cap(max_iter):
    """Sweeps of the first NSGS stage on a small local problem (:data:`SMALL_SWEEPS`)."""
    cap, _ = _small_knobs()
    if cap is None:
        return max_iter
    return cap if max_iter is None else min(cap, max_iter)


def route(problem, *, tol, max_iter, r0, time_limit):
    """The compiled route of a plain ``auto`` call (``SolverSpec.route``).

    On a local exact-Coulomb problem with friction the chain starts with NSGS
    (at most :data:`SMALL_NC` contacts) or the NSGS probe (more); that stage
    and the dispatcher's checks of its answer run in one compiled call
    (:func:`socp_cd.solvers.nsgs_route.run`, within its bounds).  When NSGS
    misses ``tol`` and hands over, the hand-off's Newton trials run compiled
    too where they can (:func:`_compiled_trials`).

    Returns
    -------
    tuple or None
        ``(result, guard_value, resume)``: the result :func:`auto_backend`
        would give when the NSGS stage, or a trial after it, meets ``tol``
        (after NSGS alone its ``info`` a
        :class:`~socp_cd.solvers.result.LazyInfo`, built on first read:
        :func:`_route_info`), the units guard's value and None; otherwise
        ``(None, None, resume)`` (for the rest of the chain: the
        dispatcher calls :func:`auto_backend` with ``resume=``): ``{"r": NSGS's
        iterate, "stage": its path record, "trials": the trials run, each
        ``{"r", "stage", "warm"}``}``.  None when
        the route does not apply, or when the stage does not improve on
        ``r0`` (the general path then keeps ``r0`` as its best iterate).
    """
    # the chain's first stage on a local problem with friction (stage_order): NSGS, or on
    # more than SMALL_NC contacts the NSGS probe (_probe_plan: its cap and prediction)
    nc = problem.mu.shape[0]
    if r0 is None and _lemke_sized(problem.dim, nc):
        return None         # a cold chain starts with Lemke's method (plain runs it compiled)
    stall, handoff, predict = None, (0, 0), 0
    if nc <= SMALL_NC:
        if NEWTON_FIRST_BLOCKS is not None and _newton_first(problem):
            return None     # the chain starts with Newton (auto_backend; off: no call)
        method, cap = "nsgs", max_iter
        if SMALL_SWEEPS is not None or SMALL_STALL is not None:    # a study's knobs
            cap, stall = _small_cap(max_iter), _small_knobs()[1]
        elif HANDOFF_SWEEPS is not None:
            # the hand-off's cap, computed in the compiled call (_handoff_cap's rule: a
            # Python call here cost 0.85 us, a tenth of a one-contact call)
            if not (type(HANDOFF_SWEEPS) is int and HANDOFF_SWEEPS >= 1):
                _handoff_cap(problem, max_iter)         # raises, naming the constant
            handoff = (HANDOFF_SWEEPS, int(HANDOFF_WORK))
            predict = _predict_window(problem)
    elif PROBE_SWEEPS > 0:
        method = "nsgs_probe"
        cap, predict = _probe_plan(max_iter)
    else:
        return None
    t0 = _clock()
    # (the stage's share of the budget, as auto_backend gives it)
    out = nsgs.compiled_run(problem, tol, cap, r0, _stage_limit(method, time_limit), True,
                            stall, handoff, predict)
    if out is None:
        return None
    return _stage_outcome(problem, out, method, handoff, tol, max_iter, time_limit, t0)


def _probe_plan(max_iter):
    """``(sweep cap, prediction window)`` of the NSGS probe under the caller's ``max_iter``
    (None: none): :data:`PROBE_SWEEPS` sweeps and no prediction, or with :data:`PROBE_CAP`
    set, up to that cap with NSGS's rate prediction over :data:`PROBE_PREDICT` sweeps."""
    cap = PROBE_SWEEPS if PROBE_CAP is None else max(int(PROBE_CAP), PROBE_SWEEPS)
    return min(cap, max_iter or cap), 0 if PROBE_CAP is None else int(PROBE_PREDICT)


def _went_on_and_missed(sweeps, status, err, tol) -> bool:
    """:data:`PROBE_MISS_COLD`'s rule: a probe that went on past :data:`PROBE_SWEEPS` under
    :data:`PROBE_CAP` (``sweeps`` of them, ending ``status`` at the judge's error ``err``)
    missed ``tol`` where NSGS's rate had promised it (not cut by the time limit)."""
    return (PROBE_MISS_COLD and PROBE_CAP is not None and 0 < PROBE_SWEEPS < sweeps
            and status != "time_limit" and not err <= tol)


def _stage_limit(method, left):
    """The time limit of stage ``method`` that is not the order's last, ``left`` seconds of
    the budget left (None: no limit): its share of them (:data:`_SHARES`, else
    :data:`STAGE_SHARE`), at least 1 µs; :func:`auto_backend`'s rule, and the compiled
    route's for its NSGS stage and its trials."""
    if left is None:
        return None
    limit = _SHARES.get(method, STAGE_SHARE) * left
    # (max(limit, _MIN_STAGE_LIMIT) without max's call: 0.07 µs)
    return _MIN_STAGE_LIMIT if limit < _MIN_STAGE_LIMIT else limit


def plain(problem, tol, time_limit, t0):
    """The whole plain ``solver="auto"`` call (``SolverSpec.plain``): :func:`route`'s work
    with ``max_iter`` and ``r0`` None, and on a small problem whose NSGS stage meets
    ``tol`` clear of the stop test's margin, the dispatcher's verdict too.

    On at most :data:`SMALL_NC` contacts with the hand-off's default knobs (the common
    case: a time step of a small scene, a benchmark's tiny problem), the NSGS stage's
    compiled call is made here and, when its three measures (the stage judge's error, the
    units guard's value and Siconos' error as written) are all at most ``tol *
    (1 - JUDGE_MARGIN)``, the result is returned judged: ``converged``, with the
    ``solver``, ``formulation``, ``tol`` and ``time`` (since ``t0``) the dispatcher would
    set (:func:`socp_cd.solvers.registry._routed`'s verdict is "converged" on such
    measures).  The layers between :func:`socp_cd.solve` and the compiled call cost ~3 µs
    of a ~6 µs one-contact call.  Otherwise the route's outcome (``(result,
    guard_value, resume)`` or None) for the dispatcher to judge, as :func:`route` returns
    it.  The answer is the route's, bit for bit (``tests/test_route.py``)."""
    dim = problem.dim
    nc = problem.mu.shape[0]
    if _lemke_sized(dim, nc):
        return _lemke_plain(problem, nc, tol, time_limit, t0)
    plan = _PLANS.get(dim)
    if plan is None:
        plan = small_plan(dim)
    if plan is False or nc > plan[0] or nc == 0 or nc > nsgs_route.MAX_CONTACTS:
        # a study's knobs (or a bad value, which route reports), a larger problem, or one
        # beyond the compiled route's bounds (nsgs_route.run_prepared's, read on each call)
        return route(problem, tol=tol, max_iter=None, r0=None, time_limit=time_limit)
    # (nsgs.compiled_run's call, two layers less: NSGS's defaults, its sweep cap, the
    # prediction window by _predict_window's rule; the stage's share of the budget by
    # _stage_limit's rule, its factor in the plan; the stage starts at the call's t0: a clock
    # read less, 0.06 µs)
    if time_limit is None:
        left = _INF
    else:
        if not _CLOCK.AVAILABLE:    # (nsgs_route.run_prepared's bounds for a timed call)
            return route(problem, tol=tol, max_iter=None, r0=None, time_limit=time_limit)
        left = plan[5] * time_limit       # (the stage's limit; the chain after it has the rest)
        if left < _MIN_STAGE_LIMIT:
            left = _MIN_STAGE_LIMIT
    # the flat kernel's call (run_prepared's, within its bounds: nc <= MAX_CONTACTS above,
    # NSGS's sweep cap <= options.MAX_ITER, checked by small_plan, the compiled clock
    # above): the kernel boxes the five numbers judged here, not its stats tuple, and writes
    # r~, r, u and the stats into one array (a row of it costs less than a slice). Called
    # here, not through a function of nsgs_route: 0.3 µs of a 5 µs call
    indptr, indices, data = problem.csr_parts
    q = problem.q
    m = q.shape[0]
    out = _empty((3 - (-_N_OUT // m), m))          # (nsgs_route.flat_rows(m), without a call)
    kernel = _FLAT_ENTRIES.get(indptr.dtype) if indices.dtype is indptr.dtype else None
    got = (kernel or nsgs_route.flat_entry(indptr, indices))(
        indptr, indices, data, q, problem.mu, plan[3] if m <= plan[1] else plan[4], False, tol,
        time_limit is not None, left, out)
    if got[0] < 0:          # (a declined problem, or an answer the checks cannot judge)
        return None
    code, sweeps, stage_error, error, guard_value, zero_error = got
    lo = tol * _JUDGE_LO
    # (_stage_outcome's first tests: START_ERROR is inf without r0, so a stage whose
    # measures pass is always an improvement; on such measures registry._routed's verdict is
    # "converged", keep the two in step)
    if stage_error <= lo and guard_value <= lo and error <= lo:
        s = _clock() - t0
        return SolverResult.of_local(out[1], out[2], "converged", error, sweeps,
                                     LazyInfo((_flat_route_info, dim, nc, out, "nsgs", s, code)),
                                     "nsgs met tol", zero_error <= tol, True, "auto",
                                     "coulomb", tol, s)
    return _stage_outcome(problem, nsgs_route.flat_outcome(got, out), "nsgs", plan[2], tol, None,
                          time_limit, t0)


def _lemke_plain(problem, nc, tol, time_limit, t0):
    """:func:`plain` on a 2D problem whose chain starts with ``"lemke"`` (:func:`_lemke_first`):
    the stage and the dispatcher's checks in one compiled call
    (:func:`~socp_cd.solvers.nsgs_route.lemke_checked_flat`, the general path's kernels on the
    same arrays: the same answer); the judged result when its three measures are clear of
    ``tol`` as in :func:`plain`, else the stage handed on as :func:`route`'s resume (the chain
    goes on from the second stage, the stage's time counted), or None when the kernel
    declined (all ``mu = 0``, non-finite answers: the general path from the start)."""
    blocked = time_limit is not None
    if (blocked and not _CLOCK.AVAILABLE) or nc > nsgs_route.MAX_CONTACTS:
        return None     # (the compiled route's bounds, as for NSGS: the general path)
    indptr, indices, data = problem.csr_parts
    m = problem.q.shape[0]
    out = _empty((3 - (-_N_OUT // m), m))
    # (through its entry point: numba's dispatcher would type the 9 arguments on each call)
    got = nsgs_route.lemke_entry(indptr, indices)(
        indptr, indices, data, problem.q, problem.mu, lemke.pivot_cap(4 * nc, None), blocked,
        _stage_limit("lemke", time_limit) if blocked else 0.0, out)
    code, pivots, stage_error, error, guard_value, zero_error = got
    if code < 0:
        return None
    s = _clock() - t0
    lo = tol * _JUDGE_LO
    if stage_error <= lo and guard_value <= lo and error <= lo:
        return SolverResult.of_local(out[1], out[2], "converged", error, pivots,
                                     LazyInfo((_flat_route_info, 2, nc, out, "lemke", s, code)),
                                     "lemke met tol", zero_error <= tol, True, "auto",
                                     "coulomb", tol, s)
    # (the stage's record as the route's NSGS resume makes it: _route_info of the stats)
    stage = _flat_route_info(2, nc, out, "lemke", s, code)["path"][0]
    return None, None, {"r": out[0], "stage": stage, "trials": []}


#: :func:`plain`'s small call in dimension ``d``, prepared once (:func:`small_plan`); emptied
#: when one of :data:`_PLAN_KNOBS` is set (:class:`_Knobs`)
_PLANS = {}
#: the knobs :func:`small_plan` reads
_PLAN_KNOBS = frozenset({"SMALL_NC", "SMALL_SWEEPS", "SMALL_STALL", "HANDOFF_SWEEPS",
                         "HANDOFF_WORK", "HANDOFF_PREDICT", "PREDICT_MAX_M", "STAGE_SHARE",
                         "NEWTON_FIRST_BLOCKS"})


def small_plan(dim):
    """:func:`plain`'s small call in dimension ``dim`` from the knobs as they are, recorded in
    :data:`_PLANS`: ``(SMALL_NC, PREDICT_MAX_M, handoff, settings with the prediction window,
    settings without, the NSGS stage's share of the budget)`` (the settings
    :func:`~socp_cd.solvers.nsgs_route.flat_settings`' vectors of NSGS's sweep cap, the first
    block of a timed run and :func:`~socp_cd.solvers.nsgs_route.prepared`'s tail), or False
    when a study's knob (or a bad value, which :func:`route` reports) sends every call through
    :func:`route`.  Making these per call cost ~0.7 µs of a ~6 µs one-contact call."""
    w = HANDOFF_PREDICT
    try:
        work = int(HANDOFF_WORK)
    except (TypeError, ValueError, OverflowError):
        work = None
    if (SMALL_SWEEPS is not None or SMALL_STALL is not None or type(HANDOFF_SWEEPS) is not int
            or HANDOFF_SWEEPS < 1 or type(w) is not int or w < 0 or work is None
            or not _SWEEPS_OK or NEWTON_FIRST_BLOCKS is not None):
        # (_SWEEPS_OK: plain's kernel call within nsgs_route.run_prepared's bounds;
        # NEWTON_FIRST_BLOCKS: route applies _newton_first's rule)
        plan = False
    else:
        handoff = (HANDOFF_SWEEPS, work)
        settings = nsgs.route_settings(dim)
        try:
            flat = [nsgs_route.flat_settings(dim, _NSGS_MAX_ITER, _TIME_CHECK_SWEEPS,
                                             nsgs_route.prepared(settings, True, handoff, win))
                    for win in (w, 0)]
        except ValueError:      # (a study's knob beyond float64's exact integers)
            flat = None
        plan = (False if flat is None else
                (SMALL_NC, PREDICT_MAX_M, handoff, flat[0], flat[1],
                 _SHARES.get("nsgs", STAGE_SHARE)))
    _PLANS[dim] = plan
    return plan


class _Knobs(types.ModuleType):
    """This module's type: setting or deleting one of :data:`_PLAN_KNOBS` (a study, a test's
    ``monkeypatch``) empties :data:`_PLANS`, so :func:`plain` reads the knobs as they are.
    (Knobs are set between calls: a plan made in one thread while another sets a knob
    may outlive the change.)"""

    def __setattr__(self, name, value):
        super().__setattr__(name, value)
        if name in _PLAN_KNOBS:
            _PLANS.clear()

    def __delattr__(self, name):
        super().__delattr__(name)
        if name in _PLAN_KNOBS:
            _PLANS.clear()


sys.modules[__name__].__class__ = _Knobs


def _stage_outcome(problem, out, method, handoff, tol, max_iter, time_limit, t0):
    """:func:`route` after its first stage's compiled call ``out`` (``method``, started at
    ``t0``): the route's outcome (see there)."""
    status, vectors, x = out
    nc = problem.mu.shape[0]
    stage_error = x[INTERNAL_ERROR]         # the stage judge's measure (to rounding)
    if not stage_error < x[START_ERROR]:
        return None
    t = _clock() - t0
    sweeps = int(x[SWEEPS])
    # auto_backend's stop test (_Judge: its error, and its guard value: the guard and the
    # error as written), read on the route's own measures of the same quantities when they are
    # clear of tol (they differ from the judge's in the last digits), else on the judge's
    lo = tol * _JUDGE_LO
    if stage_error <= lo and x[GUARD_VALUE] <= lo and x[ERROR] <= lo:
        stop = met = True
    else:
        stop, met = _stop_test(problem, out, tol, lo)
    if stop:
        # (the probe's problems, more than SMALL_NC contacts: features' redundancy, read
        # when the info is)
        return (SolverResult.of_local(vectors[1], vectors[2], "converged", x[ERROR], sweeps,
                                      LazyInfo((_route_info, problem.dim, nc, x, method, t,
                                                status,
                                                problem if method == "nsgs_probe" else None)),
                                      "nsgs met tol", x[ZERO_ERROR] <= tol),
                x[GUARD_VALUE], None)
    # (handed on: auto_backend reads its features itself; or the small chain's trials' answer)
    info = _route_info(problem.dim, nc, x, method, t, status)
    trials = []
    if (handoff[0] and not met and problem.m <= nsgs_route.TRIAL_MAX_M
            and _handoff_cap(problem, max_iter) is not None
            and newton.compiled_loop_takes(problem)):
        # the hand-off's trials, compiled too (_compiled_trials), when the chain runs them
        done = _compiled_trials(problem, out, tol, max_iter, time_limit, t0)
        if done:
            last, tx = done[-1]["stage"], done[-1]["stats"]
            # auto_backend's stop test (the judge's error and guard value), then the verdict's
            if last["error"] <= tol and done[-1]["judge_guard"] <= tol:
                vec = done[-1]["vectors"]
                info["path"] += [d["stage"] for d in done]
                info.update(best_stage=done[-1]["k"], guard=guard_record(tx),
                            scaling=scaling_record(tx))
                its = sweeps + sum(d["stage"]["iterations"] for d in done)
                return (SolverResult.of_local(vec[1], vec[2], "converged", tx[ERROR], its,
                                              info, f"{last['method']} met tol",
                                              tx[ZERO_ERROR] <= tol), tx[GUARD_VALUE], None)
            trials = [{"r": d["vectors"][0], "stage": d["stage"], "warm": d["warm"]}
                      for d in done]
    return None, None, {"r": vectors[0], "stage": info["path"][0], "trials": trials}


def _stop_test(problem, out, tol, lo):
    """``(stop, met)`` of auto_backend's test after the route's NSGS stage ``out`` when its
    measures are not all at most ``lo`` (below ``tol`` by :data:`JUDGE_MARGIN`): ``met`` the
    judge's error within ``tol``, ``stop`` its guard value too; on the judge's own measures
    (:func:`~socp_cd.solvers.nsgs_route.trial_outcome`) when one of the route's lies within
    the margin of ``tol``."""
    x = out.stats
    e, g, w = x[INTERNAL_ERROR], x[GUARD_VALUE], x[ERROR]
    hi = tol * (2.0 - _JUDGE_LO)
    if any(lo < v <= hi for v in (e, g, w)):
        judged = nsgs_route.trial_outcome(problem, nsgs_route.judge_norm(problem), out.status,
                                          out.vectors[0])
        if judged is not None:
            met = judged[0].stats[INTERNAL_ERROR] <= tol
            return met and judged[1] <= tol, met
    return e <= tol and g <= tol and w <= tol, e <= tol


#: relative distance to tol within which the compiled route reads auto_backend's stop test on
#: the stage judge's own measures of NSGS's iterate (nsgs_route.trial_outcome, ~2 us), not on
#: the route's measures of the same quantities (computed in another order: they differ by up
#: to ~1e-6 relative on heavy/light problems)
JUDGE_MARGIN = 1e-4
_JUDGE_LO = 1.0 - JUDGE_MARGIN      # (per call: one multiplication)

#: the hand-off's trials the compiled route can run: method -> (from NSGS's iterate, proximal)
_ROUTE_TRIALS = {"newton_trial": (True, False), "newton_trial_cold": (False, False),
                 "newton_trial_prox": (False, True)}


def _compiled_trials(problem, out, tol, max_iter, time_limit, t0):
    """The hand-off's Newton trials after the compiled route's NSGS stage ``out``, compiled
    (:func:`socp_cd.solvers.newton.compiled_runs`: the Newton backend's runs), in
    :func:`stage_order`'s order and under
    :func:`auto_backend`'s rules (the cold trials only after a failed first trial, on at most
    :data:`COLD_MAX_M` unknowns, with their step caps, not after an early hand-off when
    :data:`EARLY_COLD_MAX_M` makes them wait): the list of those run, each
    ``{"stage": its path record, "vectors", "stats", "warm", "k" (its index in the stage
    order), "judge_guard"}``, up to the first whose error
    meets ``tol`` by the stages' measure (the chain decides what follows it), or before one
    whose checks are not finite (the chain runs it and what follows)."""
    done = []
    constants = newton.trial_constants()
    wait = _cold_trials_wait(problem, out.status, int(out.stats[SWEEPS]),
                             _handoff_cap(problem, max_iter))
    for k, method in enumerate(("newton_trial",) + _cold_trial_order(), start=1):
        warm, prox = _ROUTE_TRIALS[method]
        if method == "newton_trial":
            steps, stall = TRIAL_STEPS, TRIAL_STALL
        else:
            steps, stall = _cold_steps(method), COLD_TRIAL_STALL
            if not steps or problem.m > COLD_MAX_M or wait:
                continue
        if max_iter is not None:
            steps = min(max_iter, steps)
        if time_limit is not None and _clock() - t0 >= time_limit:
            break
        t1 = _clock()
        start = out.vectors[0].copy() if warm else np.zeros(problem.m)
        # the Newton backend's runs (newton.continued_runs: on the dispatcher's balanced copy
        # a run that meets tol there and not as written goes on), its default settings
        # (norm_q -1: ||q~||, judge_norm's value, computed in the trial's compiled call)
        # (the trial's share of the budget left, as auto_backend gives it)
        ran = newton.compiled_runs(problem, -1.0, start, tol, steps, prox=prox,
                                   stall_window=stall, constants=constants,
                                   time_left=_stage_limit(method, None if time_limit is None
                                                          else time_limit - (t1 - t0)))
        if ran is None or ran[3] is None:
            break
        its = ran[1]
        tout, judge_guard = ran[3]
        tx = tout.stats
        done.append({"stage": {"method": method, "formulation": "coulomb", "iterations": its,
                               "time": _clock() - t1, "error": tx[INTERNAL_ERROR],
                               "status": tout.status},
                     "vectors": tout.vectors, "stats": tx, "warm": warm, "k": k,
                     "judge_guard": judge_guard})
        if tx[INTERNAL_ERROR] <= tol:
            break
    return done


def _route_info(dim, nc, x, method, seconds, status, probed=None) -> dict:
    """``result.info`` of :func:`route`'s result: the stage ``method`` (its ``status``,
    ``seconds``) from the compiled call's stats tuple ``x``
    (:data:`~socp_cd.solvers.nsgs_route.STATS`) on a problem of ``nc`` contacts
    (``probed``: the problem of an NSGS probe, whose :func:`features` carry a
    ``redundancy``; None on the small chain's problems, whose value is None)."""
    stage = {"method": method, "formulation": "coulomb", "iterations": int(x[SWEEPS]),
             "time": seconds, "error": x[INTERNAL_ERROR], "status": status}
    return {"path": [stage],
            "features": {"dim": dim, "n_contacts": nc, "global": False, "mu_max": x[MU_MAX],
                         "frictionless": False, "structurally_rank_deficient": None,
                         "redundancy": (None if probed is None
                                        else _redundancy_feature(probed))},
            "best_stage": 0, "guard": guard_record(x), "scaling": scaling_record(x),
            "route": "compiled"}


def _flat_route_info(dim, nc, out, method, seconds, code) -> dict:
    """:func:`_route_info` of :func:`plain`'s flat call (``out``, ``code``:
    :func:`~socp_cd.solvers.nsgs_route.nsgs_checked_flat`'s array and code)."""
    return _route_info(dim, nc, nsgs_route.flat_stats(out), method, seconds,
                       nsgs_route.STATUS_NAMES[code])


def _starts_cold(method, k, seed_err) -> bool:
    """Whether stage ``k`` (``method``) starts from ``r = 0`` (the first stage starts from the
    caller's ``r0``): :data:`ALWAYS_COLD`, or :data:`COLD_STAGES` while the seed's error is above
    :data:`WARM_MAX`."""
    return k > 0 and (method in ALWAYS_COLD
                      or (method in COLD_STAGES and not seed_err <= WARM_MAX))


def _seed_score(judge, r, err, tol) -> float:
    """The rank of ``r`` (stage judge's error ``err``) as the chain's seed, least first
    (:data:`SEED_BY_GUARD`): ``err``; with the knob, an ``r`` within ``tol`` by ``err``
    ranks by the larger of ``err`` and the units guard's value, so that one the guard
    refuses ranks by how far it is refused (``inf`` without an iterate).  Iterates farther
    than ``tol`` keep their rank by the error: ranked by the guard there too, the chain's
    warm starts changed on held-out cases (OneObject ×6.5 slower; formulations/auto.md)."""
    if r is None or not err < np.inf:
        return np.inf
    if not (SEED_BY_GUARD and err <= tol):
        return err
    g = judge.guard_value(r)
    return err if err >= g else g       # (NaN guard: inf from guard_value, never NaN)


def _round_gain(bests, since) -> bool:
    """Whether one more round (:data:`ROUND`) follows: the best error (``bests``: after each
    stage run) fell by at least :data:`ROUND_GAIN` over the last round (``since``: the length
    of ``bests`` when it began; a round whose stages were all skipped, their start unchanged,
    ends the rounds; with :data:`RERUN_TIGHTER` a round may hold a fixed point's one rerun
    from an unchanged start) or, before the first round (``since`` None), over the last
    ``len(ROUND)`` stages run (over all of them but the first when fewer ran)."""
    if since is None:
        since = max(1, len(bests) - len(ROUND))
    if len(bests) <= since or not np.isfinite(bests[-1]):
        return False        # (no stage ran since: a skipped round, or a one-stage order)
    return bests[-1] * ROUND_GAIN <= bests[since - 1]


def _drift_window(feats) -> int:
    """The ``drift_window`` of the ``"newton"`` stages for the problem of ``feats``
    (:data:`DRIFT_WINDOW` in the small local chain, or at any size with
    :data:`DRIFT_ANY_SIZE`; 0: none)."""
    return int(DRIFT_WINDOW) if DRIFT_WINDOW and (DRIFT_ANY_SIZE or _small_local(feats)) else 0


def _fixed_point_next(order, k):
    """``order`` with its first ``("clarabel", "coulomb")`` stage after position ``k`` moved to
    ``k + 1`` (the stages between follow it; with :data:`DRIFT_KEEP_WARM` copied there, the
    stage also kept in its place, where it starts as the chain's rules say: warm from a seed
    within :data:`WARM_MAX`); unchanged when there is none."""
    for j in range(k + 1, len(order)):
        if order[j] == ("clarabel", "coulomb"):
            rest = order[k + 1:] if DRIFT_KEEP_WARM else order[k + 1:j] + order[j + 1:]
            return order[:k + 1] + (order[j],) + rest
    return order


def _explicit_order(methods, formulation):
    order = []
    for m in methods:
        form = "frictionless" if m == "clarabel_qp" else formulation
        order.append((m, form))
    return tuple(order)


def auto_backend(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                 time_limit=None, verbose=False, inner_settings=None, resume=None,
                 **options) -> SolverResult:
    """Portfolio backend for :func:`socp_cd.solve` (see the module docstring).

    ``resume`` (set by the dispatcher only, from the ``resume`` that
    :func:`route` returns beside its result): the first stage of the order, already run by the
    compiled route — ``{"r": its iterate on this (balanced) problem,
    "stage": its path record, "trials": the hand-off's trials the route ran after it}``; the
    chain goes on from the second stage as if it had run that stage itself, and takes each
    trial as its own stage when it reaches it in the route's order, from the same start and
    tolerance (otherwise it runs the trials itself).
    """
    t_start = _clock()
    params = law_parameters(formulation, options)
    feats = features(problem, formulation)
    methods = options.get("methods")
    order = (_explicit_order(methods, formulation) if methods is not None
             else stage_order(problem, formulation, feats))
    if methods is None and r0 is not None and order[0][0] == "lemke":
        order = order[1:]       # (a warm call: NSGS from r0 first; pivoting has no warm start)
    judge = _Judge(problem, formulation, params, tol)
    best_r = None if r0 is None else np.array(r0, dtype=np.float64)
    best_err = judge(best_r) if best_r is not None else np.inf
    best_v, best_stage = None, -1
    # the seed: the iterate later stages start from (SEED_BY_GUARD), its error and its rank
    seed_r, seed_err, seed_v, seed_stage = best_r, best_err, None, -1
    seed_score = _seed_score(judge, best_r, best_err, tol)
    local = None
    path, hist = [], ([] if history else None)
    iterations, status, message = 0, "max_iter", ""
    version, ran = 0, {}          # version: bumped whenever the seed (the start) changes;
    #                               ran: the stages run, each with the stage tolerance its
    #                               answer met (None: it did not), RERUN_TIGHTER
    after_far_probe = False       # the previous stage was a probe that ended far from tol
    # best_err without the iterates of a newton_first or clarabel_first that missed tol (they
    # are not the seed, and a probe after them is judged as without them)
    chain_err = best_err
    stage_tol = tol               # the stages' target: tightened after a guard refusal
    knobs = _small_knobs()
    handoff = (_handoff_cap(problem, max_iter) if methods is None and _small_local(feats)
               and not feats["frictionless"] else None)
    nsgs_own = None               # the hand-off's first NSGS stage: (its iterate, status, sweeps)
    tried = mid_ran = False       # whether the hand-off's trial, and nsgs_mid, have run
    retried = False               # whether a refused stage has been run once more
    # rounds: bests is the best error after each stage run, since its length when the last
    # round began (None before the first)
    rounds, bests, since = 0, [], None
    took = {}                     # method -> shortest duration of its runs in this call
    short = ""                    # why a SLOW_TO_STOP stage was not run for lack of time
    # the hand-off's trials the compiled route ran after its NSGS stage (route)
    trials = list(resume.get("trials") or ()) if resume is not None else []
    # whether no NSGS stage has been reached yet: the small chain's first NSGS stage is the
    # order's first, or the one after "newton_first" (and a refused stage's retry inserted
    # before it)
    nsgs_pending = True
    drift_window = _drift_window(feats)     # the "newton" stages' drift_window (0: none)
    # the next fixed point the chain reaches starts from r = 0: a drift stop moved it next
    # (DRIFT_COLD), or a warm one missed tol (FP_COLD_AFTER_WARM)
    fp_cold_next = False
    # a fixed point on the Coulomb law has run from r = 0, or FP_COLD_AFTER_WARM has put one
    # next (its rule acts once per call, also when that stage is then skipped)
    fp_zero_tried = False
    k = -1
    while True:     # (a refused stage may be inserted once: RETRY_REFUSED; rounds appended)
        if k + 1 >= len(order):
            exact = methods is None and formulation == "coulomb" and not feats["frictionless"]
            more = exact and rounds < MAX_ROUNDS and _round_gain(bests, since)
            last = (not more and exact and LAST_RESORT and not feats["global"]
                    and ("newton_prox_error", "coulomb") not in order)
            if not (more or last):
                break
            if time_limit is not None and _clock() - t_start >= time_limit:
                status, message = "time_limit", BUDGET_SPENT
                break       # (a stage would follow: the budget, not the methods, ran out)
            if last:
                order = order + (("newton_prox_error", "coulomb"),)
            else:
                order = order + tuple((m, "coulomb") for m in ROUND)
                rounds, since = rounds + 1, len(bests)
        k += 1
        method, form = order[k]
        # the first NSGS stage of a small local exact-Coulomb problem runs with the study
        # knobs' settings (SMALL_SWEEPS / SMALL_STALL): when one is set, a different run from
        # NSGS with its defaults (the chain's last stage then)
        small_first = (nsgs_pending and method == "nsgs" and form == "coulomb"
                       and methods is None and not feats["frictionless"]
                       and _small_local(feats))
        if method == "nsgs":
            nsgs_pending = False
        variant = "small_first" if small_first and knobs != (None, None) else ""
        if method == "newton_trial" and mid_ran:
            variant = "at_cap"      # the second trial starts from NSGS's iterate, not the best
        # a stage started from r = 0 (or the caller's r0) has the same start whatever the best
        # iterate: keyed without its version (a round's fixed point after a cold one: skipped,
        # unless RERUN_TIGHTER lets a fixed point that met a looser tolerance go on, once)
        forced_cold = fp_cold_next and method == "clarabel"
        if method == "clarabel":
            fp_cold_next = False    # (used by the next fixed point reached, run or skipped)
        cold = _starts_cold(method, k, seed_err) or forced_cold
        key = (method, form, None if cold else version, variant)
        # (this stage ran from an iterate, FP_COLD_AFTER_WARM's test: set where a stage is
        # run below; the route's resumed stage and its trials are never the fixed point)
        started_warm = False
        rerun = RERUN_TIGHTER and ran.get(key) is not None and stage_tol < ran[key]
        if key in ran and not rerun:
            continue    # same deterministic method from the same start: nothing to gain
        if (method in ("newton_trial", "nsgs_mid", "nsgs_rest") + _COLD_TRIALS
                and methods is None and handoff is None):
            continue    # no hand-off in this call (one contact, or max_iter leaves no sweeps)
        if method in _COLD_TRIALS and methods is None and (
                not _cold_steps(method) or problem.m > COLD_MAX_M or not tried):
            continue    # only after a failed first trial, on at most COLD_MAX_M unknowns
        if (method in _COLD_TRIALS and methods is None and not mid_ran and nsgs_own is not None
                and _cold_trials_wait(problem, nsgs_own[1], nsgs_own[2], handoff)):
            continue    # after a failed early trial: nsgs_mid and its trial first
        if method == "newton_trial" and methods is None and tried and not mid_ran:
            continue    # a second trial only follows nsgs_mid
        if method == "nsgs_mid":
            # after an early hand-off (the rate prediction stopped NSGS before the cap) whose
            # trial failed: NSGS goes on from its own iterate up to the cap, where a second
            # trial follows, as without the prediction (a failed early trial costs its steps)
            rest = None
            if nsgs_own is not None and nsgs_own[1] == "max_iter" and nsgs_own[2] < handoff:
                rest = handoff - nsgs_own[2]
            if rest is None:
                continue
        if method == "nsgs_rest":
            # NSGS goes on from its own iterate (not the trial's): only after a first stage
            # that ran out of sweeps, and only for the sweeps it has left
            rest = None
            if nsgs_own is not None and nsgs_own[1] == "max_iter":
                rest = (nsgs.DEFAULT_MAX_ITER if max_iter is None else max_iter) - nsgs_own[2]
            if rest is None or rest <= 0:
                continue
        ran[key] = None
        target = problem
        if k == 0 and resume is not None and (method, form) == (resume["stage"]["method"],
                                                                "coulomb"):
            # done by the compiled route (the dispatcher's resume): its iterate and record
            stage = resume["stage"]
            r, res = np.asarray(resume["r"], dtype=np.float64), None
            st, its, dt = stage["status"], int(stage["iterations"]), float(stage["time"])
            err = judge(r)
        elif (trials and method == trials[0]["stage"]["method"] and stage_tol == tol
              and (not trials[0]["warm"] or (seed_r is not None
                                             and np.array_equal(seed_r, resume["r"])))):
            # the next trial the compiled route ran after it, from the same start and tol
            done = trials.pop(0)
            stage, r, res = done["stage"], np.asarray(done["r"], dtype=np.float64), None
            st, its, dt = stage["status"], int(stage["iterations"]), float(stage["time"])
            err = judge(r)
        else:
            trials = []     # a stage the route did not run: its later trials do not apply
            stage_limit = None
            if time_limit is not None:
                left = time_limit - (_clock() - t_start)
                if left <= 0.0:
                    status, message = "time_limit", BUDGET_SPENT
                    break
                if method in SLOW_TO_STOP and took.get(method, 0.0) > left:
                    short = (f"{method} not run again: it took {took[method]:.3g} s, "
                             f"{left:.3g} s of the budget left")
                    continue
                if (method in SLOW_TO_STOP and method not in took and k > 0
                        and left < MIN_SLOW_START * time_limit):
                    short = (f"{method} not started: {left:.3g} s of the {time_limit:g} s "
                             f"budget left (less than MIN_SLOW_START = {MIN_SLOW_START:g})")
                    continue
                stage_limit = left if k == len(order) - 1 else _stage_limit(method, left)
            spec, stage_opts = _STAGES[method]
            if problem.is_global and form not in spec.global_native:
                if local is None:
                    local = problem.to_local()
                target = local
            opts = dict(stage_opts)
            # a probe that missed by far hands nothing on: Newton from a far NSGS iterate with
            # the warm proximal parameter was 2-5x slower than from the start (auto_probe.md)
            if (method in ("newton", "newton_first") and seed_r is not None
                    and not after_far_probe):
                opts["alpha0"] = newton.WARM_ALPHA0     # warm start near a solution (newton.py)
            if method in ("newton", "newton_cold_alt") and NEWTON_STALL is not None:
                opts["stall_window"] = NEWTON_STALL
            if method == "newton" and drift_window:
                opts["drift_window"] = drift_window
            if method == "newton_cold_alt":
                opts["alpha0"] = float(ALT_ALPHA0)
            stage_max_iter = max_iter
            if method in _CAPPED:
                opts["stall_window"] = _plain_stall(method, _small_local(feats))
                if max_iter is None:
                    stage_max_iter = PLAIN_MAX_ITER
            if method == "nsgs_probe" and PROBE_SWEEPS > 0:  # a probe: _probe_plan's cap
                stage_max_iter, window = _probe_plan(max_iter)
                if window:
                    opts["predict_window"] = window
            elif small_first and handoff is not None:
                stage_max_iter = handoff
                window = _predict_window(problem)
                if window:
                    opts["predict_window"] = window
            elif small_first:
                stage_max_iter = _small_cap(max_iter)
                if knobs[1] is not None:
                    opts["stall_window"] = knobs[1]
            elif method == "clarabel_first":
                stage_max_iter = (REDUNDANT_FIRST_ITER if max_iter is None
                                  else min(max_iter, REDUNDANT_FIRST_ITER))
            elif method == "newton_first":
                stage_max_iter = (NEWTON_FIRST_STEPS if max_iter is None
                                  else min(max_iter, NEWTON_FIRST_STEPS))
                opts["stall_window"] = NEWTON_FIRST_STALL
            elif method in ("nsgs_mid", "nsgs_rest"):
                stage_max_iter = rest
                if method == "nsgs_rest" and REST_PREDICT:
                    opts["predict_window"] = REST_PREDICT
            elif method == "newton_trial":
                stage_max_iter = TRIAL_STEPS if max_iter is None else min(max_iter, TRIAL_STEPS)
                opts["stall_window"] = TRIAL_STALL
            elif method == "newton_prox_error":
                stage_max_iter = (PROX_ERROR_MAX_ITER if max_iter is None
                                  else min(max_iter, PROX_ERROR_MAX_ITER))
                opts["stall_window"] = int(PROX_ERROR_STALL)
            elif method in _COLD_TRIALS:
                steps = _cold_steps(method)
                stage_max_iter = steps if max_iter is None else min(max_iter, steps)
                opts["stall_window"] = COLD_TRIAL_STALL
            if form == "tresca":
                opts["threshold"] = options["threshold"]
            if ACCEPT_STOP and method in _NEWTON_FAMILY and stage_tol < tol:
                opts["accepted"] = judge.accepts
            t0 = _clock()
            try:
                start = None if cold else r0 if after_far_probe else seed_r
                if method == "newton_trial" and not mid_ran:
                    start = seed_r          # the first trial: from the seed, far or not
                if method in ("nsgs_mid", "nsgs_rest") or (method == "newton_trial" and mid_ran):
                    start = nsgs_own[0]     # NSGS's own iterate (the second trial: at the cap)
                started_warm = start is not None
                res = spec.func(target, form, tol=stage_tol, max_iter=stage_max_iter, r0=start,
                                history=history, time_limit=stage_limit, verbose=verbose,
                                inner_settings={}, **opts)
                r = np.asarray(res.r, dtype=np.float64).reshape(-1)
                st, its = res.status, int(res.iterations)
            except Exception as exc:  # noqa: BLE001 - one failing stage hands over to the next
                r, st, its, res = None, "numerical_error", 0, None
                message = f"{method}: {type(exc).__name__}: {exc}"
            dt = _clock() - t0
            took[method] = min(took.get(method, np.inf), dt)
            if method == "clarabel_first":      # (the full stage costs at least its set-up)
                took["clarabel"] = min(took.get("clarabel", np.inf), dt)
            err = judge(r)
        if small_first and handoff is not None and r is not None:
            nsgs_own = (r, st, its)     # the hand-off's first NSGS stage (route or here)
        elif method == "nsgs_mid" and r is not None:
            nsgs_own = (r, st, nsgs_own[2] + its)
        mid_ran = mid_ran or method == "nsgs_mid"
        tried = tried or method == "newton_trial"
        # a newton_first or clarabel_first that missed tol is not the seed: the chain after it
        # runs as without it (its far-probe verdict, the rounds' record of the best errors)
        missed_first = method in _FIRST_STAGES and not err <= tol
        if method == "nsgs_probe" or (FAR_NSGS_COLD and methods is None
                                      and method in ("nsgs", "nsgs_mid", "nsgs_rest")):
            after_far_probe = not min(err, chain_err) <= WARM_MAX or (
                method == "nsgs_probe" and _went_on_and_missed(its, st, err, tol))
        elif method == "newton_trial" or missed_first:
            pass        # a trial hands the NSGS stages' verdict on to the next stage
        elif method not in COLD_STAGES or err < chain_err:
            # (a cold stage that did not improve on a far probe, e.g. the fixed point before
            # Newton on large 2D problems, hands the far-probe rule on to the next stage)
            after_far_probe = False
        path.append({"method": method, "formulation": form, "iterations": its, "time": dt,
                     "error": err, "status": st})
        if err <= stage_tol and method in COLD_STAGES and form == "coulomb" and not rerun:
            ran[key] = stage_tol        # (a tighter target may take this run further, once)
        iterations += its
        if not missed_first:
            chain_err = min(chain_err, err)
        bests.append(chain_err)
        if history and res is not None and res.history:
            hist.extend(res.history)
        if err < best_err:
            best_r, best_err, best_stage = r, err, k
            best_v = res.v if (res is not None and target is problem) else None
        if err < seed_score and not missed_first:
            # (the rank is at least the error: else no gain; a newton_first or clarabel_first
            # that missed tol is not the seed: the chain after it starts as without it)
            score = _seed_score(judge, r, err, tol)
            if score < seed_score:
                seed_r, seed_err, seed_score, seed_stage = r, err, score, k
                seed_v = res.v if (res is not None and target is problem) else None
                version += 1        # (the start of the warm stages changed)
        status = st if st != "converged" else "stalled"
        if (method == "newton" and st == "stalled" and res is not None
                and res.info.get("stop") == "null_drift"):
            order = _fixed_point_next(order, k)
            fp_cold_next = DRIFT_COLD
        elif method == "clarabel":
            fp_zero_tried = fp_zero_tried or (form == "coulomb" and not started_warm)
            if (FP_COLD_AFTER_WARM and form == "coulomb" and started_warm and r is not None
                    and not err <= tol and _small_local(feats) and not fp_zero_tried):
                # a warm fixed point that missed tol: the fixed point from r = 0 next, once
                order = order[:k + 1] + ((method, form),) + order[k + 1:]
                fp_cold_next = fp_zero_tried = True
        if best_err <= tol:
            # (the seed's rank is already max(error, guard) of this iterate when it is the seed:
            # taken as g, the tests below read the same; the guard is not computed again)
            g = seed_score if SEED_BY_GUARD and seed_r is best_r else judge.guard_value(best_r)
            if g <= tol:
                status, message = "converged", f"{method} met tol"
                break
            if SEED_BY_GUARD and seed_score <= tol:
                # the best by the error is refused, the seed meets both measures: the answer
                best_r, best_err, best_v, best_stage = seed_r, seed_err, seed_v, seed_stage
                status = "converged"
                message = f"{order[seed_stage][0] if seed_stage >= 0 else 'r0'} met tol"
                break
            # within tol by the stages' measure, not by the guard: the later stages aim lower,
            # as the dispatcher's retry would (options.tightened_tolerance); with
            # TIGHTEN_FROM_SEED only when they start from that answer (it is the seed)
            if not TIGHTEN_FROM_SEED or seed_r is best_r:
                stage_tol = min(stage_tol, tightened_tolerance(tol, best_err, max(best_err, g)))
            if RETRY_REFUSED and best_stage == k and not retried and k + 1 < len(order):
                # this stage's answer was refused: the same stage once more from the seed
                # (next; the answer itself when refused by little enough to be the seed);
                # a Newton-family stage as the warm proximal Newton method (a trial's or a
                # cold stage's rerun would start elsewhere, or be skipped as already run); a
                # fixed point's answer to the exact Coulomb law as REDUNDANT_RETRY and
                # CLARABEL_RETRY say (Newton solves that law only)
                coulomb = form == "coulomb"
                again = ("newton" if method in _NEWTON_FAMILY or (method == "lemke" and coulomb)
                         else REDUNDANT_RETRY if method == "clarabel_first" and coulomb
                         else CLARABEL_RETRY if method == "clarabel" and coulomb else method)
                order = (order[:k + 1] + tuple((m, form) for m in again.split("+"))
                         + order[k + 1:])
                retried = True
    if short and status != "converged":
        status, message = "time_limit", short       # the budget, not the methods, ran out
    if best_r is None:
        best_r = np.zeros(problem.m)
    if status != "converged" and not message:
        message = f"no stage met tol; best error {best_err:.3e}"
    if verbose:
        print("auto: " + " -> ".join(f"{s['method']}({s['error']:.1e})" for s in path))
    info = {"path": path, "features": feats, "best_stage": best_stage}
    if rounds:
        info["rounds"] = rounds
    return SolverResult(r=best_r, v=best_v, status=status, iterations=iterations, history=hist,
                        info=info, message=message)


SPEC = SolverSpec(
    "auto", auto_backend, ("coulomb", "associated", "tresca", "frictionless"),
    global_native=("coulomb", "associated"), dims=(2, 3),
    description="portfolio: models only what the law needs, chains newton / nsgs / clarabel "
                "from cheap problem features, warm-starting each stage from the best iterate (the seed)",
    default_max_iter=newton.DEFAULT_MAX_ITER, options=OPTIONS,
    inner_settings="not applicable (rejected)", check=check, route=route,
    plain=plain)

__all__ = ["auto_backend", "route", "plain", "features", "contact_redundancy", "stage_order", "SPEC", "OPTIONS", "HIGH_MU",
           "SMALL_SWEEPS", "SMALL_STALL", "HANDOFF_SWEEPS", "HANDOFF_WORK", "TRIAL_STEPS",
           "TRIAL_STALL", "HANDOFF_PREDICT",
           "COLD_STAGES", "WARM_MAX", "STAGE_SHARE", "SMALL_NC", "ALWAYS_COLD", "PLAIN_STALL",
           "PLAIN_STALL_LARGE", "COLD_PLAIN_STALL_LARGE", "PLAIN_MAX_ITER", "PLAIN_SHARE",
           "PROBE_SWEEPS", "PROBE_CAP", "PROBE_PREDICT", "PROBE_MISS_COLD", "LARGE_2D_NC", "RETRY_REFUSED",
           "FAR_NSGS_COLD", "REST_PREDICT", "COLD_TRIAL_STEPS", "COLD_TRIAL_STALL", "COLD_PROX_STEPS",
           "ROUND", "ROUND_GAIN", "MAX_ROUNDS", "COLD_MAX_M", "PREDICT_MAX_M", "SLOW_TO_STOP",
           "ALT_ALPHA0", "COLD_PROX_FIRST", "EARLY_COLD_MAX_M", "MIN_SLOW_START", "COLD_SPLIT",
           "SEED_BY_GUARD",
           "TIGHTEN_FROM_SEED", "REDUNDANT_SHARE", "REDUNDANT_FIRST_ITER", "REDUNDANT_RETRY",
           "CLARABEL_RETRY", "REDUNDANT_RETRIES", "RERUN_TIGHTER", "ACCEPT_STOP", "DRIFT_WINDOW",
           "DRIFT_ANY_SIZE", "DRIFT_COLD", "DRIFT_KEEP_WARM", "FP_COLD_AFTER_WARM", "small_plan"]
