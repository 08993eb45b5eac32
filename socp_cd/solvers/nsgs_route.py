"""The compiled route: a whole plain NSGS call on a small local Coulomb problem in one kernel.

On a problem of a few contacts the mathematics of a :func:`socp_cd.solve`
call with NSGS — balance the units, build the block storage, sweep, map ``r``
back, recompute ``u = W r + q``, Siconos' error and the units guard — costs
a few microseconds; the Python around it (the dispatcher's checks, the
backend's set-up, the named tuples handed to the sweep kernel, each
compiled call's argument unboxing) costs 100 µs and more.  Siconos' NSGS
takes 4–12 µs per one-contact call.  :func:`nsgs_checked` runs the same
compiled pieces the general path runs, in the same order and on the same
arrays, in one compiled call:

1. :func:`~socp_cd.solvers.kernels.scaling.balance_csr` (the balanced
   problem ``W~ = S W S``, ``q~ = q / b`` of :mod:`socp_cd.solvers.scaling`);
2. :func:`~socp_cd.solvers.block_storage.csr_to_bsr` and
   :func:`~socp_cd.solvers.nsgs_kernels.local_parameters` (NSGS's set-up);
3. :func:`~socp_cd.solvers.nsgs_kernels.nsgs_loop` from ``r0 / a`` or 0 (in the
   blocks of sweeps the NSGS backend uses when a time limit is given);
4. ``r = a r~`` (:func:`~socp_cd.solvers.kernels.scaling.times_factors`'s
   product), ``u = W r + q`` on the data as written, Siconos' error and
   the parts of the units guard
   (:func:`~socp_cd.solvers.kernels.cone.error_parts`,
   :func:`~socp_cd.solvers.kernels.scaling.balanced_guard`: the
   dispatcher's own checks, :mod:`socp_cd.solvers.checks`).

So the answer is the general path's, bit for bit (``tests/test_route.py``
holds the two equal); the verdict (``converged``) stays the dispatcher's.
Backends offer the route through ``SolverSpec.route``
(:mod:`socp_cd.solvers.nsgs`, :mod:`socp_cd.solvers.auto`, and
:mod:`socp_cd.solvers.newton` with the Newton pieces below).

``solver="auto"`` hands a small problem's NSGS stage that misses ``tol`` to
Newton trials.  On at most :data:`TRIAL_MAX_M` unknowns (where the Newton
backend runs the compiled dense loop with the written-out LU) its route runs them
compiled too: :func:`trial_run` is one run of the Newton backend's compiled
loop on the same balanced problem (dense ``W~``), :func:`trial_checked` computes the
stage judge's measure and the dispatcher's checks of the answer
(:func:`checked_answer`, shared with :func:`nsgs_checked`), and
:func:`newton_checked` is the two in one call, balancing once
(:func:`socp_cd.solvers.newton.compiled_runs` makes it; only when the backend's own
run logic, :func:`socp_cd.solvers.newton.continued_runs`, would go on from that run
does :func:`trial_runner` feed :func:`trial_run` to it).
Through the general path each trial cost ~60 µs of Python around a kernel of
10–500 µs (the backend's set-up, the chain's and the dispatcher's bookkeeping).
``solver="newton"``'s own route (:func:`socp_cd.solvers.newton.route`) runs a whole
Newton solve with the same pieces.
"""
from __future__ import annotations

from collections import namedtuple
from math import inf

import numpy as np
from numba import njit, types
# numba's own array -> fixed-length tuple (numba >= 0.57; in its "unsafe" namespace, which
# only means it trusts the length given: here a module constant)
from numba.np.unsafe.ndarray import to_fixed_tuple

from .block_storage import csr_to_bsr
from .kernels import clock
from .kernels.clock import deadline_after, monotonic, past
from .kernels.cone import LAW_COULOMB, error_parts, relative_error, siconos_error
from .kernels import newton_dense as nd
from .kernels.dense import csr_matvec_add, csr_matvec_add_into, csr_to_dense, matvec_into
from .kernels.entry import F64_VECTOR, entry_point, index_vector
from .kernels.lemke import lemke_coulomb_2d
from .kernels.newton_ac import block_rho_dense
from .kernels.scaling import GUARD_KEYS, balance_csr, balanced_guard, factor_summary, origin_error
from .options import MAX_ITER
from .nsgs_kernels import (STATUS_CONVERGED, STATUS_MAX_ITER, STATUS_NAMES, STATUS_NUMERICAL,
                           STATUS_TIME_LIMIT, BlockW, Law, LocalSolver, Origin, Sweeps,
                           local_parameters, next_block, nsgs_loop, whole_windows)

#: the route runs on local problems with at most this many contacts (it builds the balanced
#: copy and the block storage in every call, where the general path keeps them on the
#: problem object; beyond this size the sweeps dominate either way)
MAX_CONTACTS = 20000
#: ... a time limit is the kernel's deadline on the compiled clock (:mod:`~.kernels.clock`),
#: read by the sweeps (every ``nsgs_kernels.CHECK_BLOCKS // nnzb`` sweeps, session 25) and
#: between blocks of sweeps, as in the NSGS backend; where that clock is
#: not available (``clock.AVAILABLE`` False), only a limit of at least this many seconds and
#: sweeps' work, ``sweeps * nnz(W)``, of at most MAX_TIMED_WORK (5e7 entry visits take
#: ~0.1 s), the bounds of every time-limited call until session 24
MIN_TIME_LIMIT = 0.5
MAX_TIMED_WORK = 5e7
#: first block of sweeps when a time limit is given (also the NSGS backend's, which checks
#: the clock between blocks)
TIME_CHECK_SWEEPS = 10

#: kernel outcome codes besides the sweep statuses of :mod:`~socp_cd.solvers.nsgs_kernels`
DECLINED_FRICTIONLESS = -2   # every mu = 0 and friction was required
DECLINED_ILL_POSED = -3      # a contact with W_NN <= 0 (the general path reports it)
DECLINED_SHORT_OUT = -5      # nsgs_checked_flat's out or settings too short
DECLINED_NOT_FINITE = -4     # r or u not finite, or the checks cannot judge them (the
                             # general path reports it: checked_answer)

#: the compiled Newton runs (:func:`trial_run`: ``auto``'s trials, ``newton``'s route) take
#: local problems of at most this many unknowns (``auto``'s cold trials' bound,
#: ``auto.COLD_MAX_M``) whose Newton steps the backend computes with the compiled dense loop
#: and the written-out LU (``newton.compiled_written_out``)
TRIAL_MAX_M = 150
#: the entries of :func:`trial_run`'s ``constants``, in order
TRIAL_CONSTANTS = ("alpha0", "plain_regularization", "goldstein_m1", "max_backtrack",
                   "alpha_min", "alpha_max", "inner_max_iter", "armijo", "nonmonotone",
                   "inner_gate", "inner_decrease")
#: the proximal loop's null-space drift test, off in these runs (``prox_newton_dense``'s ``drift``)
_NO_DRIFT = (0.0, 0.0, 0.0, 1.0)
(C_ALPHA0, C_PLAIN_REGULARIZATION, C_GOLDSTEIN_M1, C_MAX_BACKTRACK, C_ALPHA_MIN, C_ALPHA_MAX,
 C_INNER_MAX_ITER, C_ARMIJO, C_NONMONOTONE, C_INNER_GATE,
 C_INNER_DECREASE) = range(len(TRIAL_CONSTANTS))


#: the NSGS settings :func:`run` takes, in order (the keys of the NSGS backend's settings)
ROUTE_SETTINGS = ("kind", "loc_tol", "newton_maxit", "proj_maxit", "omega", "error_every",
                  "stall_window")
#: the values of :func:`nsgs_checked_flat`'s ``settings`` vector, in order (:func:`flat_settings`)
FLAT_SETTINGS = (("dim", "max_iter", "first_block") + ROUTE_SETTINGS
                 + ("need_friction", "handoff_sweeps", "handoff_work", "predict_window"))
N_FLAT_SETTINGS = len(FLAT_SETTINGS)
#: entries of :func:`nsgs_checked`'s ``stats`` tuple, in order (then the guard's,
#: :data:`~socp_cd.solvers.kernels.scaling.GUARD_KEYS`)
STATS = ("sweeps", "internal_error", "n_full", "n_fail", "light", "error", "zero_error",
         "start_error", "mu_max", "velocity_scale", "diag_min", "diag_max", "guard_finite")
(SWEEPS, INTERNAL_ERROR, N_FULL, N_FAIL, LIGHT, ERROR, ZERO_ERROR, START_ERROR, MU_MAX,
 VELOCITY_SCALE, DIAG_MIN, DIAG_MAX, GUARD_FINITE) = range(len(STATS))
_N_STATS = len(STATS)
#: length of :func:`nsgs_checked`'s ``stats`` tuple (STATS, then the guard's entries)
N_OUT = _N_STATS + len(GUARD_KEYS)
#: index of the units guard's value (what ``converged`` needs ``<= tol``) in that tuple
GUARD_VALUE = _N_STATS + GUARD_KEYS.index("value")
_GUARD_VALUE_AT = GUARD_KEYS.index("value")     # (in the guard's own entries)


@njit(cache=True, inline="always")
def checked_answer(indptr, indices, data, q, mu, dim, a, b, q_norm, q_s_norm, r_s, vectors,
                   stats):
    """The dispatcher's checks of a balanced iterate ``r_s``, in place: ``vectors[1] = a r_s``
    (:func:`~socp_cd.solvers.kernels.scaling.times_factors`'s product), ``vectors[2] = W r + q``
    (the data as written), and the entries ``ERROR``, ``VELOCITY_SCALE``, ``DIAG_MIN``,
    ``DIAG_MAX``, ``GUARD_FINITE`` and the units guard's of ``stats``
    (:func:`~socp_cd.solvers.kernels.cone.error_parts`,
    :func:`~socp_cd.solvers.kernels.scaling.balanced_guard`,
    :func:`~socp_cd.solvers.kernels.scaling.factor_summary`).  False when ``r`` or ``u`` is
    not finite (nothing filled) or the checks cannot judge them: Siconos' error overflows or
    the units guard is not finite (both kernels' callers then leave the answer to the
    general path)."""
    m = q.shape[0]
    r, u = vectors[1], vectors[2]
    for j in range(m):
        r[j] = r_s[j] * a[j]                          # = times_factors(r_s, a)
    csr_matvec_add_into(indptr, indices, data, r, q, u)
    for j in range(m):
        if not (np.isfinite(r[j]) and np.isfinite(u[j])):
            return False
    # (mu for the unread thresholds)
    f2, r2, u2 = error_parts(r, u, mu, mu, dim, np.int64(LAW_COULOMB))
    g_finite, guard = balanced_guard(r, u, a, b, mu, dim, q_s_norm)
    sigma, d_min, d_max = factor_summary(a, b, dim)
    stats[ERROR] = relative_error(f2, r2, u2, q_norm)
    stats[VELOCITY_SCALE] = sigma
    stats[DIAG_MIN] = d_min
    stats[DIAG_MAX] = d_max
    stats[GUARD_FINITE] = 1.0 if g_finite else 0.0
    stats[_N_STATS:] = guard
    return g_finite and np.isfinite(stats[ERROR])


@njit(cache=True)
def nsgs_checked(indptr, indices, data, q, mu, dim, warm, tol, max_iter, blocked, first_block,
                 time_left, kind, loc_tol, newton_max_iter, projection_max_iter, omega,
                 error_every, stall_window, need_friction, handoff_sweeps, handoff_work, predict_window,
                 vectors):
    """Balance, NSGS sweeps from ``vectors[0]`` or 0, map back, and the dispatcher's checks, in
    one call (:func:`checked_work`; :func:`nsgs_checked_flat` is the same call with its
    outputs in one array).

    Parameters
    ----------
    indptr, indices, data, q, mu, dim
        The local problem as written (``W`` in CSR form, duplicates summed).
    warm
        Start from ``vectors[0]`` (caller's units; else from 0).
    tol, max_iter, omega, error_every, stall_window
        NSGS's sweep settings (:data:`~socp_cd.solvers.nsgs_kernels.Sweeps`,
        natural ordering).
    blocked, first_block, time_left
        Run the sweeps in blocks of ``first_block``, twice that, ... sweeps, as
        the NSGS backend does when a time limit is given (each block restarts
        the light-error and stall bookkeeping), and stop with status
        ``STATUS_TIME_LIMIT`` when the clock passes ``time_left`` seconds after the
        call began, read by the sweeps (:data:`~socp_cd.solvers.nsgs_kernels.Sweeps`'
        ``deadline``) and after each block (:mod:`~socp_cd.solvers.kernels.clock`'s
        clock, read in the kernel: a deadline computed by the caller cost 0.2 µs of a
        7 µs call).
    kind, loc_tol, newton_max_iter, projection_max_iter
        The one-contact solver (:data:`~socp_cd.solvers.nsgs_kernels.LocalSolver`).
    need_friction
        Decline (code :data:`DECLINED_FRICTIONLESS`) before any work when every
        ``mu`` is 0.
    handoff_sweeps, handoff_work
        When ``handoff_sweeps > 0``: stop after
        ``max(handoff_sweeps, ceil(handoff_work / nnz(W)))`` sweeps when that is
        fewer than ``max_iter`` (``solver="auto"``'s hand-off,
        :func:`socp_cd.solvers.auto._handoff_cap` is the same rule in Python).
    predict_window
        NSGS's option of that name (0: off): stop early when the error's rate
        predicts that the hand-off's cap will not reach ``tol``; ignored when the
        hand-off is on and its cap is not below ``max_iter`` (the general path
        then runs NSGS without it).
    vectors : ndarray (3, m)
        With ``warm``, its first row the start ``r0``; output, overwritten: rows the
        balanced iterate ``r~``, ``r = a r~`` and ``u = W r + q`` (the data as written).
        Passed in, one array: an array a compiled call allocates and returns costs its
        boxing (~0.3 µs, three times NumPy's allocation).

    Returns
    -------
    code : int
        The sweeps' status, or a ``DECLINED_*`` code (then nothing else is meaningful).
    stats : tuple of float
        A tuple, not an array (boxing floats costs a third of an array's and
        its ``tolist``): the entries named by :data:`STATS`, then the units guard's
        (:func:`~socp_cd.solvers.kernels.scaling.balanced_guard` of ``(r, u)``):
        NSGS's counts and last errors (``internal_error``: Siconos' error of the
        balanced pair, what ``solver="auto"``'s stage judge measures, to
        rounding); ``error`` Siconos' error of ``(r, u)``; ``zero_error`` that
        of ``r = 0``; ``start_error`` that of the balanced start (``inf`` when
        not ``warm``); ``mu_max``; the three numbers of
        :func:`~socp_cd.solvers.kernels.scaling.factor_summary`;
        ``guard_finite`` (1 or 0).
    """
    stats = np.zeros(N_OUT)
    code = checked_work(indptr, indices, data, q, mu, dim, warm, tol, max_iter, blocked,
                        first_block, time_left, kind, loc_tol, newton_max_iter,
                        projection_max_iter, omega, error_every, stall_window, need_friction,
                        handoff_sweeps, handoff_work, predict_window, vectors, stats)
    return code, to_fixed_tuple(stats, N_OUT)


@njit(cache=True)
def nsgs_checked_flat(indptr, indices, data, q, mu, settings, warm, tol, blocked, time_left,
                      out):
    """:func:`nsgs_checked` with its settings in one array and its outputs in another.

    ``settings``: the float64 vector :func:`flat_settings` makes, the values
    :data:`FLAT_SETTINGS` names (``dim``, ``max_iter``, ``first_block``, the
    :data:`ROUTE_SETTINGS`, ``need_friction``, the hand-off's two and
    ``predict_window``), made once by a caller that runs the same settings on many
    problems: unboxing one array instead of 14 numbers took 0.07-0.13 µs off a one-contact
    call (``validation/results/per_call_ab_s33.md``).  ``out``: :func:`flat_rows`
    ``(m)`` rows of ``m``: the rows of ``vectors`` (the start ``r0`` in the first with
    ``warm``), then ``stats`` (the first :data:`N_OUT` entries of the rows after, in
    order).

    Returns ``(code, sweeps, internal_error, error, guard_value, zero_error)``: the
    code and the entries of ``stats`` a caller judges a run by
    (:func:`socp_cd.solvers.auto.plain`; a row of ``out`` costs it less than a slice).  Boxing
    these five numbers, not the twenty of the tuple, saves 0.2 µs of a one-contact call.
    A ``settings`` or ``out`` too short declines (:data:`DECLINED_SHORT_OUT`).
    """
    m = q.shape[0]
    # (no bounds checks in compiled code: a short out or settings declines)
    if out.size < 3 * m + N_OUT or settings.size < N_FLAT_SETTINGS:
        return DECLINED_SHORT_OUT, 0, np.inf, np.inf, np.inf, np.inf
    entries = out.reshape(out.size)
    stats = entries[3 * m:3 * m + N_OUT]
    stats[:] = 0.0
    s = settings
    code = checked_work(indptr, indices, data, q, mu, int(s[0]), warm, tol, int(s[1]), blocked,
                        int(s[2]), time_left, int(s[3]), s[4], int(s[5]), int(s[6]), s[7],
                        int(s[8]), int(s[9]), s[10] != 0.0, int(s[11]), int(s[12]), int(s[13]),
                        entries[:3 * m].reshape((3, m)), stats)
    return (code, int(stats[SWEEPS]), stats[INTERNAL_ERROR], stats[ERROR], stats[GUARD_VALUE],
            stats[ZERO_ERROR])


@njit(cache=True)
def checked_work(indptr, indices, data, q, mu, dim, warm, tol, max_iter, blocked, first_block,
                 time_left, kind, loc_tol, newton_max_iter, projection_max_iter, omega,
                 error_every, stall_window, need_friction, handoff_sweeps, handoff_work,
                 predict_window, vectors, stats):
    """The work of :func:`nsgs_checked` (its arguments, and ``stats`` (:data:`N_OUT`,
    zeros) for the tuple it returns, filled here): returns the code."""
    deadline = monotonic() + time_left if blocked else np.inf
    nc = mu.shape[0]
    m = q.shape[0]
    nnz = max(indptr[nc * dim], 1)
    if handoff_sweeps > 0:
        cap = max(handoff_sweeps, (handoff_work + nnz - 1) // nnz)
        if cap < max_iter:
            max_iter = cap
        else:
            predict_window = 0      # no hand-off: NSGS as without it (no early stop either)
    mu_max = 0.0
    for i in range(nc):
        mu_max = max(mu_max, mu[i])
    stats[MU_MAX] = mu_max
    if need_friction and mu_max == 0.0:
        return DECLINED_FRICTIONLESS
    a, b, data_s, q_s, q_norm, q_s_norm, err0 = balance_csr(indptr, indices, data, q, mu, dim)
    bptr, bcol, blocks, _, diag = csr_to_bsr(indptr, indices, data_s, dim, nc)
    rhoN, rhoT, rhoP, bad = local_parameters(diag, blocks)
    if bad.any():
        return DECLINED_ILL_POSED
    r_s = vectors[0]
    start_error = np.inf
    if warm:
        for j in range(m):
            r_s[j] = r_s[j] / a[j]      # (the start, in place: an array argument less)
        start_error = siconos_error(r_s, csr_matvec_add(indptr, indices, data_s, r_s, q_s), mu,
                                    dim, q_s_norm)
    else:
        r_s[:] = 0.0
    W = BlockW(bptr, bcol, blocks, diag)
    law = Law(mu, mu, LAW_COULOMB)     # (the Coulomb law never reads its thresholds)
    origin = Origin(a, b, q_norm)       # the dispatcher's measure stops the sweeps too
    local = LocalSolver(kind, rhoN, rhoT, rhoP, loc_tol, newton_max_iter, projection_max_iter)
    hist = np.full(1, np.nan)
    done = 0
    block = min(max_iter, whole_windows(first_block, predict_window)) if blocked else max_iter
    prev = -1.0             # the rate prediction's error at the end of the last block
    while True:
        sweeps = Sweeps(tol, block, omega, False, done, error_every, stall_window, False,
                        predict_window, max_iter - done, prev, deadline)
        status, its, err, n_full, n_fail, light, hist = nsgs_loop(dim, W, q_s, law, local, sweeps,
                                                                  r_s, hist, origin)
        done += its
        if not blocked:
            break
        block, prev = next_block(status, its, block, done, max_iter, err, predict_window)
        if block == 0:
            break
        if past(deadline):
            status = STATUS_TIME_LIMIT
            break
    if not checked_answer(indptr, indices, data, q, mu, dim, a, b, q_norm, q_s_norm, r_s,
                          vectors, stats):
        return DECLINED_NOT_FINITE
    stats[SWEEPS] = done
    stats[INTERNAL_ERROR] = err
    stats[N_FULL] = n_full
    stats[N_FAIL] = n_fail
    stats[LIGHT] = light
    stats[ZERO_ERROR] = err0
    stats[START_ERROR] = start_error
    return status


@njit(cache=True)
def trial_run(indptr, indices, data, q, mu, dim, start, norm_q, tol, max_iter, stall_window,
              prox, constants, alpha0, r_s, fstate, istate):
    """One run of the Newton backend's compiled loop on the balanced problem, from ``start``.

    The loop the backend runs with its default settings — plain steps
    (:func:`~socp_cd.solvers.kernels.newton_dense.plain_newton_dense`,
    ``policy="plain"``) or the proximal method
    (:func:`~socp_cd.solvers.kernels.newton_dense.prox_newton_dense`) — on the
    balanced problem of :func:`~socp_cd.solvers.kernels.scaling.balance_csr` as a
    dense ``W~``, Alart–Curnier parameters of
    :func:`~socp_cd.solvers.kernels.newton_ac.block_rho_dense`, with the arguments
    the backend passes it (``_newton_compiled``): the same iterates, bit for bit, as
    one run of ``solver="newton"`` on the dispatcher's balanced copy.

    Parameters
    ----------
    indptr, indices, data, q, mu, dim
        The local problem as written (``m <=`` :data:`TRIAL_MAX_M` unknowns).
    start : ndarray (m,)
        The balanced start.
    norm_q : float
        ``||q~||`` as the balanced copy computes it (``problem.q_norm``).
    tol, max_iter, stall_window, prox
        The run's tolerance, outer-iteration cap, stall window; the proximal method
        (else plain steps).
    constants : ndarray (11,)
        The backend's loop constants (:data:`TRIAL_CONSTANTS` names them,
        :func:`socp_cd.solvers.newton.trial_constants` gives them); ``alpha0`` (relative
        to the block scale) replaces its first.
    r_s : ndarray (m,)
        Output: the run's answer (its last iterate, or its best one when it did not
        converge).
    fstate, istate : ndarray
        The loop's state (the shapes of
        :func:`~socp_cd.solvers.kernels.newton_dense.new_state`): on entry only
        ``fstate[F_DEADLINE]`` is read, the run's deadline (``inf``: none; the run then
        stops ``TIME_LIMIT``); on exit the state at the run's end (counters, proximal
        parameters).

    Returns
    -------
    code, iterations, internal_error, error_as_written, wscale
        The loop's status (:data:`~socp_cd.solvers.kernels.newton_dense.STATUS_NAMES`), its
        outer iterations, its own error (the smaller of the last and best), Siconos' error of
        the problem as
        written (:func:`~socp_cd.solvers.kernels.scaling.origin_error` of ``r_s`` and
        ``W~ r_s + q~``, the backend's test), and the block scale of ``W~`` (the unit of
        the proximal parameter).
    """
    m = q.shape[0]
    a, b, data_s, q_s, q_norm, q_s_norm, err0 = balance_csr(indptr, indices, data, q, mu, dim)
    W = csr_to_dense(indptr, indices, data_s, m, m)
    return _balanced_run(W, q_s, a, b, q_norm, mu, dim, start, norm_q, tol, max_iter,
                         stall_window, prox, constants, alpha0, r_s, fstate, istate)


@njit(cache=True)
def _balanced_run(W, q_s, a, b, q_norm, mu, dim, start, norm_q, tol, max_iter, stall_window,
                  prox, constants, alpha0, r_s, fstate, istate):
    """:func:`trial_run` on the balanced problem ``W~`` (dense), ``q~`` of
    :func:`~socp_cd.solvers.kernels.scaling.balance_csr` (``a``, ``b``, ``q_norm`` its unit
    factors and ``||q||``): the same returns.  (Called, not inlined, as
    :func:`_checked_balanced`: once per route call, and inlined into each caller it was
    compiled once per caller, ~25 s of a fresh install's warm-up for the two; session 47.)"""
    nc = mu.shape[0]
    m = q_s.shape[0]
    rho = np.empty(nc)
    wscale = block_rho_dense(W, dim, rho)
    deadline = fstate[nd.F_DEADLINE]        # (the caller's, kept)
    fstate[:] = 0.0
    fstate[nd.F_DEADLINE] = deadline
    fstate[nd.F_ALPHA] = alpha0 * wscale
    fstate[nd.F_ALPHA_MAX_USED] = alpha0 * wscale
    istate[:] = 0
    r_s[:] = start
    best_r = np.empty(m)
    max_backtrack = int(constants[C_MAX_BACKTRACK])
    # the written-out LU (dense.WRITTEN_OUT) and the equation as run-time values, not literals:
    # the backend's calls and these share the loops' compiled versions
    written_out = (np.int64(0), np.int64(0))
    law = np.int64(nd.LAW_AC)
    if prox:
        nd.prox_newton_dense(W, q_s, norm_q, mu, rho, rho, dim, tol, max_iter,
                             constants[C_ALPHA_MIN] * wscale, constants[C_ALPHA_MAX] * wscale,
                             int(constants[C_INNER_MAX_ITER]), stall_window, constants[C_ARMIJO],
                             max_backtrack, constants[C_NONMONOTONE], constants[C_INNER_GATE],
                             constants[C_INNER_DECREASE], r_s, best_r, fstate, istate,
                             written_out, law, _NO_DRIFT)
    else:
        nd.plain_newton_dense(W, q_s, norm_q, mu, rho, rho, dim, tol, max_iter,
                              constants[C_PLAIN_REGULARIZATION] * wscale, stall_window,
                              constants[C_GOLDSTEIN_M1], max_backtrack, r_s, best_r, fstate,
                              istate, written_out, law)
    status = istate[nd.I_STATUS]
    err, best_err = fstate[nd.F_ERR], fstate[nd.F_BEST_ERR]
    if status != nd.CONVERGED and best_err < err:
        r_s[:] = best_r
    u = np.empty(m)
    matvec_into(W, r_s, q_s, u)                 # the backend's system.start(r)
    return (status, istate[nd.I_IT], min(err, best_err),
            origin_error(r_s, u, a, b, mu, dim, q_norm), wscale)


@njit(cache=True)
def trial_checked(indptr, indices, data, q, mu, dim, r_s, norm_q, vectors):
    """The stage judge's measures and the dispatcher's checks of a balanced answer ``r_s``.

    Returns ``(ok, stats, judge_guard)``: ``stats`` as :func:`nsgs_checked`'s
    (``INTERNAL_ERROR`` Siconos' error of the balanced pair as ``solver="auto"``'s
    stage judge computes it, ``ERROR`` and the guard's entries the dispatcher's checks
    of ``r = a r~``; the counters 0); ``judge_guard`` the judge's ``guard_value``
    (the units guard of the balanced pair with unit factors 1, or Siconos' error as
    written when larger; ``inf`` when not finite); ``vectors`` (3, m) as there (row 0
    ``r_s``); ``ok`` False when :func:`checked_answer` is.  ``norm_q``: ``||q~||``
    as the judge computes it.
    """
    a, b, data_s, q_s, q_norm, q_s_norm, err0 = balance_csr(indptr, indices, data, q, mu, dim)
    vectors[0] = r_s
    return _checked_balanced(indptr, indices, data, q, mu, dim, a, b, data_s, q_s, q_norm,
                             q_s_norm, err0, norm_q, vectors)


@njit(cache=True)
def _checked_balanced(indptr, indices, data, q, mu, dim, a, b, data_s, q_s, q_norm, q_s_norm,
                      err0, norm_q, vectors):
    """:func:`trial_checked` of the balanced answer ``vectors[0]``, the outputs of
    :func:`~socp_cd.solvers.kernels.scaling.balance_csr` given: the same returns (called,
    not inlined: see :func:`_balanced_run`)."""
    nc = mu.shape[0]
    m = q.shape[0]
    stats = np.zeros(N_OUT)
    r_s = vectors[0]
    if not checked_answer(indptr, indices, data, q, mu, dim, a, b, q_norm, q_s_norm, r_s,
                          vectors, stats):
        return False, to_fixed_tuple(stats, N_OUT), np.inf
    u_s = csr_matvec_add(indptr, indices, data_s, r_s, q_s)     # (the judge's u~)
    stats[INTERNAL_ERROR] = siconos_error(r_s, u_s, mu, dim, norm_q)
    ones = np.ones(m)
    g_finite, g = balanced_guard(r_s, u_s, ones, ones, mu, dim, norm_q)
    judge_guard = g[_GUARD_VALUE_AT] if g_finite else np.inf
    e = origin_error(r_s, u_s, a, b, mu, dim, q_norm)
    if not e <= judge_guard:
        judge_guard = e
    if not np.isfinite(judge_guard):
        judge_guard = np.inf
    stats[ZERO_ERROR] = err0
    stats[START_ERROR] = np.inf
    mu_max = 0.0
    for i in range(nc):
        mu_max = max(mu_max, mu[i])
    stats[MU_MAX] = mu_max
    return True, to_fixed_tuple(stats, N_OUT), judge_guard


@njit(cache=True)
def newton_checked(indptr, indices, data, q, mu, dim, start, norm_q, tol, max_iter,
                   stall_window, prox, constants, alpha0, vectors, fstate, istate):
    """:func:`trial_run` then :func:`trial_checked` of its answer, in one call, balancing once.

    The arguments are :func:`trial_run`'s, with ``vectors`` (3, m) for ``r_s`` (its row 0)
    and :func:`trial_checked`'s output; ``norm_q < 0`` computes ``||q~||`` here as
    :func:`judge_norm` does: ``np.dot`` of the contiguous ``q~``, which numba hands to
    BLAS ``ddot`` (scipy's build) and NumPy to its own build's ``ddot``; on this machine
    the two agree to the last bit on every length (``tests/test_route.py`` checks it),
    which an install whose two builds sum in another order would break.

    Returns
    -------
    code, iterations, internal_error, error_as_written, wscale
        :func:`trial_run`'s.
    norm_q : float
        ``||q~||`` as used.
    ok, stats, judge_guard
        :func:`trial_checked`'s (``ok`` False: the checks cannot judge the answer).
    """
    m = q.shape[0]
    a, b, data_s, q_s, q_norm, q_s_norm, err0 = balance_csr(indptr, indices, data, q, mu, dim)
    if norm_q < 0.0:
        norm_q = np.sqrt(np.dot(q_s, q_s))
    W = csr_to_dense(indptr, indices, data_s, m, m)
    code, its, internal, e, wscale = _balanced_run(W, q_s, a, b, q_norm, mu, dim, start, norm_q,
                                                   tol, max_iter, stall_window, prox, constants,
                                                   alpha0, vectors[0], fstate, istate)
    ok, stats, judge_guard = _checked_balanced(indptr, indices, data, q, mu, dim, a, b, data_s,
                                               q_s, q_norm, q_s_norm, err0, norm_q, vectors)
    return code, its, internal, e, wscale, norm_q, ok, stats, judge_guard


#: What :func:`run` gives a backend's route.  ``status``: the sweeps' own status
#: (:data:`~socp_cd.solvers.nsgs_kernels.STATUS_NAMES`); ``vectors``: rows ``r~`` (the
#: balanced iterate), ``r`` and ``u = W r + q`` in the caller's units; ``stats``: the tuple
#: of the entries of :data:`STATS` (index constants ``SWEEPS``, ``ERROR``, ...: ``ERROR``
#: is the dispatcher's recomputed Siconos error, ``INTERNAL_ERROR`` what ``auto``'s stage
#: judge measures), then the units guard's (:func:`guard_record`, :func:`scaling_record`
#: make the records ``result.info`` holds).
RouteOutcome = namedtuple("RouteOutcome", "status vectors stats")


def guard_record(x) -> dict:
    """The units guard's record (:func:`socp_cd.residuals.guard`) from a stats tuple ``x``."""
    # keys in GUARD_KEYS' order, literal indices (the fastest: this runs on every routed
    # call; tests/test_route.py checks them against STATS and GUARD_KEYS)
    return {"error": x[13], "balanced_siconos": x[14], "rounding": x[15], "value": x[16],
            "cone": x[17], "normal_velocity": x[18], "complementarity": x[19]}


def scaling_record(x) -> dict:
    """``result.info["scaling"]`` (:meth:`~socp_cd.solvers.scaling.Scaling.describe`) from a
    stats tuple ``x``."""
    return {"velocity_scale": x[9], "diag_min": x[10], "diag_max": x[11]}


def run(problem, settings, tol, max_iter, r0, time_limit, need_friction, handoff=(0, 0),
        predict_window=0):
    """Run :func:`nsgs_checked` on a local problem: a :data:`RouteOutcome`, or None.

    ``settings``: the NSGS backend's checked settings as the tuple
    :data:`ROUTE_SETTINGS` names (its defaults: the route runs plain calls
    only); ``max_iter`` sweeps, in the backend's time-limit blocks when
    ``time_limit`` is given, which is the kernel's deadline (a run past it:
    status ``"time_limit"``).  None when the route does not apply (it takes a
    local problem of 1 to :data:`MAX_CONTACTS` contacts; with a time limit and
    without the compiled clock, only a limit of at least :data:`MIN_TIME_LIMIT` s and
    ``max_iter * nnz(W) <=`` :data:`MAX_TIMED_WORK`) or declines: a problem whose every
    ``mu`` is 0 when ``need_friction``, one with an ill-posed contact, an answer that is not
    finite, whose error overflows or whose guard cannot be evaluated (the
    general path reports those).  ``handoff``: ``(sweeps, work)`` of
    :func:`nsgs_checked` (``(0, 0)``: off); ``predict_window`` as there.
    """
    return run_prepared(problem, prepared(settings, need_friction, handoff, predict_window), tol,
                        max_iter, r0, time_limit)


def prepared(settings, need_friction, handoff=(0, 0), predict_window=0) -> tuple:
    """:func:`run`'s arguments ``settings``, ``need_friction``, ``handoff`` and
    ``predict_window`` as :func:`run_prepared` takes them: the kernel's trailing arguments in
    one tuple, made once by a caller that runs the same settings on many problems."""
    return (*settings, need_friction, *handoff, predict_window)


def run_prepared(problem, tail, tol, max_iter, r0, time_limit, _new=tuple.__new__):
    """:func:`run` with ``settings``, ``need_friction``, ``handoff`` and ``predict_window``
    in ``tail`` (:func:`prepared`).  A plain ``solver="auto"`` call on a small problem is a
    few µs, a tenth of it the making of :func:`nsgs_checked`'s 24 arguments:
    :func:`socp_cd.solvers.auto.plain` keeps ``tail`` from one call to the next (and calls
    :func:`nsgs_checked_flat` itself, within these bounds)."""
    mu = problem.mu
    indptr, indices, data = problem.csr_parts
    nc = mu.shape[0]
    # the bounds (MAX_CONTACTS; a sweep cap the kernel's int64 holds, options.MAX_ITER;
    # with a time limit and no compiled clock, MIN_TIME_LIMIT and MAX_TIMED_WORK, compared
    # in floats, where max_iter * nnz would wrap around in int64; auto.plain's call keeps
    # within them too: MAX_CONTACTS and nc > 0 read per call, its sweep cap checked with its
    # plan, a timed call without the compiled clock sent to auto.route)
    if (nc > MAX_CONTACTS or nc == 0 or max_iter > MAX_ITER
            or time_limit is not None and not clock.AVAILABLE and not (
                time_limit >= MIN_TIME_LIMIT
                and float(max_iter) * max(int(indptr[-1]), 1) <= MAX_TIMED_WORK)):
        return None
    q = problem.q
    vectors = np.empty((3, q.shape[0]))
    if r0 is not None:          # (the start, the kernel's first row: the checks of solve())
        vectors[0] = problem.check_reaction(r0, "r0")
    kernel = _CHECKED.get(indptr.dtype) if indices.dtype is indptr.dtype else None
    code, x = (kernel or _checked_entry(indptr, indices))(
        indptr, indices, data, q, mu, problem.dim, r0 is not None, tol,
        max_iter, time_limit is not None, TIME_CHECK_SWEEPS,
        inf if time_limit is None else time_limit, *tail, vectors)
    if code < 0:            # (a declined problem, or an answer the checks cannot judge)
        return None
    # (tuple.__new__: half the cost of the named tuple's own constructor, per call)
    return _new(RouteOutcome, (STATUS_NAMES[code], vectors, x))


def flat_settings(dim, max_iter, first_block, tail) -> np.ndarray:
    """:func:`nsgs_checked_flat`'s ``settings``: ``dim``, the sweep cap ``max_iter``, the
    first block of a timed run ``first_block`` and ``tail`` (:func:`prepared`'s) as one float64
    vector (:data:`FLAT_SETTINGS`).  Its integers must be exact in float64 (every integer up
    to 2**53 is): checked here (``ValueError``)."""
    values = (dim, max_iter, first_block) + tuple(tail)
    if len(values) != N_FLAT_SETTINGS:
        raise ValueError(f"flat_settings: {N_FLAT_SETTINGS} values expected, got {len(values)}")
    out = np.array(values, dtype=np.float64)
    for v, x in zip(values, out):
        if (isinstance(v, (int, np.integer)) and not isinstance(v, bool)) and int(x) != v:
            raise ValueError(f"flat_settings: {v} is not exact in float64")
    return out


#: :func:`lemke_checked_flat`'s code by Lemke's outcome
#: (:data:`~socp_cd.solvers.kernels.lemke.SOLVED`, ``RAY``, ``MAX_PIVOTS``, ``TIME_LIMIT``): the
#: NSGS statuses whose names (:data:`STATUS_NAMES`) the backend ``"lemke"`` reports
LEMKE_CODES = (STATUS_CONVERGED, STATUS_NUMERICAL, STATUS_MAX_ITER, STATUS_TIME_LIMIT)


@njit(cache=True)
def lemke_checked_flat(indptr, indices, data, q, mu, max_pivots, blocked, time_left, out):
    """Balance, Lemke's method on the 2D Coulomb LCP, map back and the dispatcher's checks, in
    one call: the compiled route of ``solver="auto"``'s ``"lemke"`` stage
    (:func:`socp_cd.solvers.auto.plain`).

    The same pieces as the general path, on the same arrays: the balanced problem of
    :func:`~socp_cd.solvers.kernels.scaling.balance_csr`, the backend's kernel
    (:func:`~socp_cd.solvers.kernels.lemke.lemke_coulomb_2d`), the stage judge's error
    (``||q~||`` by ``np.dot``, as :func:`newton_checked`) and :func:`checked_answer`.
    ``out``: :func:`flat_rows` ``(m)`` rows of ``m`` as :func:`nsgs_checked_flat`'s (``SWEEPS``
    holds the pivots).  Returns ``(code, pivots, internal_error, error, guard_value,
    zero_error)`` as that kernel: ``code`` an NSGS status (:data:`LEMKE_CODES`) or
    :data:`DECLINED_FRICTIONLESS` (every ``mu = 0``: the QP comes first),
    :data:`DECLINED_NOT_FINITE`, :data:`DECLINED_SHORT_OUT`; ``guard_value`` the larger of the
    dispatcher's units guard and the judge's (:func:`trial_checked`'s ``judge_guard``), so
    that a caller accepting on it accepts what both would."""
    m = q.shape[0]
    nc = mu.shape[0]
    if out.size < 3 * m + N_OUT or m != 2 * nc:
        return DECLINED_SHORT_OUT, 0, np.inf, np.inf, np.inf, np.inf
    mu_max = 0.0
    for i in range(nc):
        mu_max = max(mu_max, mu[i])
    if mu_max == 0.0:
        return DECLINED_FRICTIONLESS, 0, np.inf, np.inf, np.inf, np.inf
    deadline = monotonic() + time_left if blocked else np.inf
    entries = out.reshape(out.size)
    vectors = entries[:3 * m].reshape((3, m))
    stats = entries[3 * m:3 * m + N_OUT]
    dim = np.int64(2)   # (not the literal 2: the kernels below would be compiled apart for it)
    a, b, data_s, q_s, q_norm, q_s_norm, err0 = balance_csr(indptr, indices, data, q, mu, dim)
    norm_q = np.sqrt(np.dot(q_s, q_s))
    outcome, pivots = lemke_coulomb_2d(indptr, indices, data_s, q_s, mu, max_pivots, deadline,
                                       vectors[0])
    ok, st, judge_guard = _checked_balanced(indptr, indices, data, q, mu, dim, a, b, data_s, q_s,
                                            q_norm, q_s_norm, err0, norm_q, vectors)
    if not ok:
        return DECLINED_NOT_FINITE, 0, np.inf, np.inf, np.inf, np.inf
    for k in range(N_OUT):
        stats[k] = st[k]
    stats[SWEEPS] = pivots
    guard = stats[GUARD_VALUE]
    if not judge_guard <= guard:
        guard = judge_guard
    return (LEMKE_CODES[outcome], pivots, stats[INTERNAL_ERROR], stats[ERROR], guard,
            stats[ZERO_ERROR])


def flat_rows(m) -> int:
    """Rows of :func:`nsgs_checked_flat`'s ``out`` for ``m`` unknowns: three, and those the
    :data:`N_OUT` stats fill."""
    return 3 - (-N_OUT // m)


def flat_stats(out) -> tuple:
    """The ``stats`` tuple of :func:`nsgs_checked_flat`'s ``out`` (:func:`nsgs_checked`'s)."""
    m = out.shape[1]
    return tuple(out.reshape(-1)[3 * m:3 * m + N_OUT].tolist())


def flat_outcome(numbers, out):
    """The :data:`RouteOutcome` of :func:`nsgs_checked_flat`'s returns ``numbers`` and its
    ``out`` (:func:`run_prepared`'s)."""
    return RouteOutcome(STATUS_NAMES[numbers[0]], out[:3], flat_stats(out))


#: :func:`nsgs_checked`'s entry point (:mod:`~socp_cd.solvers.kernels.entry`) by the dtype of
#: ``W``'s CSR index arrays (int32 unless a matrix is too large for it: the form the problem
#: classes hold, :func:`socp_cd.problem.kernel_array`): its other arguments' types are fixed
#: (the problem classes keep ``data``, ``q`` and ``mu`` contiguous, writable float64 vectors,
#: :func:`run_prepared` makes the rest);
#: :data:`FLAT_ENTRIES`: :func:`nsgs_checked_flat`'s (public: :func:`socp_cd.solvers.auto.plain`
#: calls the kernel itself, a Python layer less: 0.1-0.3 µs of a one-contact call)
_CHECKED = {}
FLAT_ENTRIES = {}
LEMKE_ENTRIES = {}
_INDEX_DTYPES = (np.dtype(np.int32), np.dtype(np.int64))


def _checked_entry(indptr, indices):
    """:func:`nsgs_checked`'s entry point for these index arrays (recorded in :data:`_CHECKED`
    when both have the same dtype; else the dispatcher, which checks every argument)."""
    return _entry(indptr, indices, nsgs_checked, _CHECKED, _CHECKED_ARGS)


def lemke_entry(indptr, indices):
    """:func:`lemke_checked_flat`'s entry point, as :func:`_checked_entry` (recorded in
    :data:`LEMKE_ENTRIES`)."""
    return _entry(indptr, indices, lemke_checked_flat, LEMKE_ENTRIES, _LEMKE_ARGS)


def flat_entry(indptr, indices):
    """:func:`nsgs_checked_flat`'s entry point, as :func:`_checked_entry` (recorded in
    :data:`FLAT_ENTRIES`)."""
    return _entry(indptr, indices, nsgs_checked_flat, FLAT_ENTRIES, _FLAT_ARGS)


_B, _I, _F = types.boolean, types.int64, types.float64
_OUT = types.Array(types.float64, 2, "C")
#: the argument types of :func:`nsgs_checked` and :func:`nsgs_checked_flat` after the two
#: CSR index arrays (whose dtype picks the entry point)
_CHECKED_ARGS = (F64_VECTOR, F64_VECTOR, F64_VECTOR, _I, _B, _F, _I, _B, _I, _F, _I, _F, _I, _I,
                 _F, _I, _I, _B, _I, _I, _I, _OUT)
_FLAT_ARGS = (F64_VECTOR, F64_VECTOR, F64_VECTOR, F64_VECTOR, _B, _F, _B, _F, _OUT)
#: :func:`lemke_checked_flat`'s, after the index arrays
_LEMKE_ARGS = (F64_VECTOR, F64_VECTOR, F64_VECTOR, _I, _B, _F, _OUT)


def _entry(indptr, indices, kernel, table, args):
    """The entry point of ``kernel`` for these index arrays and its other arguments' types
    ``args``, recorded in ``table`` by dtype."""
    dtype = indptr.dtype
    if indices.dtype != dtype or dtype not in _INDEX_DTYPES:
        return kernel
    ep = table.get(dtype)        # (an equal dtype that is not the same object: run's test)
    if ep is not None:
        return ep
    ix = index_vector(dtype)
    ep = table[dtype] = entry_point(kernel, (ix, ix) + args)
    return ep


def judge_norm(problem) -> float:
    """``||q~||`` of the dispatcher's balanced copy of ``problem`` (local) as ``solver="auto"``'s
    stage judge and the Newton backend compute it (NumPy's dot of ``q~``: the balancing kernel's
    own sum differs in the last bits), for :func:`trial_runner` and :func:`trial_outcome`
    (:func:`newton_checked` computes the same with numba's ``np.dot``; ``tests/test_route.py``
    holds the two equal)."""
    return judge_units(problem)[1]


def judge_units(problem):
    """``(a, ||q~||)``: the unit factors ``r = a r~`` of the dispatcher's balanced copy of
    ``problem`` (local) and :func:`judge_norm`, from one balancing pass."""
    indptr, indices, data = problem.csr_parts
    a, _, _, q_s = balance_csr(indptr, indices, data, problem.q, problem.mu, problem.dim)[:4]
    return a, float(np.sqrt(q_s.dot(q_s)))


def trial_runner(problem, norm_q, prox, stall_window, constants, full_info=False,
                 factorizations=0):
    """``run(r, tol, max_iter, alpha0, time_left)`` of
    :func:`socp_cd.solvers.newton.continued_runs` through :func:`trial_run` on
    ``problem`` (as written; ``norm_q``: :func:`judge_norm`): returns ``(status, r~,
    iterations, None, info)`` with ``info["internal_error"]`` and
    ``info["error_as_written"]``, and with ``full_info`` the Newton backend's ``info`` of
    a run (:func:`~socp_cd.solvers.kernels.newton_dense.run_info`: its counters, the
    factorizations of all runs of this runner and ``factorizations`` before them, as of
    one system).  ``time_left`` (seconds, None: no limit) is the run's deadline on the
    compiled clock (:mod:`~socp_cd.solvers.kernels.clock`).  None when the problem has
    more than :data:`TRIAL_MAX_M` unknowns."""
    q = problem.q
    if q.shape[0] > TRIAL_MAX_M:
        return None
    indptr, indices, data = problem.csr_parts
    mu, dim = problem.mu, problem.dim
    factorizations = [factorizations]

    def run(r, tol, max_iter, alpha0, time_left):
        r_s = np.empty(q.shape[0])
        fstate, istate = np.empty(nd.FSTATE), np.empty(nd.ISTATE, dtype=np.int64)
        fstate[nd.F_DEADLINE] = deadline_after(time_left)
        code, its, internal, e, wscale = trial_run(indptr, indices, data, q, mu, dim, r, norm_q,
                                                   tol, max_iter, stall_window, prox, constants,
                                                   alpha0, r_s, fstate, istate)
        info = run_record(fstate, istate, wscale, prox, internal, e, full_info,
                          factorizations[0])
        if full_info:
            factorizations[0] = info["factorizations"]
        return nd.STATUS_NAMES[code], r_s, int(its), None, info
    return run


def run_record(fstate, istate, wscale, prox, internal, e, full_info, factorizations=0):
    """The ``info`` of one compiled Newton run (:func:`trial_run`'s returns and end state):
    with ``full_info`` the Newton backend's (:func:`~socp_cd.solvers.kernels.newton_dense.run_info`,
    ``factorizations`` the earlier runs' count, this run's added), then ``internal_error``
    and ``error_as_written`` (what :func:`socp_cd.solvers.newton.continued_runs` reads)."""
    if full_info:
        ist = istate.tolist()
        info = nd.run_info(fstate.tolist(), ist, wscale, not prox,
                           factorizations + ist[nd.I_FACTORIZATIONS], "dense", "block",
                           nd.LAW_AC)
    else:
        info = {}
    info["internal_error"] = float(internal)
    info["error_as_written"] = float(e)
    return info


def trial_outcome(problem, norm_q, status, r_s):
    """The checks of a balanced answer ``r_s`` on ``problem`` (:func:`trial_checked`;
    ``norm_q``: :func:`judge_norm`): ``(RouteOutcome, judge_guard)`` (``status`` the
    answer's), or None when they are not finite."""
    indptr, indices, data = problem.csr_parts
    vectors = np.empty((3, problem.q.shape[0]))
    ok, x, judge_guard = trial_checked(indptr, indices, data, problem.q, problem.mu,
                                       problem.dim, r_s, norm_q, vectors)
    if not ok:              # (r, u not finite, or the checks cannot judge them)
        return None
    return RouteOutcome(status, vectors, x), judge_guard


__all__ = ["nsgs_checked", "nsgs_checked_flat", "lemke_checked_flat", "lemke_entry", "LEMKE_CODES",
           "checked_work", "run", "run_prepared", "flat_entry",
           "flat_settings", "FLAT_SETTINGS", "N_FLAT_SETTINGS",
           "FLAT_ENTRIES", "N_OUT",
           "flat_outcome", "flat_stats", "flat_rows", "prepared", "trial_run", "trial_checked", "newton_checked", "trial_runner", "run_record", "trial_outcome", "judge_norm", "judge_units",
           "checked_answer", "TRIAL_MAX_M", "TRIAL_CONSTANTS", "C_ALPHA0", "C_ALPHA_MIN", "RouteOutcome", "guard_record", "scaling_record", "STATS", "ROUTE_SETTINGS", "MAX_CONTACTS",
           "MIN_TIME_LIMIT", "MAX_TIMED_WORK", "SWEEPS", "INTERNAL_ERROR", "N_FULL", "N_FAIL",
           "LIGHT", "ERROR", "ZERO_ERROR", "START_ERROR", "MU_MAX", "GUARD_VALUE"]
