"""Compiled NSGS sweeps and error evaluation (numba, ``cache=True``).

:func:`nsgs_loop` runs the whole iteration — sweeps over contacts, one-contact
solves, light and full error evaluations, stopping rules — in compiled code;
the Python side (:mod:`socp_cd.solvers.nsgs`) only prepares arrays and decodes
the outcome.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .kernels.clock import past
from .kernels.cone import EPS, LAW_ASSOCIATED, error_parts, law_error, relative_error
from .kernels.scaling import origin_error
from .local_solvers import (KIND_PROJECTION, LOCAL_OK, NEEDS_PROJECTION, local_solve_first,
                            local_solve_rest)

STATUS_CONVERGED = 0
STATUS_MAX_ITER = 1
STATUS_STALLED = 2
STATUS_NUMERICAL = 3
STATUS_TIME_LIMIT = 4       # (the clock passed the sweeps' deadline)
#: stopped by the rate prediction (reported as ``"max_iter"``): a code of its own, so that a
#: run in blocks ends there even when the verdict falls on a block's last sweep, where the
#: block's own cap gives ``STATUS_MAX_ITER`` and the same count of sweeps
STATUS_PREDICTED = 5
#: with a deadline, the sweeps read the clock every ``max(1, CHECK_BLOCKS // nnzb)`` sweeps
#: (``nnzb``: blocks of ``W``): about every 10 µs of work (a clock read costs ~25 ns, a
#: block visit ~5 ns), so a run stops within one sweep or ~10 µs of its deadline
CHECK_BLOCKS = 2000
STATUS_NAMES = ("converged", "max_iter", "stalled", "numerical_error", "time_limit", "max_iter")


@njit(cache=True, inline="always")
def local_free_velocity(i, d, indptr, indices, blocks, q, r, b):
    """``b = q_i + sum_{j != i} W_ij r_j`` from block row ``i``."""
    for a in range(d):
        b[a] = q[i * d + a]
    for p in range(indptr[i], indptr[i + 1]):
        j = indices[p]
        if j == i:
            continue
        o = j * d
        for a in range(d):
            s = 0.0
            for c in range(d):
                s += blocks[p, a, c] * r[o + c]
            b[a] += s


@njit(cache=True)
def block_matvec(d, nc, indptr, indices, blocks, x, q, out):
    """``out = W x + q``."""
    for i in range(nc):
        for a in range(d):
            out[i * d + a] = q[i * d + a]
        for p in range(indptr[i], indptr[i + 1]):
            o = indices[p] * d
            for a in range(d):
                s = 0.0
                for c in range(d):
                    s += blocks[p, a, c] * x[o + c]
                out[i * d + a] += s


@njit(cache=True)
def full_error(d, nc, indptr, indices, blocks, q, r, mu, g, law, norm_q, u):
    """Relative residual of the law, ``||r - P(r - û)|| / max(||q||, ||r||, ||u||)``.

    ``u = W r + q`` is recomputed (into ``u``); the measure itself is
    :func:`socp_cd.solvers.kernels.cone.law_error` (= :func:`socp_cd.error`
    for Coulomb, :mod:`socp_cd.laws` for the other laws).
    """
    block_matvec(d, nc, indptr, indices, blocks, r, q, u)
    return law_error(r, u, mu, g, d, law, norm_q)


@njit(cache=True)
def full_errors(d, nc, indptr, indices, blocks, q, r, mu, g, law, norm_q, u):
    """:func:`full_error` and the stopping measure: the same residual over ``max(||q||, ||u||)``.

    The second is the dispatcher's units guard's measure
    (:func:`socp_cd.residuals.guard_values`: ``error``) on the (balanced)
    problem the sweeps see: ``||F|| / V`` with the velocity scale
    ``V = max(||q||, ||u||)`` (1 below eps).  Siconos' normalization also
    divides by ``||r||``; where ``||r||`` dominates, an ``r`` within ``tol``
    by Siconos' measure fails the guard, and the dispatcher would run NSGS
    once more.  Stopping on this measure stops where the dispatcher accepts.
    """
    block_matvec(d, nc, indptr, indices, blocks, r, q, u)
    f2, r2, u2 = error_parts(r, u, mu, g, d, law)
    vel = np.sqrt(u2)
    if norm_q > vel:
        vel = norm_q
    if not vel > EPS:
        vel = 1.0
    return relative_error(f2, r2, u2, norm_q), np.sqrt(f2) / vel


#: :func:`sweep_span`'s code for a contact whose new iterate is not finite
NOT_FINITE = -1


@njit(cache=True, inline="always")
def all_finite(x, d):
    """Whether ``x[:d]`` is finite."""
    for a in range(d):
        if not np.isfinite(x[a]):
            return False
    return True


@njit(cache=True, inline="always")
def load_contact(i, d, indptr, indices, blocks, q, r, b, rold, rl):
    """Contact ``i``'s free velocity into ``b`` and its iterate into ``rold`` and ``rl``."""
    local_free_velocity(i, d, indptr, indices, blocks, q, r, b)
    for a in range(d):
        rold[a] = r[i * d + a]
        rl[a] = r[i * d + a]


@njit(cache=True, inline="always")
def relax_into(r, o, d, rl, rold, omega, dsum):
    """``r[o:o+d] = omega rl + (1 - omega) rold``; returns ``dsum`` plus the squared change."""
    for a in range(d):
        v = omega * rl[a] + (1.0 - omega) * rold[a]
        e = v - rold[a]
        dsum += e * e
        r[o + a] = v
    return dsum


@njit(cache=True)
def sweep_span(k0, order, dims, indptr, indices, blocks, diag, q, r, mu, g, law, kind, rhoN,
               rhoT, loc_tol, newton_maxit, omega, b, rl, rold, M, dsum):
    """Contacts ``order[k0:]`` of one Gauss–Seidel sweep, up to the first one the cheap local
    attempt (:func:`~socp_cd.solvers.local_solvers.local_solve_first`) does not settle.

    The contact loop holds no call that is not inlined (see
    :func:`~socp_cd.solvers.local_solvers.local_solve_first`); the caller runs the rest of
    the local chain on the contact it stopped at and calls it again from the next one.
    ``dims``: a tuple of ``d`` entries (its length is a compile-time constant, so numba
    compiles a version per dimension with the ``d``-loops unrolled: a 304-contact sweep
    20 -> 14 µs).

    Returns
    -------
    kk, first, dsum
        ``kk = n_contacts`` when the sweep is done; else the position of the contact
        that stopped it, with ``b`` its free velocity, ``rold`` its iterate before and
        ``rl`` after the attempt, and ``first`` the attempt's code (or
        :data:`NOT_FINITE`: ``rl`` is not finite); ``dsum``: the squared change of
        ``r`` so far in this sweep.
    """
    d = len(dims)
    nc = diag.shape[0]
    for kk in range(k0, nc):
        i = order[kk]
        load_contact(i, d, indptr, indices, blocks, q, r, b, rold, rl)
        first = local_solve_first(kind, diag, i, b, mu[i], g[i], law, rhoN[i], rhoT[i], rl, d,
                                  loc_tol, newton_maxit, M)
        if first != LOCAL_OK:
            return kk, first, dsum
        if not all_finite(rl, d):
            return kk, NOT_FINITE, dsum
        dsum = relax_into(r, i * d, d, rl, rold, omega, dsum)
    return nc, LOCAL_OK, dsum


#: The block-sparse ``W`` (:mod:`socp_cd.solvers.block_storage`): block-row pointers,
#: block-column indices, the ``(nnzb, d, d)`` blocks and the ``(nc, d, d)`` diagonal blocks.
BlockW = namedtuple("BlockW", "indptr indices blocks diag")
#: The contact law: friction coefficients, Tresca thresholds (per contact) and the law code.
Law = namedtuple("Law", "mu g code")
#: One-contact solver: kind code, per-contact steps and its tolerance and caps.
LocalSolver = namedtuple("LocalSolver", "kind rhoN rhoT rhoP tol newton_max_iter projection_max_iter")
#: The units of the problem as written, when the sweeps run on the dispatcher's balanced copy
#: of it: unit factors ``a, b`` (``r = a r~``, ``u = b u~``) and ``q_norm = ||q||``
#: (:func:`~socp_cd.solvers.kernels.scaling.origin_error`, Coulomb law only);
#: ``q_norm < 0``: none (the sweeps' own measures only).
Origin = namedtuple("Origin", "a b q_norm")
#: Sweep settings: tolerance, cap, relaxation, ordering, error policy, recording, and the
#: rate prediction (``predict_window`` sweeps, 0: off; ``predict_budget``: the sweeps the
#: run may still do from the start of this call; ``predict_prev``: the full error at the
#: end of the window before this call, -1 for none: a run in blocks of whole windows
#: carries it from one block to the next), and the deadline on the compiled clock
#: (:mod:`~socp_cd.solvers.kernels.clock`; ``inf``: none): past it the loop stops with
#: ``STATUS_TIME_LIMIT``.
Sweeps = namedtuple("Sweeps", "tol max_iter omega shuffle seed error_every stall_window record "
                              "predict_window predict_budget predict_prev deadline")


@njit(cache=True)
def nsgs_loop(d, W, q, law, local, sweeps, r, hist, origin):
    """Nonsmooth block Gauss–Seidel iterations, in place on ``r``.

    ``W`` is a :data:`BlockW`, ``law`` a :data:`Law`, ``local`` a
    :data:`LocalSolver`, ``sweeps`` a :data:`Sweeps`, ``origin`` an
    :data:`Origin` (:func:`no_origin`: none; numba takes these named tuples
    as they are).

    Error policy (Siconos' ``LIGHT_WITH_FULL_FINAL`` plus a periodic check):
    after each sweep the light error ``||r_k+1 - r_k|| / ||r_k+1||`` is
    accumulated contact by contact; the full relative error is evaluated when
    the light error drops below the light tolerance (initially ``tol``; on a
    false alarm it is tightened to ``light * tol / full``), every
    ``error_every`` sweeps (``0``: never), at the last sweep, and at every
    sweep when ``record`` or when the contacts do not couple (one contact, or
    ``W`` block diagonal with ``omega = 1``: each local solve is then its whole
    problem, and such a call stops after one sweep, not two).  Convergence is
    declared on the full error only:
    Siconos' relative error and the same residual relative to the velocity
    scale (:func:`full_errors`, the dispatcher's units-guard measure) must
    both be ``<= tol``; ``error`` is Siconos'.  With an ``origin`` (the sweeps
    run on the dispatcher's balanced copy of a Coulomb problem) a third
    measure must be too: Siconos' error of the problem as written
    (:func:`~socp_cd.solvers.kernels.scaling.origin_error`, evaluated only
    when the other two pass), the one
    the dispatcher judges by; when it fails, the pass counts as a false alarm
    of the light error (its tolerance is tightened, the sweeps go on), where
    the dispatcher would refuse the claim and run NSGS once more.

    Rate prediction (``predict_window = w > 0``): the full error is also
    evaluated every ``w`` sweeps; from the second such evaluation on, its
    mean rate over the last ``w`` sweeps, ``c = (e_k / e_{k-w})^(1/w)``,
    predicts ``k + log(e_k / tol) / log(1 / c)`` sweeps to reach ``tol``
    (infinitely many when ``c >= 1``); when that exceeds ``predict_budget``
    the loop stops with ``STATUS_PREDICTED`` (reported as ``"max_iter"``) after
    ``k`` sweeps: the cap would be reached first (``solver="auto"`` hands such an
    NSGS stage over early).  The verdict is made at every window's end before
    the run's last sweep, a block's last sweep included.

    Deadline (``sweeps.deadline < inf``): the clock is read after every
    ``max(1, CHECK_BLOCKS // nnzb)`` sweeps that did not end the run; past the
    deadline the loop stops with ``STATUS_TIME_LIMIT`` (a time-limited run stops
    within about one sweep of its limit; until session 25 the callers read the
    clock between blocks of 10, 20, 40, ... sweeps only).

    Returns
    -------
    status, iterations, error, n_full_evaluations, n_local_failures, light_error, hist
        ``hist`` holds the full error of every sweep when ``record`` (the buffer
        passed in, doubled whenever it is full: nothing is allocated up front).
    """
    indptr, indices, blocks, diag = W.indptr, W.indices, W.blocks, W.diag
    nc = diag.shape[0]
    mu, g, law = law.mu, law.g, law.code
    kind, rhoN, rhoT, rhoP = local.kind, local.rhoN, local.rhoT, local.rhoP
    loc_tol, newton_maxit, proj_maxit = local.tol, local.newton_max_iter, local.projection_max_iter
    tol, max_iter, omega, shuffle = sweeps.tol, sweeps.max_iter, sweeps.omega, sweeps.shuffle
    seed, error_every, stall_window, record = (sweeps.seed, sweeps.error_every,
                                               sweeps.stall_window, sweeps.record)
    window, budget = sweeps.predict_window, sweeps.predict_budget
    window_err = sweeps.predict_prev    # the full error at the previous window's end (-1: none)
    deadline = sweeps.deadline
    check_every = max(1, CHECK_BLOCKS // max(indptr[nc], 1))
    # W block diagonal (one stored block per contact; the callers decline a contact whose
    # diagonal block is missing or not positive before the sweeps, local_parameters' ``bad``,
    # so that block is its diagonal one): the contacts do not couple, each local solve is its
    # whole problem, and without relaxation (omega = 1) one sweep is the answer: checked at
    # once, as one contact's always was (a 20-sphere pile on its floor: 1 sweep, not 2)
    decoupled = nc == 1 or (indptr[nc] == nc and omega == 1.0)
    order = np.arange(nc)
    if shuffle:
        np.random.seed(seed)
    # one allocation for the small buffers, M and u (each costs ~20 ns of a one-contact call's
    # few µs)
    buf = np.zeros(7 * d + d * (d + 1) + nc * d)
    small = buf[:7 * d].reshape((7, d))
    work = small[:4]            # local_solve's buffer (rows 0-3)
    b, rl, rold = small[4], small[5], small[6]
    M = buf[7 * d:(8 + d) * d].reshape((d, d + 1))
    u = buf[(8 + d) * d:]
    norm_q = 0.0
    for k in range(nc * d):
        norm_q += q[k] * q[k]
    norm_q = np.sqrt(norm_q)
    light_tol = tol
    best = np.inf
    best_iter = 0
    err = np.inf
    light = np.inf
    n_full = 0
    n_fail = 0
    # the projection fixed point is the whole local chain (local_solve_first declines it)
    projection_only = law == LAW_ASSOCIATED or kind == KIND_PROJECTION
    for it in range(1, max_iter + 1):
        if shuffle:
            np.random.shuffle(order)
        dsum = 0.0
        kk = np.int64(0)      # (not the literal 0: numba would compile sweep_span for it apart)
        while kk < nc:
            if projection_only:
                # every contact takes the rest of the chain: no span to run first
                load_contact(order[kk], d, indptr, indices, blocks, q, r, b, rold, rl)
                first = NEEDS_PROJECTION
            # (the dimension as a tuple's length: a compile-time constant in each version)
            elif d == 3:
                kk, first, dsum = sweep_span(kk, order, (0, 0, 0), indptr, indices, blocks, diag,
                                             q, r, mu, g, law, kind, rhoN, rhoT, loc_tol,
                                             newton_maxit, omega, b, rl, rold, M, dsum)
            else:
                kk, first, dsum = sweep_span(kk, order, (0, 0), indptr, indices, blocks, diag, q,
                                             r, mu, g, law, kind, rhoN, rhoT, loc_tol,
                                             newton_maxit, omega, b, rl, rold, M, dsum)
            if kk == nc:
                break
            # contact order[kk] needs the rest of the local chain (or broke)
            i = order[kk]
            if first != NOT_FINITE:
                flag = local_solve_rest(first, diag, i, b, mu[i], g[i], law, rhoN[i], rhoT[i],
                                        rhoP[i], rl, rold, d, loc_tol, newton_maxit, proj_maxit,
                                        work, M)
                if flag != LOCAL_OK:
                    n_fail += 1
                if all_finite(rl, d):
                    dsum = relax_into(r, i * d, d, rl, rold, omega, dsum)
                else:
                    first = NOT_FINITE
            if first == NOT_FINITE:
                err = full_error(d, nc, indptr, indices, blocks, q, r, mu, g, law, norm_q, u)
                return STATUS_NUMERICAL, it, err, n_full + 1, n_fail, light, hist
            kk += 1
        nr = 0.0
        for k in range(nc * d):
            nr += r[k] * r[k]
        nr = np.sqrt(nr)
        light = np.sqrt(dsum)
        if nr > 2.220446049250313e-16:
            light /= nr
        full_now = record or light <= light_tol or it == max_iter or decoupled
        if error_every > 0 and it % error_every == 0:
            full_now = True
        window_end = window > 0 and it % window == 0
        if window_end:
            full_now = True
        if full_now:
            err, stop = full_errors(d, nc, indptr, indices, blocks, q, r, mu, g, law, norm_q, u)
            n_full += 1
            if record:
                hist = recorded(hist, it, err)
            if not np.isfinite(err):
                return STATUS_NUMERICAL, it, err, n_full, n_fail, light, hist
            worst = stop if stop > err else err      # (stop >= err unless ||q||, ||u|| < eps)
            if worst <= tol and origin.q_norm >= 0.0:
                orig = origin_error(r, u, origin.a, origin.b, mu, d, origin.q_norm)
                if not orig <= worst:
                    worst = orig if orig < np.inf else np.inf      # (NaN: not met, as inf)
            if worst <= tol:
                return STATUS_CONVERGED, it, err, n_full, n_fail, light, hist
            if light <= light_tol:
                if light == 0.0:
                    # the sweep is a fixed point but not a solution
                    return STATUS_STALLED, it, err, n_full, n_fail, light, hist
                light_tol = light * tol / worst
            if err < 0.99 * best:
                best = err
                best_iter = it
            elif stall_window > 0 and it - best_iter >= stall_window:
                return STATUS_STALLED, it, err, n_full, n_fail, light, hist
            if window_end:
                # (the run's last sweep, it == budget, needs no verdict; a block's last one
                # does: until session 45 `it < max_iter` skipped it, so a run in blocks made
                # its verdicts a window later than one run did)
                if window_err > 0.0 and it < budget and predicted_sweeps(
                        it, window, window_err, err, tol) > budget:
                    return STATUS_PREDICTED, it, err, n_full, n_fail, light, hist
                window_err = err
        if it % check_every == 0 and it < max_iter and past(deadline):
            if not full_now:        # (the error of the iterate returned, as at a block's end)
                err, _ = full_errors(d, nc, indptr, indices, blocks, q, r, mu, g, law, norm_q, u)
                n_full += 1
            return STATUS_TIME_LIMIT, it, err, n_full, n_fail, light, hist
    return STATUS_MAX_ITER, max_iter, err, n_full, n_fail, light, hist


@njit(cache=True)
def whole_windows(sweeps, window):
    """The first block of a run in blocks (``sweeps``, doubled from block to block), rounded up
    to whole windows of the rate prediction (``window``; 0: off), so that every block ends on
    a window's end and the prediction goes on across blocks as in one run."""
    if window <= 0:
        return sweeps
    return -(-sweeps // window) * window


@njit(cache=True)
def recorded(hist, it, err):
    """``hist`` with ``hist[it - 1] = err`` (a history buffer, grown by doubling when full)."""
    if it > hist.shape[0]:
        grown = np.full(2 * hist.shape[0], np.nan)
        grown[:hist.shape[0]] = hist
        hist = grown
    hist[it - 1] = err
    return hist


def timed_next_block(status, its, block, done, max_iter, err, window, started, time_limit, clock):
    """:func:`next_block` of a run under ``time_limit`` seconds since ``started`` (``clock()``):
    ``(sweeps of the next block, its prediction error, out of time)``; ``(0, -1, False)``
    when the run is over, ``(0, -1, True)`` when a next block is due but the time is spent."""
    nxt, prev = next_block(status, its, block, done, max_iter, err, window)
    if not nxt:
        return 0, -1.0, False
    if clock() - started > time_limit:
        return 0, -1.0, True
    return nxt, prev, False


@njit(cache=True)
def next_block(status, its, block, done, max_iter, err, window):
    """A run in blocks (the time-limited NSGS backend and the compiled route alike), after a
    block of ``block`` sweeps that ran ``its`` of them (``done`` in all, the last full error
    ``err``): ``(sweeps of the next block, the error the rate prediction carries into it)``,
    ``(0, -1)`` when the run is over (converged, stalled, broken, out of sweeps, or stopped
    by the rate prediction: ``STATUS_PREDICTED``)."""
    if status != STATUS_MAX_ITER or done >= max_iter or its < block:
        return 0, -1.0
    prev = err if window > 0 and done % window == 0 else -1.0
    return min(2 * block, max_iter - done), prev


@njit(cache=True)
def predicted_sweeps(it, window, e_before, e_now, tol):
    """Sweeps to reach ``tol`` predicted from the mean linear rate of the error over the last
    ``window`` sweeps (``e_before`` then ``e_now``, after sweep ``it``): ``it + log(e_now /
    tol) / log(1 / c)``, ``c = (e_now / e_before)^(1 / window)``; ``inf`` when ``c >= 1``."""
    if not (e_now > 0.0 and e_before > 0.0) or e_now >= e_before:
        return np.inf
    if e_now <= tol:
        return float(it)
    return it + np.log(e_now / tol) * window / np.log(e_before / e_now)


@njit(cache=True)
def local_parameters(diag, blocks):
    """Per-contact step sizes of the local solvers and ill-posed contacts.

    Returns
    -------
    rhoN, rhoT, rhoP : ndarray, shape (n_contacts,)
        ``rhoN = 1 / W_NN``; ``rhoT = 1 / lambda_max`` of the symmetric part of
        the tangential block (Siconos' "split spectral norm" choice);
        ``rhoP = 1 / ||W_ii||_F`` for the projection fixed point.
    bad : ndarray of bool
        Contacts whose ``W_NN <= 1e-14 max|W|`` (no well-posed local problem).
    """
    nc = diag.shape[0]
    d = diag.shape[1]
    scale = 0.0
    for p in range(blocks.shape[0]):
        for a in range(d):
            for c in range(d):
                if abs(blocks[p, a, c]) > scale:
                    scale = abs(blocks[p, a, c])
    if scale == 0.0:
        scale = 1e-300
    rho = np.zeros((3, nc))     # (one allocation: rows rhoN, rhoT, rhoP)
    rhoN, rhoT, rhoP = rho[0], rho[1], rho[2]
    bad = np.zeros(nc, dtype=np.bool_)
    for i in range(nc):
        wn = diag[i, 0, 0]             # element by element: no array view per contact
        if not (wn > 1e-14 * scale):
            bad[i] = True
            continue
        rhoN[i] = 1.0 / wn
        if d == 2:
            lt = diag[i, 1, 1]
        else:
            a = diag[i, 1, 1]
            c = diag[i, 2, 2]
            bs = 0.5 * (diag[i, 1, 2] + diag[i, 2, 1])
            lt = 0.5 * (a + c) + np.sqrt(0.25 * (a - c) ** 2 + bs * bs)
        rhoT[i] = 1.0 / lt if lt > 0.0 else rhoN[i]
        fro = 0.0
        for a2 in range(d):
            for c2 in range(d):
                fro += diag[i, a2, c2] * diag[i, a2, c2]
        rhoP[i] = 1.0 / np.sqrt(fro)
    return rhoN, rhoT, rhoP, bad


def no_origin():
    """The :data:`Origin` meaning "none": the sweeps judge by their own measures only."""
    return Origin(np.empty(0), np.empty(0), -1.0)

