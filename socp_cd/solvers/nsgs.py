"""Reference NSGS: Moreau–Jean nonlinear block Gauss–Seidel (backend ``"nsgs"``).

One sweep visits every contact ``i`` and solves its one-contact problem
``u_i = W_ii r_i + b_i`` with ``b_i = q_i + sum_{j != i} W_ij r_j`` (using
the impulses already updated in this sweep) exactly or to a tight local
tolerance, as Moreau's and Jean's NSCD codes and Siconos' ``fc3d_nsgs`` do.
The sweeps run in compiled code (:mod:`socp_cd.solvers.nsgs_kernels`) over a
block-sparse copy of ``W`` (:mod:`socp_cd.solvers.block_storage`).

Options (``socp_cd.solve(problem, solver="nsgs", **options)``)
---------------------------------------------------------------
local_solver : {"exact", "ac_newton", "projection"}
    One-contact solver. ``"exact"`` (2D default, Coulomb law): Moreau's
    explicit case analysis. ``"ac_newton"`` (3D default): Alart–Curnier
    semismooth Newton with line search, projection fallback.
    ``"projection"``: projected fixed point only.  The associated law always
    uses the projection fixed point; Tresca uses Newton for ``"exact"``.
omega : float, default 1
    Relaxation ``r_i <- omega r_i^new + (1 - omega) r_i^old``, ``0 < omega < 2``.
ordering : {"natural", "shuffled"}, default "natural"
    Contact order; ``"shuffled"`` draws a new permutation every sweep from ``seed``.
seed : int, default 0
error_every : int, default 10
    Evaluate the full relative error every ``error_every`` sweeps (``0``: only
    when the light error ``||r_k+1 - r_k|| / ||r_k+1||`` falls below its
    tolerance, as Siconos' LIGHT_WITH_FULL_FINAL, and at the last sweep; also
    every sweep with ``history``, every ``predict_window`` sweeps, and every
    sweep when the contacts do not couple: one contact, or ``W`` block diagonal
    with ``omega = 1``, where one sweep is the answer).
stall_window : int, default 5000
    Status ``"stalled"`` when the full error has not dropped by 1 % over that
    many sweeps (``0``: never).
predict_window : int, default 0
    When positive: the full error is also evaluated every ``predict_window``
    sweeps, and the run stops (status ``"max_iter"``, before the cap) as soon as
    its mean linear rate over the last window predicts that ``max_iter`` sweeps
    will not reach ``tol`` (:func:`~socp_cd.solvers.nsgs_kernels.nsgs_loop`;
    ``solver="auto"`` uses it to hand a slow NSGS stage over early).  ``0``: off.
local_tol : float, default 1e-13
    Relative tolerance of the one-contact solvers.
newton_max_iter : int, default 10; projection_max_iter : int, default 100
threshold : array_like
    Tresca threshold per contact (formulation ``"tresca"``).

Common options: ``max_iter`` counts sweeps (default 1000); ``time_limit`` is
the sweeps' deadline on the compiled clock, read about every 10 µs of work
(:data:`~socp_cd.solvers.nsgs_kernels.CHECK_BLOCKS`; a run stops within about
one sweep of its limit), and checked between blocks of sweeps (the sweeps then
run in blocks of 10, 20, 40, ... sweeps, each block restarting the light-error
and stall bookkeeping and, for ``ordering="shuffled"``, reseeding with ``seed +
sweeps done``; without the compiled clock, only there); ``verbose`` prints a one-line summary; ``inner_settings`` holds the
local solver's settings, nested: ``{"local_solver", "local_tol",
"newton_max_iter", "projection_max_iter"}`` (the same names as the flat options).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import UnsupportedError
from ..problem import kernel_array
from . import nsgs_route
from .kernels import clock
from .block_storage import problem_blocks
from .local_solvers import (KIND_AC_NEWTON, KIND_EXACT, KIND_PROJECTION, LAW_ASSOCIATED,
                            LAW_COULOMB, LAW_TRESCA)
from .nsgs_kernels import (STATUS_NAMES, STATUS_TIME_LIMIT, BlockW, Law, LocalSolver, Origin,
                           Sweeps, no_origin, full_error, local_parameters, nsgs_loop, timed_next_block, whole_windows)
from .options import check_choice, check_int, check_real, check_unknown
from .result import SolverResult
from .scaling import origin
from .spec import SolverSpec

DEFAULT_MAX_ITER = 1000

_KINDS = {"exact": KIND_EXACT, "ac_newton": KIND_AC_NEWTON, "projection": KIND_PROJECTION}
_LAWS = {"coulomb": LAW_COULOMB, "frictionless": LAW_COULOMB, "associated": LAW_ASSOCIATED,
         "tresca": LAW_TRESCA}
#: solver-specific options (name -> description)
OPTIONS = {
    "local_solver": "one-contact solver: 'exact' (2D default), 'ac_newton' (3D default), 'projection'",
    "omega": "relaxation in (0, 2) (default 1)",
    "ordering": "'natural' (default) or 'shuffled'",
    "seed": "int seed of the shuffled ordering (default 0)",
    "error_every": "full error every that many sweeps (default 10; 0: light-error rule only)",
    "stall_window": "sweeps without 1 % progress before 'stalled' (default 5000; 0: never)",
    "predict_window": "stop early ('max_iter') when the error's rate over this many sweeps "
                      "predicts that max_iter sweeps will not reach tol (default 0: off)",
    "local_tol": "relative tolerance of the one-contact solvers (default 1e-13)",
    "newton_max_iter": "one-contact Newton iterations (default 10)",
    "projection_max_iter": "one-contact projection iterations (default 100)",
    "threshold": "Tresca threshold per contact (formulation 'tresca')",
}
#: keys of ``inner_settings`` (the local solver's settings, nested)
LOCAL_SETTINGS = ("local_solver", "local_tol", "newton_max_iter", "projection_max_iter")
#: first block of sweeps when a time limit is checked between blocks
TIME_CHECK_SWEEPS = nsgs_route.TIME_CHECK_SWEEPS
#: initial length of the history buffer (doubled as sweeps go on)
HISTORY_CHUNK = 64


def _option(options, name, default):
    v = options.get(name, default)
    return default if v is None else v


_DEFAULT_SETTINGS: dict = {}
_ROUTE_SETTINGS: dict = {}     # dim -> the defaults as the compiled route takes them


def _settings(problem, options, inner_settings):
    """Checked NSGS settings (every bad value raises ``InvalidProblemError`` naming it)."""
    d = problem.dim
    if not inner_settings and not (set(options) - {"threshold"}):
        if d not in _DEFAULT_SETTINGS:        # defaults checked once per dimension
            _DEFAULT_SETTINGS[d] = _checked_settings(d, {})
        return _DEFAULT_SETTINGS[d]
    check_unknown("nsgs (inner_settings)", inner_settings, LOCAL_SETTINGS)
    return _checked_settings(d, {**options, **inner_settings})


def _checked_settings(d, options):
    ls_name = _option(options, "local_solver", "exact" if d == 2 else "ac_newton")
    check_choice("local_solver", ls_name, _KINDS)
    if ls_name == "exact" and d == 3:
        raise UnsupportedError("nsgs: local_solver='exact' exists in 2D only; use 'ac_newton' in 3D")
    omega = check_real("omega", _option(options, "omega", 1.0), minimum=0.0, maximum=2.0,
                       open_interval=True)
    ordering = check_choice("ordering", _option(options, "ordering", "natural"),
                            ("natural", "shuffled"))
    return dict(
        ls_name=ls_name, kind=int(_KINDS[ls_name]), omega=omega, ordering=ordering,
        seed=check_int("seed", _option(options, "seed", 0), minimum=0),
        error_every=check_int("error_every", _option(options, "error_every", 10), minimum=0),
        stall_window=check_int("stall_window", _option(options, "stall_window", 5000), minimum=0),
        predict_window=check_int("predict_window", _option(options, "predict_window", 0),
                                 minimum=0),
        loc_tol=check_real("local_tol", _option(options, "local_tol", 1e-13), positive=True),
        newton_maxit=check_int("newton_max_iter", _option(options, "newton_max_iter", 10),
                               minimum=1),
        proj_maxit=check_int("projection_max_iter", _option(options, "projection_max_iter", 100),
                             minimum=1))


def _message(status_name, light, err, stall_window, time_limit, done) -> str:
    """``result.message`` for an NSGS outcome."""
    if status_name == "numerical_error":
        return "non-finite value in a local solve; r is the last finite iterate"
    if status_name == "time_limit":
        return f"time_limit {time_limit:g} s reached after {done} sweeps"
    if status_name == "stalled" and light == 0.0:
        return f"a sweep left r unchanged but the error is {err:.3e} > tol"
    if status_name == "stalled":
        return f"no progress of the error over {stall_window} sweeps (error {err:.3e})"
    return ""


def nsgs_backend(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                 time_limit=None, verbose=False, inner_settings=None, **options) -> SolverResult:
    """NSGS backend for :func:`socp_cd.solve` (see the module docstring for options)."""
    check_unknown("nsgs", options, OPTIONS)
    d, nc = problem.dim, problem.n_contacts
    t_setup, cpu0 = time.perf_counter(), time.process_time()
    st = _settings(problem, options, dict(inner_settings or {}))
    max_iter = DEFAULT_MAX_ITER if max_iter is None else int(max_iter)

    law = _LAWS[formulation]
    mu = np.ascontiguousarray(problem.mu, dtype=np.float64)
    if formulation == "frictionless":
        mu = np.zeros(nc)
    g = np.zeros(nc)
    if formulation == "tresca":
        g = np.ascontiguousarray(options["threshold"], dtype=np.float64)

    S = problem_blocks(problem)
    q = kernel_array(problem.q)     # (the balanced copy's q is read-only)
    r = np.zeros(problem.m) if r0 is None else np.array(r0, dtype=np.float64).reshape(-1)
    rhoN, rhoT, rhoP, bad = local_parameters(S.diag, S.blocks)
    info = {"local_solver": st["ls_name"], "omega": st["omega"], "ordering": st["ordering"],
            "error_every": st["error_every"]}
    if bad.any():
        # a contact whose W_NN is not positive has no well-posed one-contact problem
        bad = np.flatnonzero(bad)
        info["singular_contacts"] = bad.tolist()
        return SolverResult(r=r, status="numerical_error", iterations=0, info=info,
                            message=f"diagonal block W_ii of contact(s) {bad[:10].tolist()} has "
                                    f"W_NN <= 0: one-contact problem ill-posed")

    hist = np.full(min(max_iter, HISTORY_CHUNK) if history else 1, np.nan)
    W = BlockW(S.indptr, S.indices, S.blocks, S.diag)
    law_t = Law(mu, g, int(law))
    local = LocalSolver(int(_KINDS[st["ls_name"]]), rhoN, rhoT, rhoP, float(st["loc_tol"]),
                        int(st["newton_maxit"]), int(st["proj_maxit"]))
    # on the dispatcher's balanced copy of a Coulomb problem, also stop on its measure
    units = origin(problem) if formulation == "coulomb" else None
    units = no_origin() if units is None else Origin(*units)
    info["setup_time"] = time.perf_counter() - t_setup
    t0 = time.perf_counter()
    deadline = clock.deadline_after(time_limit)     # (read by the sweeps: inf without a limit)
    window = int(st["predict_window"])
    done, block = 0, (max_iter if time_limit is None
                      else min(max_iter, whole_windows(TIME_CHECK_SWEEPS, window)))
    hist_all = []
    prev = -1.0             # the rate prediction's error at the end of the last block
    while True:
        sweeps = Sweeps(float(tol), int(block), float(st["omega"]), st["ordering"] == "shuffled",
                        int(st["seed"] + done), int(st["error_every"]), int(st["stall_window"]),
                        bool(history), window, int(max_iter - done), prev, deadline)
        status, iters, err, n_full, n_fail, light, hist = nsgs_loop(d, W, q, law_t, local, sweeps,
                                                                    r, hist, units)
        if history:
            hist_all.extend(hist[:iters].tolist())
        done += int(iters)
        if time_limit is None:
            break
        block, prev, spent = timed_next_block(status, int(iters), int(block), done, max_iter, err,
                                              window, t0, time_limit, time.perf_counter)
        if not block:
            status = STATUS_TIME_LIMIT if spent else status
            break
    info["loop_time"] = time.perf_counter() - t0
    info["cpu_time"] = time.process_time() - cpu0
    info.update(full_error_evaluations=int(n_full), local_failures=int(n_fail),
                light_error=float(light), internal_error=float(err))
    status_name = STATUS_NAMES[status]
    message = _message(status_name, light, err, st["stall_window"], time_limit, done)
    if status_name == "max_iter" and done < max_iter:
        message = (f"stopped after {done} of {max_iter} sweeps: the error's rate over the last "
                   f"{st['predict_window']} sweeps predicts more than {max_iter} to reach tol "
                   f"(error {err:.3e})")
    if verbose:
        print(f"nsgs: {status_name} after {done} sweeps, error {err:.3e} "
              f"({info['loop_time']:.3g} s)")
    return SolverResult(r=r, status=status_name, iterations=int(done),
                        history=hist_all if history else None, info=info, message=message)


def route_settings(dim):
    """NSGS's default settings in dimension ``dim`` as :func:`socp_cd.solvers.nsgs_route.run`
    takes them (the tuple :data:`~socp_cd.solvers.nsgs_route.ROUTE_SETTINGS` names; checked
    once per dimension)."""
    settings = _ROUTE_SETTINGS.get(dim)
    if settings is None:
        st = _checked_settings(dim, {})
        settings = _ROUTE_SETTINGS[dim] = tuple(st[k] for k in nsgs_route.ROUTE_SETTINGS)
    return settings


def compiled_run(problem, tol, max_iter, r0, time_limit, need_friction=False, stall_window=None,
                 handoff=(0, 0), predict_window=0):
    """NSGS with its default settings through the compiled route (:mod:`~socp_cd.solvers.nsgs_route`).

    ``max_iter`` sweeps (None: :data:`DEFAULT_MAX_ITER`) from ``r0`` (caller's
    units) on the balanced problem, in the backend's time-limit blocks when
    ``time_limit`` is given, with the dispatcher's checks of the answer;
    ``stall_window`` replaces the default one (the option of the same name)
    when given; ``handoff`` ``(sweeps, work)``: ``solver="auto"``'s hand-off
    cap (:func:`~socp_cd.solvers.nsgs_route.nsgs_checked`; ``(0, 0)``: none);
    ``predict_window``: the option of the same name.

    Returns
    -------
    RouteOutcome or None
        None when the route does not apply or declines
        (:func:`~socp_cd.solvers.nsgs_route.run`).
    """
    settings = route_settings(problem.dim)
    if stall_window is not None:
        settings = settings[:-1] + (int(stall_window),)
    return nsgs_route.run(problem, settings, tol,
                          DEFAULT_MAX_ITER if max_iter is None else int(max_iter), r0, time_limit,
                          need_friction, handoff, int(predict_window))


def route(problem, *, tol, max_iter, r0, time_limit):
    """The compiled route of a plain NSGS call (``SolverSpec.route``).

    For a local exact-Coulomb problem called with the default settings (and
    within :func:`~socp_cd.solvers.nsgs_route.run`'s bounds): the result that :func:`nsgs_backend` on the balanced
    problem and the dispatcher's checks would give, with ``u``, ``error``,
    ``coulomb_error``, ``trivial`` and ``info["guard"]`` filled from the
    checks (``info["route"] = "compiled"``; ``setup_time`` is 0, the set-up
    runs inside the compiled call), as ``(result, guard_value, None)`` (the
    route's contract, ``SolverSpec.route``); None when the route does not apply.
    """
    t0, cpu0 = time.perf_counter(), time.process_time()
    out = compiled_run(problem, tol, max_iter, r0, time_limit)
    if out is None:
        return None
    st = _settings(problem, {}, {})
    x, R = out.stats, nsgs_route
    sweeps = int(x[R.SWEEPS])
    info = {"local_solver": st["ls_name"], "omega": st["omega"], "ordering": st["ordering"],
            "error_every": st["error_every"], "setup_time": 0.0,
            "loop_time": time.perf_counter() - t0, "cpu_time": time.process_time() - cpu0,
            "full_error_evaluations": int(x[R.N_FULL]), "local_failures": int(x[R.N_FAIL]),
            "light_error": x[R.LIGHT], "internal_error": x[R.INTERNAL_ERROR],
            "guard": R.guard_record(x), "scaling": R.scaling_record(x), "route": "compiled"}
    message = _message(out.status, x[R.LIGHT], x[R.INTERNAL_ERROR], st["stall_window"],
                       time_limit, sweeps)
    return (SolverResult.of_local(out.vectors[1], out.vectors[2], out.status, x[R.ERROR], sweeps,
                                  info, message, x[R.ZERO_ERROR] <= tol),
            x[R.GUARD_VALUE], None)


SPEC = SolverSpec(
    "nsgs", nsgs_backend, ("coulomb", "frictionless", "tresca", "associated"), dims=(2, 3),
    description="Moreau–Jean nonlinear block Gauss–Seidel (numba), exact 2D / "
                "Alart–Curnier Newton 3D local solvers",
    default_max_iter=DEFAULT_MAX_ITER, options=OPTIONS,
    inner_settings="the local solver's settings: " + ", ".join(LOCAL_SETTINGS),
    check=lambda problem, options, inner_settings: _settings(problem, options, inner_settings),
    route=route)


def warmup() -> float:
    """Compile (or load from cache) the numba kernels on tiny problems; returns seconds."""
    from ..problem import FrictionContactProblem
    t0 = time.perf_counter()
    for d in (2, 3):
        W = np.eye(2 * d) + 0.1
        prob = FrictionContactProblem(W, -np.ones(2 * d), 0.3, d)
        for ls in (("exact", "ac_newton", "projection") if d == 2 else ("ac_newton", "projection")):
            nsgs_backend(prob, "coulomb", tol=1e-8, max_iter=5, local_solver=ls)
    return time.perf_counter() - t0


__all__ = ["SPEC", "OPTIONS", "nsgs_backend", "route", "compiled_run", "route_settings", "local_parameters", "warmup", "full_error", "DEFAULT_MAX_ITER"]
