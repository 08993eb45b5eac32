"""The projection method's iterations, compiled (numba, ``cache=True``).

The law as a fixed point (``formulations/projection.md``): ``r`` solves the
contact problem iff ``r = P(r - rho F(r))`` for one (every) ``rho > 0``, with
``F(r) = law_velocity(W r + q)`` (De Saxcé's ``û = u + mu ||u_T|| e_N`` for
Coulomb, ``u`` for the associated, Tresca and frictionless laws) and ``P`` the
projection on the law's set (:func:`~socp_cd.solvers.kernels.cone.law_projection`).
One step is ``r+ = P(r - rho F(r))`` with a self-adaptive ``rho`` (Khobotov's
rule as in He & Liao 2002 and Siconos' ``fc3d_fixedPoint_projection``): the
step is accepted when ``rho ||F(r+) - F(r)|| <= L ||r+ - r||``, else ``rho``
shrinks by ``tau`` and the step is retried; after an accepted step with
``rho ||F(r+) - F(r)|| < L_min ||r+ - r||`` and a lower error, ``rho`` grows by
``1 / tau_min``.  A step costs one product ``W x`` (the velocity of ``r+``
serves the test, the error and the next step), plus one per retry.

Stable API: :func:`projection_loop`, :data:`Step`.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .cone import EPS, error_parts, law_projection, law_velocity, relative_error
from ..nsgs_kernels import (STATUS_CONVERGED, STATUS_MAX_ITER, STATUS_NUMERICAL,
                            STATUS_PREDICTED, STATUS_STALLED, predicted_sweeps, recorded)

#: The step rule: the acceptance and growth thresholds ``L``, ``L_min``, the shrink and
#: growth factors ``tau``, ``tau_min`` and the retries of one step.
Step = namedtuple("Step", "L L_min tau tau_min max_retries")


@njit(cache=True, inline="always")
def _velocity_and_F(indptr, indices, data, q, x, mu, dim, law, u, F):
    """``u = W x + q`` (CSR rows in scipy's order) and ``F = law_velocity(u)``, in place."""
    n = indptr.shape[0] - 1
    for i in range(n):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            s += data[k] * x[indices[k]]
        u[i] = s + q[i]
    for c in range(mu.shape[0]):
        o = c * dim
        h0, h1, h2 = law_velocity(u[o], u[o + 1], u[o + 2] if dim == 3 else 0.0, dim, mu[c], law)
        F[o] = h0
        F[o + 1] = h1
        if dim == 3:
            F[o + 2] = h2


@njit(cache=True)
def projection_loop(indptr, indices, data, q, mu, g, dim, law, r, best_r, rho, tol, max_iter,
                    step, stall_window, predict_window, predict_budget, predict_prev, record, hist):
    """Projection steps from ``r`` (in place: the last iterate; ``best_r``: the best one).

    Parameters
    ----------
    indptr, indices, data : ndarray
        ``W`` in CSR form.
    q, mu, g : ndarray
        Free velocity; friction coefficients and Tresca thresholds per contact.
    dim, law : int
        Contact dimension; law code (:mod:`~socp_cd.solvers.kernels.cone`).
    r : ndarray
        Starting point; on return the last iterate (a run in blocks goes on from it).
    best_r : ndarray
        Out: the iterate of least Siconos error (``r`` itself when that is the start).
    rho : float
        Initial step (> 0).
    tol, max_iter : float, int
        Stop when Siconos' error and the units guard's measure (the residual
        over ``max(||q||, ||u||)``, as NSGS stops) are both ``<= tol``; at most
        ``max_iter`` accepted steps.
    step : Step
    stall_window : int
        ``"stalled"`` after that many steps without a 1 % drop of the best error (0: never).
    predict_window, predict_budget, predict_prev : int, int, float
        Rate prediction (NSGS's, :func:`~socp_cd.solvers.nsgs_kernels.predicted_sweeps`):
        at the end of each window of ``predict_window`` steps (0: off; a block's last step
        included, the run's last one not), stop with ``STATUS_PREDICTED`` (reported as
        ``"max_iter"``) when the error's mean rate over the window predicts more than
        ``predict_budget`` steps to reach ``tol``; ``predict_prev``: the error at the
        end of the window before this call (-1: none).
    record : bool
        Write each step's error into ``hist`` (grown by doubling when full; returned).

    Returns
    -------
    status, steps, best_error, rho, products, last_error, hist
        Status code (``nsgs_kernels.STATUS_*``), accepted steps, ``best_r``'s
        Siconos error, the step size reached, products ``W x`` done, the last
        iterate's error (the rate prediction's, for a run in blocks) and the
        history buffer.
    """
    m = r.shape[0]
    nc = mu.shape[0]
    u = np.empty(m)
    F = np.empty(m)
    rn = np.empty(m)
    un = np.empty(m)
    Fn = np.empty(m)
    best_r[:] = r
    norm_q = 0.0
    for k in range(m):
        norm_q += q[k] * q[k]
    norm_q = np.sqrt(norm_q)
    _velocity_and_F(indptr, indices, data, q, r, mu, dim, law, u, F)
    products = 1
    f2, r2, u2 = error_parts(r, u, mu, g, dim, law)
    err = relative_error(f2, r2, u2, norm_q)
    best = err
    best_err = err
    best_iter = 0
    window_err = predict_prev
    if not np.isfinite(err):
        return STATUS_NUMERICAL, 0, err, rho, products, err, hist
    for it in range(1, max_iter + 1):
        a1 = 0.0
        a2 = 0.0
        for attempt in range(step.max_retries + 1):
            for c in range(nc):
                o = c * dim
                p0, p1, p2 = law_projection(
                    r[o] - rho * F[o], r[o + 1] - rho * F[o + 1],
                    (r[o + 2] - rho * F[o + 2]) if dim == 3 else 0.0, dim, mu[c], g[c], law)
                rn[o] = p0
                rn[o + 1] = p1
                if dim == 3:
                    rn[o + 2] = p2
            _velocity_and_F(indptr, indices, data, q, rn, mu, dim, law, un, Fn)
            products += 1
            a1 = 0.0
            a2 = 0.0
            for k in range(m):
                e = Fn[k] - F[k]
                a1 += e * e
                e = rn[k] - r[k]
                a2 += e * e
            a1 = np.sqrt(a1)
            a2 = np.sqrt(a2)
            if rho * a1 <= step.L * a2 or a2 == 0.0 or attempt == step.max_retries:
                break
            rho *= step.tau
        f2, r2, u2 = error_parts(rn, un, mu, g, dim, law)
        new_err = relative_error(f2, r2, u2, norm_q)
        if not np.isfinite(new_err):
            return STATUS_NUMERICAL, it, best_err, rho, products, new_err, hist
        if rho * a1 < step.L_min * a2 and new_err < err:
            rho /= step.tau_min
        err = new_err
        for k in range(m):
            r[k] = rn[k]
            u[k] = un[k]
            F[k] = Fn[k]
        if record:
            hist = recorded(hist, it, err)
        if err < best_err:
            best_err = err
            for k in range(m):
                best_r[k] = r[k]
        vel = np.sqrt(u2)
        if norm_q > vel:
            vel = norm_q
        if not vel > EPS:
            vel = 1.0
        stop = np.sqrt(f2) / vel
        if (stop if stop > err else err) <= tol:
            best_r[:] = r
            return STATUS_CONVERGED, it, err, rho, products, err, hist
        if a2 == 0.0:       # r = P(r - rho F(r)) to the last bit, yet not within tol
            return STATUS_STALLED, it, best_err, rho, products, err, hist
        if err < 0.99 * best:
            best = err
            best_iter = it
        elif stall_window > 0 and it - best_iter >= stall_window:
            return STATUS_STALLED, it, best_err, rho, products, err, hist
        if predict_window > 0 and it % predict_window == 0:
            if window_err > 0.0 and it < predict_budget and predicted_sweeps(
                    it, predict_window, window_err, err, tol) > predict_budget:
                return STATUS_PREDICTED, it, best_err, rho, products, err, hist
            window_err = err
    return STATUS_MAX_ITER, max_iter, best_err, rho, products, err, hist
