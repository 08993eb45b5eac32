"""The proximal-point semismooth Newton loop on a small dense ``W``, compiled (numba).

The compiled twin of :func:`socp_cd.solvers.newton.prox_newton` (policy
``"prox"``, no history) for a dense local problem ``u = W r + q``
(``m <= COMPILED_LOOP_MAX_M`` of :mod:`socp_cd.solvers.newton`).
The Python function is the reference and the path of every other case
(sparse or global systems, ``policy="hybrid"`` or ``"prox_error"``'s own loop,
``history=True``, values of ``rho`` given per contact); the plain-steps loop
(:func:`plain_newton_dense`) is the twin of ``policy="plain"``, and both take the
equation of the law (:func:`law_blocks`);
``tests/test_newton_dense.py`` holds the two equal (same status, same number of
outer iterations, same counters, same ``r``).  Both call the same kernels in
the same order (the equation's kernel through :func:`law_blocks`, :func:`~.newton_ac.dense_jacobian`,
:func:`~.dense.dense_solve`, :func:`~.dense.matvec_into`,
:func:`~.cone.siconos_error`), so the iterates agree to the last bit; what the
twin removes is the interpreter and the small temporaries of the loop body
(~35 µs per inner Newton step on a 1-contact problem).

The whole state of a run lives in two small arrays (:data:`FSTATE` floats,
:data:`ISTATE` integers) and two iterates, so a run can be split into calls
(:func:`prox_newton_dense` stops after outer iteration ``it_end``).  A time
limit is a deadline on :mod:`~.clock`'s clock in the float state
(``F_DEADLINE``), read after every outer iteration and, in the proximal loop,
before every factorization of a subproblem but its first (a subproblem is cut
there: the outer iteration ends), where the Python reference reads its clock:
the loop then stops with :data:`TIME_LIMIT` (an outer iteration that starts
does one Newton step; a run overruns its limit by at most one factorization).

Equations and the meaning of every step: ``formulations/newton.md`` and the
Python reference.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .clock import past
from .cone import pair_scale, project_cone_stacked, siconos_error
from .dense import dense_solve, matvec, matvec_into
from .newton_ac import ac_blocks, dense_jacobian
from .newton_fb import fb_blocks
from .newton_nm import nm_blocks

#: run status codes (``RUNNING`` after the last call means the step cap was reached;
#: ``TIME_LIMIT``: the clock passed the deadline ``F_DEADLINE``)
RUNNING, CONVERGED, STALLED, NUMERICAL_ERROR, TIME_LIMIT = 0, 1, 2, 3, 4
#: the solver statuses of the codes (``RUNNING``: the step cap was reached)
STATUS_NAMES = {RUNNING: "max_iter", CONVERGED: "converged", STALLED: "stalled",
                NUMERICAL_ERROR: "numerical_error", TIME_LIMIT: "time_limit"}
#: slots of the float state: proximal parameter, largest one used, current error, best error,
#: the run's deadline on :func:`~.clock.monotonic`'s clock (``inf``: none)
F_ALPHA, F_ALPHA_MAX_USED, F_ERR, F_BEST_ERR, F_DEADLINE = 0, 1, 2, 3, 4
FSTATE = 5
#: slots of the integer state: started flag, status, outer iterations, outer iteration of
#: the last 10 % drop of the best error, then the counters of ``prox_newton``'s info
(I_STARTED, I_STATUS, I_IT, I_BEST_IT, I_NEWTON, I_BACKTRACK, I_LS_FAIL, I_SINGULAR,
 I_REJECTED, I_FACTORIZATIONS) = range(10)
#: ... and (plain policy) whether the next step tries the regularized matrix first (set when
#: a step's retry with it worked, cleared when a retry without it did)
I_REGULARIZED = 10
#: ... and (proximal loop) the null-space drift test's count of outer iterations in a row that
#: pass it, and whether the run stopped on it (:func:`prox_newton_dense`'s ``drift``)
I_DRIFT, I_DRIFT_STOP = 11, 12
ISTATE = 13
#: codes of the equations of the law the loops solve (their ``law`` argument), by the
#: backend's names (``newton.EQUATIONS``)
LAW_AC, LAW_NM, LAW_FB = 0, 1, 2
LAW_CODES = {"alart_curnier": LAW_AC, "natural_map": LAW_NM, "fischer_burmeister": LAW_FB}
LAW_NAMES = {code: name for name, code in LAW_CODES.items()}


@njit(cache=True, inline="always")
def law_blocks(law, r, u, mu, rho_n, rho_t, d, want_jac, F, Dr, Du, branch):
    """The kernel of the equation ``law`` (:data:`LAW_CODES`):
    :func:`~.newton_ac.ac_blocks`, :func:`~.newton_nm.nm_blocks` or
    :func:`~.newton_fb.fb_blocks`, same arguments and return value (``||F||``); an unknown
    code fills ``F`` with NaN and returns NaN (the loops then end ``NUMERICAL_ERROR``).

    ``want_jac`` goes on as a run-time ``bool``: the loops pass the literals ``True`` and
    ``False``, for which numba would compile each kernel apart, twice more than the
    backend's own calls need (a fresh install's compile time, ``validation/compile_cost.py``)."""
    jac = np.bool_(want_jac)
    if law == LAW_AC:
        return ac_blocks(r, u, mu, rho_n, rho_t, d, jac, F, Dr, Du, branch)
    if law == LAW_NM:
        return nm_blocks(r, u, mu, rho_n, rho_t, d, jac, F, Dr, Du, branch)
    if law == LAW_FB:
        return fb_blocks(r, u, mu, rho_n, rho_t, d, jac, F, Dr, Du, branch)
    F[:] = np.nan
    return np.nan


def new_state(alpha, deadline=np.inf):
    """Fresh ``(fstate, istate)`` of a run starting with proximal parameter ``alpha``, to
    stop at ``deadline`` (:func:`~.clock.deadline_after`; ``inf``: no time limit)."""
    fstate = np.zeros(FSTATE)
    fstate[F_ALPHA] = alpha
    fstate[F_ALPHA_MAX_USED] = alpha
    fstate[F_DEADLINE] = deadline
    return fstate, np.zeros(ISTATE, dtype=np.int64)


def run_info(fs, ist, wscale, plain, factorizations, linear_solver, rho, law) -> dict:
    """``info`` of a run of these loops as the Newton backend reports it
    (:func:`socp_cd.solvers.newton.prox_newton`'s keys): ``fs``, ``ist`` the run's state
    (:func:`new_state`) as lists, ``wscale`` the block scale of ``W`` (the proximal
    parameter's unit), ``plain`` the plain-steps loop, ``factorizations`` the system's
    count so far (this run's included), ``linear_solver`` its kind, ``rho`` the
    strategy of the equation's parameters, ``law`` the equation's code (:data:`LAW_CODES`)."""
    alpha = fs[F_ALPHA]
    return {"alpha": alpha, "alpha_relative": alpha / wscale,
            "alpha_max_relative": fs[F_ALPHA_MAX_USED] / wscale,
            "newton_steps": ist[I_NEWTON], "plain_steps": ist[I_NEWTON] if plain else 0,
            "policy": "plain" if plain else "prox",
            "backtracks": ist[I_BACKTRACK], "line_search_failures": ist[I_LS_FAIL],
            "singular_steps": ist[I_SINGULAR], "rejected_outer": ist[I_REJECTED],
            "factorizations": factorizations, "linear_solver": linear_solver,
            "internal_error": min(fs[F_ERR], fs[F_BEST_ERR]), "rho": rho,
            "equation": LAW_NAMES[law], "stop": "null_drift" if ist[I_DRIFT_STOP] else ""}


@njit(cache=True)
def _start(W, q, norm_q, mu, d, tol, r, best_r, fstate, istate, velocity):
    """``u = W r + q``; on a run's first call its error (Siconos', or :func:`velocity_error`
    of it when ``velocity``) recorded as the current and best one, ``best_r = r``, and
    ``CONVERGED`` when it already meets ``tol``.  Returns ``(u, status, it, best_it, err,
    best_err)`` of the run so far."""
    u = np.empty(r.shape[0])
    matvec_into(W, r, q, u)
    if istate[I_STARTED] == 0:
        istate[I_STARTED] = 1
        err0 = siconos_error(r, u, mu, d, norm_q)
        if velocity:
            err0 = velocity_error(err0, r, u, norm_q)
        fstate[F_ERR] = err0
        fstate[F_BEST_ERR] = err0
        best_r[:] = r
        if err0 <= tol:
            istate[I_STATUS] = CONVERGED
    return (u, istate[I_STATUS], istate[I_IT], istate[I_BEST_IT], fstate[F_ERR],
            fstate[F_BEST_ERR])


@njit(cache=True)
def _buffers(m, nc, d):
    """Work arrays of one call: ``F, Ft, mF, ua, rk, rt, ut`` (m), ``J`` (m, m),
    ``Dr, Du`` (nc, d, d), ``branch`` (nc)."""
    return (np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m),
            np.empty(m), np.empty((m, m)), np.empty((nc, d, d)), np.empty((nc, d, d)),
            np.empty(nc, dtype=np.int64))


@njit(cache=True)
def drift_step(solved, err, err_k, r, rk, u, uk, wscale, change, null):
    """The null-space drift test's verdict on an outer iteration of the proximal loop
    (``formulations/newton.md`` §7): 1, a *drift step*: its subproblem was solved, the error
    moved by at most ``change`` relative (``|err - err_k| <= change err_k``), and the step
    barely moved the velocity, ``||u - u_k|| <= null * wscale * ||r - r_k||`` with
    ``r - r_k != 0`` (a step near the null space of ``W``; ``wscale`` the block scale of
    ``W``); 0, neutral: an unsolved subproblem that did not cut the error by more than
    ``change`` relative (a failed try at a smaller proximal parameter); -1 otherwise.  The
    loops count drift steps in a row, neutral ones skipped; the reference and the compiled
    loop both call it."""
    if not solved:
        return 0 if err >= (1.0 - change) * err_k else -1
    if not abs(err - err_k) <= change * err_k:
        return -1
    dr2 = 0.0
    du2 = 0.0
    for k in range(r.shape[0]):
        dr2 += (r[k] - rk[k]) * (r[k] - rk[k])
        du2 += (u[k] - uk[k]) * (u[k] - uk[k])
    return 1 if dr2 > 0.0 and np.sqrt(du2) <= null * wscale * np.sqrt(dr2) else -1


@njit(cache=True)
def _measure(W, q, norm_q, mu, d, tol, r, rk, u, best_r, it, best_it, best_err, velocity):
    """End of an outer iteration: ``u = W r + q``, the error of ``r`` (as :func:`_start`),
    the best iterate kept (``best_it`` moves on a 10 % drop).  Returns ``(err, best_it,
    best_err, status)``: ``NUMERICAL_ERROR`` (``r`` reset to ``rk``) on a non-finite
    error, ``CONVERGED`` when it meets ``tol``, else ``RUNNING``."""
    matvec_into(W, r, q, u)
    err = siconos_error(r, u, mu, d, norm_q)
    if velocity:
        err = velocity_error(err, r, u, norm_q)
    if not np.isfinite(err):
        r[:] = rk
        return err, best_it, best_err, NUMERICAL_ERROR
    if err < best_err:
        if err < 0.9 * best_err:
            best_it = it
        best_err = err
        best_r[:] = r
    return err, best_it, best_err, (CONVERGED if err <= tol else RUNNING)


@njit(cache=True)
def _store(istate, fstate, status, it, best_it, n_newton, n_backtrack, n_ls_fail, n_singular,
           n_rejected, n_fact, err, best_err):
    """Write a call's end state and add its counters to the run's."""
    istate[I_STATUS] = status
    istate[I_IT] = it
    istate[I_BEST_IT] = best_it
    istate[I_NEWTON] += n_newton
    istate[I_BACKTRACK] += n_backtrack
    istate[I_LS_FAIL] += n_ls_fail
    istate[I_SINGULAR] += n_singular
    istate[I_REJECTED] += n_rejected
    istate[I_FACTORIZATIONS] += n_fact
    fstate[F_ERR] = err
    fstate[F_BEST_ERR] = best_err


@njit(cache=True)
def prox_newton_dense(W, q, norm_q, mu, rho_n, rho_t, d, tol, it_end, a_min, a_max,
                      inner_max_iter, stall_window, armijo, max_backtrack, nonmonotone,
                      inner_gate, inner_decrease, r, best_r, fstate, istate, lapack, law,
                      drift):
    """Run outer proximal iterations until ``it_end``, convergence, stall or a non-finite error.

    Parameters
    ----------
    W : ndarray (m, m), C-contiguous
    q : ndarray (m,)
    norm_q : float
        ``||q||`` (the normalization of Siconos' error).
    mu, rho_n, rho_t : ndarray (nc,)
        Friction coefficients and the equation's parameters.
    d : int
    tol : float
    it_end : int
        Stop after this outer iteration (the caller's ``max_iter``, or the end of a chunk).
    a_min, a_max : float
        Absolute bounds of the proximal parameter.
    inner_max_iter, stall_window : int
    armijo, max_backtrack, nonmonotone : float, int, float
        The line-search and acceptance constants of the reference.
    inner_gate, inner_decrease : float
        The reference's test of a solved subproblem (``newton.INNER_GATE``,
        ``newton.INNER_DECREASE``).
    r, best_r : ndarray (m,)
        Current and best iterate, updated in place (``r`` is the start on the first call).
    fstate, istate : ndarray
        Run state (:func:`new_state`), updated in place.
    lapack : tuple of two ints
        The LU of :func:`~.dense.dense_solve` (:data:`~.dense.LAPACK_LU`, or
        :data:`~.dense.WRITTEN_OUT`: the written-out one).
    law : int
        The equation of the law (:data:`LAW_CODES`; ``rho_t`` is read by Alart–Curnier's only).
    drift : tuple of four floats
        ``(window, change, null, wscale)``: the run stops ``STALLED`` (``I_DRIFT_STOP`` set)
        after ``window`` outer iterations in a row that are :func:`drift_step` steps with
        ``change``, ``null`` and the block scale ``wscale`` (its neutral iterations skipped);
        ``window`` 0: no such test.

    Notes
    -----
    Cost bound of one call: at most ``(it_end - it) * inner_max_iter`` LU
    factorizations of the ``m x m`` Newton matrix and ``max_backtrack`` residual
    evaluations per factorization.  The caller restores the best iterate when
    the run does not converge (as the reference does after its loop).
    """
    m = r.shape[0]
    nc = mu.shape[0]
    # (flags as run-time bools, not literals, here and below: see law_blocks)
    u, status, it, best_it, err, best_err = _start(W, q, norm_q, mu, d, tol, r, best_r, fstate,
                                                   istate, np.bool_(False))
    alpha = fstate[F_ALPHA]
    alpha_max_used = fstate[F_ALPHA_MAX_USED]
    # (counters start as int64, not the literal 0: _store is compiled once)
    n_newton = n_backtrack = n_ls_fail = n_singular = n_rejected = n_fact = np.int64(0)
    F, Ft, mF, ua, rk, rt, ut, J, Dr, Du, branch = _buffers(m, nc, d)
    drift_window = int(drift[0])
    uk = np.empty(m if drift_window > 0 else 0)
    while status == RUNNING and it < it_end:
        it += 1
        rk[:] = r
        if drift_window > 0:
            uk[:] = u
        err_k = err
        if alpha > alpha_max_used:
            alpha_max_used = alpha
        sub_ok = True
        solved = False
        for _inner in range(inner_max_iter):
            for k in range(m):
                ua[k] = u[k] + alpha * (r[k] - rk[k])
            nF = law_blocks(law, r, ua, mu, rho_n, rho_t, d, True, F, Dr, Du, branch)
            if nF == 0.0:
                solved = True
                break
            if _inner > 0 and past(fstate[F_DEADLINE]):
                break           # (the subproblem cut: the outer iteration ends, then the run)
            n_fact += 1
            dense_jacobian(Dr, Du, W, alpha, d, J)
            for k in range(m):
                mF[k] = -F[k]
            dr, ok = dense_solve(J, mF, lapack, np.bool_(False))
            if not ok:
                n_singular += 1
                sub_ok = False
                break
            du = matvec(W, dr)
            n_newton += 1
            phi = 0.5 * nF * nF
            t = 1.0
            nFt = 0.0
            found = False
            for _bt in range(max_backtrack):
                for k in range(m):
                    rt[k] = r[k] + t * dr[k]
                    ut[k] = u[k] + t * du[k]
                for k in range(m):
                    ua[k] = ut[k] + alpha * (rt[k] - rk[k])
                nFt = law_blocks(law, rt, ua, mu, rho_n, rho_t, d, False, Ft, Dr, Du, branch)
                if 0.5 * nFt * nFt <= (1.0 - 2.0 * armijo * t) * phi:
                    found = True
                    break
                t *= 0.5
                n_backtrack += 1
            if not found:
                n_ls_fail += 1
                sub_ok = False
                break
            r[:] = rt
            u[:] = ut
            if t == 1.0 and nFt <= inner_gate * nF and (
                    nFt <= inner_decrease * nF or siconos_error(r, u, mu, d, norm_q) <= tol):
                solved = True
                break
        err, best_it, best_err, status = _measure(W, q, norm_q, mu, d, tol, r, rk, u, best_r,
                                                  it, best_it, best_err, np.bool_(False))
        if status != RUNNING:
            break
        if drift_window > 0:
            verdict = drift_step(solved, err, err_k, r, rk, u, uk, drift[3], drift[1], drift[2])
            if verdict > 0:
                istate[I_DRIFT] += 1
            elif verdict < 0:
                istate[I_DRIFT] = 0
        if solved and err < err_k:
            alpha = max(a_min, alpha * 0.1)
        elif not (solved and err <= nonmonotone * best_err) and (not sub_ok or err >= err_k):
            alpha = min(a_max, alpha * 10.0)
            if err > err_k:
                n_rejected += 1
                r[:] = rk
                err = err_k
                matvec_into(W, r, q, u)
        if drift_window > 0 and istate[I_DRIFT] >= drift_window:
            istate[I_DRIFT_STOP] = 1
            status = STALLED
            break
        if stall_window > 0 and it - best_it >= stall_window:
            status = STALLED
            break
        if past(fstate[F_DEADLINE]):
            status = TIME_LIMIT
            break
    _store(istate, fstate, status, it, best_it, n_newton, n_backtrack, n_ls_fail, n_singular,
           n_rejected, n_fact, err, best_err)
    fstate[F_ALPHA] = alpha
    fstate[F_ALPHA_MAX_USED] = alpha_max_used


@njit(cache=True)
def velocity_error(err, r, u, norm_q):
    """Siconos' error ``err`` of ``(r, u)`` re-normalized by ``max(||q||, ||u||)``.

    The ``"error"`` entry of :func:`socp_cd.residuals.guard_values` (the
    units guard's measure in balanced units; norms of ``r``, ``u`` summed here
    in index order, to rounding the reference's): ``err * max(||q||, ||r||,
    ||u||) / max(||q||, ||u||)``, each maximum replaced by 1 when it is not
    above machine epsilon.  :func:`socp_cd.solvers.newton.velocity_relative_error`
    calls it, so the plain policy measures the same number on both loops.
    """
    r2 = 0.0
    for k in range(r.shape[0]):
        r2 += r[k] * r[k]
    u2 = 0.0
    for k in range(u.shape[0]):
        u2 += u[k] * u[k]
    r_norm, u_norm = np.sqrt(r2), np.sqrt(u2)
    if not (np.isfinite(r_norm) and np.isfinite(u_norm)):
        # squares beyond the largest float (entries beyond ~1e154): the norms of the pair
        # and ||q|| scaled by its largest entry (the ratio below is the same)
        c = pair_scale(r, u)
        if not (np.isfinite(c) and c > 0.0):
            return np.inf
        r2 = 0.0
        u2 = 0.0
        for k in range(r.shape[0]):
            r2 += (r[k] / c) * (r[k] / c)
            u2 += (u[k] / c) * (u[k] / c)
        r_norm, u_norm, norm_q = np.sqrt(r2), np.sqrt(u2), norm_q / c
    eps = 2.220446049250313e-16
    vel = max(norm_q, u_norm)
    vel = vel if vel > eps else 1.0
    sic = max(max(norm_q, r_norm), u_norm)
    sic = sic if sic > eps else 1.0
    return err * (sic / vel)


@njit(cache=True)
def _plain_direction(W, Dr, Du, F, d, reg, J, mF, lapack, reg_first):
    """``(dr, W dr, ok, factorizations)`` of ``(Dr + Du (W + reg I)) dr = -F``: first
    ``reg = 0``, then, when that matrix is singular, ``reg`` (the reference's retry); with
    ``reg_first`` the two shifts in the other order.  The first factorization's pivot test
    is strict, the retry's not (:func:`~.dense.dense_solve`)."""
    m = F.shape[0]
    for k in range(m):
        mF[k] = -F[k]
    dense_jacobian(Dr, Du, W, reg if reg_first else 0.0, d, J)
    dr, ok = dense_solve(J, mF, lapack, np.bool_(True))
    n_fact = 1
    if not ok:
        for k in range(m):
            mF[k] = -F[k]
        dense_jacobian(Dr, Du, W, 0.0 if reg_first else reg, d, J)
        dr, ok = dense_solve(J, mF, lapack, np.bool_(False))
        n_fact = 2
    if not ok:
        return dr, dr, False, n_fact
    return dr, matvec(W, dr), True, n_fact


@njit(cache=True)
def plain_newton_dense(W, q, norm_q, mu, rho_n, rho_t, d, tol, it_end, reg, stall_window,
                       m1, max_backtrack, r, best_r, fstate, istate, lapack, law):
    """Plain (nonmonotone) semismooth Newton steps until ``it_end``, convergence or stall.

    The compiled twin of :func:`socp_cd.solvers.newton.prox_newton` with
    ``policy="plain"`` (Siconos NSN_AC's globalization, ``formulations/newton.md``
    §8), same iterates and counters: per step the Newton direction of the
    equation ``law`` (a singular matrix retried with ``W + reg I``, and the
    run's later steps regularized first, the unregularized matrix their retry, until
    that retry is the one that works; when both are singular the run ends with
    ``NUMERICAL_ERROR``), halvings of ``t``
    until ``½||F(r + t dr)||² <= (1 - 2 m1 t) ½||F(r)||²``, at most
    ``max_backtrack`` of them, else the full step; the error is Siconos'
    re-normalized by the velocity scale (:func:`velocity_error`); the best
    iterate is kept in ``best_r``; stalled after ``stall_window`` steps
    without a 10 % drop of the best error.  ``fstate``, ``istate``: as
    :func:`prox_newton_dense` (``F_ALPHA`` unused; every step counts in
    ``I_NEWTON``), ``lapack`` and ``law``.
    """
    m = r.shape[0]
    nc = mu.shape[0]
    u, status, it, best_it, err, best_err = _start(W, q, norm_q, mu, d, tol, r, best_r, fstate,
                                                   istate, np.bool_(True))
    n_newton = n_backtrack = n_ls_fail = n_singular = n_fact = np.int64(0)
    F, Ft, mF, _, rk, rt, ut, J, Dr, Du, branch = _buffers(m, nc, d)
    while status == RUNNING and it < it_end:
        it += 1
        rk[:] = r
        nF = law_blocks(law, r, u, mu, rho_n, rho_t, d, True, F, Dr, Du, branch)
        bt = 0
        ls_ok = True
        if nF != 0.0:
            dr, du, ok, nf = _plain_direction(W, Dr, Du, F, d, reg, J, mF, lapack,
                                              istate[I_REGULARIZED] != 0)
            n_fact += nf
            if nf == 2 and ok:      # the second shift was the one that worked
                istate[I_REGULARIZED] = 1 - istate[I_REGULARIZED]
            if not ok:
                n_singular += 1
                status = NUMERICAL_ERROR
                break
            t = 1.0
            ls_ok = False
            for b in range(max_backtrack):
                for k in range(m):
                    rt[k] = r[k] + t * dr[k]
                    ut[k] = u[k] + t * du[k]
                nFt = law_blocks(law, rt, ut, mu, rho_n, rho_t, d, False, Ft, Dr, Du, branch)
                if nFt * nFt <= (1.0 - 2.0 * m1 * t) * nF * nF:
                    ls_ok = True
                    bt = b
                    break
                t *= 0.5
            if ls_ok:
                r[:] = rt
            else:
                bt = max_backtrack
                for k in range(m):
                    r[k] = r[k] + dr[k]
        n_newton += 1
        n_backtrack += bt
        if not ls_ok:
            n_ls_fail += 1
        err, best_it, best_err, status = _measure(W, q, norm_q, mu, d, tol, r, rk, u, best_r,
                                                  it, best_it, best_err, np.bool_(True))
        if status != RUNNING:
            break
        if stall_window > 0 and it - best_it >= stall_window:
            status = STALLED
            break
        if past(fstate[F_DEADLINE]):
            status = TIME_LIMIT
            break
    _store(istate, fstate, status, it, best_it, n_newton, n_backtrack, n_ls_fail, n_singular,
           np.int64(0), n_fact, err, best_err)


@njit(cache=True)
def projected_error(W, q, norm_q, mu, d, r, out):
    """``P_K(r)`` into ``out`` and Siconos' error of it (``u = W out + q``), one call.

    The polish's last check (:func:`socp_cd.solvers.newton.newton_polish`):
    Alart–Curnier iterates may sit slightly outside ``K``.  The same kernels,
    in the same order, as the three separate calls of the sparse path.
    """
    project_cone_stacked(r, mu, d, out)
    u = np.empty(out.shape[0])
    matvec_into(W, out, q, u)
    return siconos_error(out, u, mu, d, norm_q)


__all__ = ["prox_newton_dense", "plain_newton_dense", "drift_step", "law_blocks", "LAW_CODES", "LAW_AC",
           "LAW_NM", "LAW_FB", "LAW_NAMES", "velocity_error", "new_state", "RUNNING", "CONVERGED", "STALLED",
           "NUMERICAL_ERROR", "TIME_LIMIT", "FSTATE", "ISTATE", "F_ALPHA", "F_ALPHA_MAX_USED",
           "F_ERR", "F_BEST_ERR", "F_DEADLINE", "I_STARTED", "I_STATUS", "I_IT", "I_BEST_IT", "I_NEWTON",
           "I_BACKTRACK", "I_LS_FAIL", "I_SINGULAR", "I_REJECTED", "I_FACTORIZATIONS",
           "I_REGULARIZED", "I_DRIFT", "I_DRIFT_STOP", "projected_error"]
