"""Polyhedral contact laws as QPs solved by ProxQP (backend ``"proxsuite"``).

ProxQP (proxsuite) solves ``min ½ xᵀHx + gᵀx  s.t.  Ax = b,  l <= Cx <= u``.
Every law handled here has a polyhedral feasible set, so it is exactly one
such QP (no equality rows, ``A`` empty):

=================  =========  ========================  ======================
formulation        x          C, l, u                    dims
=================  =========  ========================  ======================
``frictionless``   ``r_N``    ``I``, ``0``, ``+inf``     2, 3 (``H = W_NN``)
``associated``     ``r``      wedge rows, ``-inf``, 0    2
``coulomb``        ``r``      wedge rows (De Saxcé)      2
``tresca``         ``r``      ``I``, ``(0,-g)``,         2
                              ``(+inf, g)``
``faceted``        ``r``      facet rows, ``-inf``, 0    2 (= associated), 3
=================  =========  ========================  ======================

with ``H = W_s = (W + Wᵀ)/2`` and ``g = q`` (or the De Saxcé shifted ``q``).
The 3D Coulomb and Tresca sets are round (not polyhedral): ask for
``formulation="faceted"`` or another solver.  See
``formulations/frictionless_qp.md`` and ``formulations/faceted.md``.

The ProxQP object is built once per solve and re-used across the outer
iterations of the 2D Coulomb fixed point with ``qp.update(g=...)`` and
``InitialGuess.WARM_START_WITH_PREVIOUS_RESULT``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .newton import resolve_polish
from ..errors import UnsupportedError
from ..laws import LAW_RESIDUALS
from ..faceted import DEFAULT_FACETS, check_facets, cone_matrix, faceted_error
from .options import check_unknown
from .spec import SolverSpec
from .result import SolverResult

try:
    from proxsuite import proxqp
except ModuleNotFoundError:  # pragma: no cover - proxsuite is a declared dependency
    proxqp = None

DEFAULT_MAX_ITER = 50       #: outer De Saxcé iterations (2D coulomb)


#: ProxQP status name -> (provisional socp_cd status, explanation)
STATUS_MAP = {
    "PROXQP_SOLVED": ("converged", ""),
    "PROXQP_MAX_ITER_REACHED": ("max_iter", "ProxQP hit its iteration cap "
                                            "(also its symptom of an unbounded QP: no solution)"),
    "PROXQP_PRIMAL_INFEASIBLE": ("numerical_error", "ProxQP reported primal infeasibility, "
                                                    "impossible (r = 0 is feasible)"),
    "PROXQP_DUAL_INFEASIBLE": ("numerical_error", "ProxQP reported dual infeasibility: the QP "
                                                  "is unbounded below, the law has no solution"),
    "PROXQP_SOLVED_CLOSEST_PRIMAL_FEASIBLE": ("numerical_error", "ProxQP returned the closest "
                                                                 "primal-feasible QP"),
    "PROXQP_NOT_RUN": ("numerical_error", "ProxQP did not run"),
}


class ProxQPInner:
    """``min ½ xᵀHx + gᵀx, l <= Cx <= u`` held in one ProxQP object.

    Implements the inner-solver protocol of
    :func:`socp_cd.solvers.desaxce.desaxce_fixed_point` for polyhedral sets:
    ``solve(g, tol) -> (r, info)``, with ``r = E x`` (``E`` scatters the QP
    unknowns into the stacked impulses).

    Parameters
    ----------
    H : sparse matrix (n, n)
        Symmetric PSD Hessian (ProxQP reads its upper triangle).
    C : sparse matrix (k, n), l, u : ndarray (k,)
    E : sparse matrix (m, n), optional
        Map from ``x`` to ``r`` (identity when None).
    scale : float
        Magnitude used to turn a relative ``tol`` into ProxQP's absolute
        ``eps_abs`` (``||q||``).
    qp_max_iter : int, optional
        ProxQP's own iteration cap.
    """

    def __init__(self, H, C, l, u, E=None, scale: float = 1.0, qp_max_iter=None):
        if proxqp is None:  # pragma: no cover
            raise UnsupportedError("solver 'proxsuite' needs the proxsuite package")
        H, C = sp.csc_matrix(H), sp.csc_matrix(C)
        n, k = H.shape[0], C.shape[0]
        self.qp = proxqp.sparse.QP(n, 0, k)
        self.qp.settings.eps_rel = 0.0
        # r = 0 is always feasible: primal infeasibility cannot happen, and ProxQP's
        # detector (eps_primal_inf = 1e-4) misfires on the redundant, nearly parallel
        # facet rows of fine faceted cones; make it effectively silent.
        self.qp.settings.eps_primal_inf = 1e-300
        if qp_max_iter is not None:
            self.qp.settings.max_iter = int(qp_max_iter)
        self.H, self.C, self.l, self.u = H, C, np.asarray(l, float), np.asarray(u, float)
        self.E = E
        self.scale = max(float(scale), np.finfo(float).tiny)
        self.n = n
        self.initialized = False

    def eps_abs(self, tol: float) -> float:
        """ProxQP's absolute tolerance (inf-norm of its residuals) for a relative ``tol``."""
        return 0.1 * tol * self.scale / np.sqrt(max(self.n, 1))

    def solve(self, g, tol: float):
        """Solve for the linear term ``g`` (warm-started after the first call)."""
        g = np.asarray(g, dtype=np.float64)
        if self.E is not None and g.shape[0] != self.n:
            g = self.E.T @ g                      # linear term seen by the QP unknowns
        self.qp.settings.eps_abs = self.eps_abs(tol)
        if not self.initialized:
            self.qp.init(self.H, g, None, None, self.C, self.l, self.u)
            self.initialized = True
        else:
            self.qp.settings.initial_guess = proxqp.WARM_START_WITH_PREVIOUS_RESULT
            self.qp.update(g=g)
        self.qp.solve()
        res = self.qp.results
        st, why = STATUS_MAP.get(res.info.status.name, ("numerical_error", "unknown ProxQP status"))
        x = np.array(res.x, dtype=np.float64)
        r = x if self.E is None else self.E @ x
        return r, {"iterations": int(res.info.iter), "status": res.info.status.name,
                   "ok": st == "converged", "socp_status": st, "why": why,
                   "objective": float(res.info.objValue), "z": np.array(res.z)}


def _scatter_normal(problem) -> sp.csr_matrix:
    """``E`` with ``r = E r_N`` (tangential components zero)."""
    nc, d = problem.n_contacts, problem.dim
    return sp.csr_matrix((np.ones(nc), (d * np.arange(nc), np.arange(nc))), shape=(problem.m, nc))


def frictionless_qp(problem, W_sym=None, qp_max_iter=None) -> ProxQPInner:
    """Signorini QP ``min ½ r_Nᵀ W_NN r_N + q_Nᵀ r_N, r_N >= 0`` (``r_T = 0``)."""
    Ws = problem.symmetric_part() if W_sym is None else W_sym
    E = _scatter_normal(problem)
    H = (E.T @ Ws @ E).tocsc()                    # W_NN: the tangential rows drop out
    nc = problem.n_contacts
    return ProxQPInner(H, sp.identity(nc, format="csc"), np.zeros(nc), np.full(nc, np.inf), E,
                       problem.q_norm, qp_max_iter)


def cone_qp(problem, W_sym=None, n_facets=DEFAULT_FACETS, placement="inscribed",
            qp_max_iter=None) -> ProxQPInner:
    """QP ``min ½ rᵀ W_s r + gᵀ r, C r <= 0`` on the (faceted) cone, see :func:`cone_matrix`."""
    Ws = problem.symmetric_part() if W_sym is None else W_sym
    C = cone_matrix(problem.mu, problem.dim, n_facets, placement)
    k = C.shape[0]
    return ProxQPInner(Ws, C, np.full(k, -np.inf), np.zeros(k), None,
                       problem.q_norm, qp_max_iter)


def tresca_qp(problem, threshold, W_sym=None, qp_max_iter=None) -> ProxQPInner:
    """2D Tresca QP: ``r_N >= 0``, ``-g <= r_T <= g`` (box, ``C = I``)."""
    Ws = problem.symmetric_part() if W_sym is None else W_sym
    g = np.asarray(threshold, dtype=np.float64)
    lo = np.column_stack([np.zeros_like(g), -g]).ravel()
    hi = np.column_stack([np.full_like(g, np.inf), g]).ravel()
    return ProxQPInner(Ws, sp.identity(problem.m, format="csc"), lo, hi, None,
                       problem.q_norm, qp_max_iter)


def _solve_law(problem, inner: ProxQPInner, tol: float, max_iter: int, residual) -> SolverResult:
    """QP(s) with ``W_s`` until the law residual (true ``W``) is ``<= tol``.

    After the first QP, while ``residual(r) > tol`` (at most ``max_iter`` QPs):

    * the QP is re-solved warm-started with ProxQP's tolerance divided by 10
      (down to ``1e-6 tol``; with a skew part only when the residual did not
      halve): ``eps_abs`` bounds ProxQP's own KKT residuals, which on badly
      scaled data are a poor proxy for the law residual;
    * with a non-symmetric ``W``, the linear term becomes ``q + W_a r_k`` — a
      splitting on the skew part, so that a fixed point solves
      ``W_s r + q + W_a r = u`` for the true ``W``. It converges when ``W_a``
      is small against the curvature of ``W_s`` on the active set.
    """
    q = problem.q_local
    W_a = None if problem.is_symmetric else problem.skew_part()
    itol, floor = tol, 1e-6 * tol
    r, info = inner.solve(q, itol)
    total, k = info["iterations"], 1
    err = residual(r)
    err_prev = np.inf
    while info["ok"] and k < max_iter and err > tol:
        if W_a is None and itol <= floor:
            break
        if W_a is None or err > 0.5 * err_prev:    # splitting alone no longer helps
            itol = max(0.1 * itol, floor)
        r, info = inner.solve(q if W_a is None else q + W_a @ r, itol)
        total, k, err_prev = total + info["iterations"], k + 1, err
        err = residual(r)
    status = info["socp_status"]
    if status == "converged" and err > tol:
        status = "stalled" if W_a is None else "max_iter"
    msg = f"ProxQP: {info['status']}" + (f" ({info['why']})" if info["why"] else "")
    if k > 1:
        msg += f"; {k} QPs (" + ("skew-part splitting, " if W_a is not None else "") + \
            f"last eps_abs for tol {itol:.0e})"
    return SolverResult(r=r, status=status, iterations=k, message=msg,
                        info={"proxqp_status": info["status"], "objective": info["objective"],
                              "inner_iterations": total, "skew_splitting": W_a is not None,
                              "law_error": err})


#: solver-specific options
OPTIONS = {
    "facets": "facets of the 3D faceted cone (default 8, >= 3)",
    "placement": "'inscribed' (default) or 'circumscribed' faceted cone",
    "threshold": "Tresca thresholds (2D)",
    "accel": "2D coulomb outer acceleration (default 'anderson')",
    "memory": "Anderson memory (default 5)", "adaptive_tol": "(default False)",
    "kappa": "(default 1e-2)", "inner_tol_max": "(default 1e-4)",
    "inner_tol_min": "(default min(1e-10, tol/100))",
    "polish": "2D coulomb polish (default None here)", "polish_max_iter": "(default 15)",
    "polish_switch": "(default per problem size)", "patience": "(default 8)",
}


def solve_proxsuite(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                    time_limit=None, verbose=False, inner_settings=None, **options):
    """Backend ``"proxsuite"``.

    Options
    -------
    facets : int
        Number of facets of the 3D faceted cone (default 8, ``>= 3``).
    placement : {"inscribed", "circumscribed"}
        Faceted polygon inscribed in the friction circle (default; the faceted
        reactions are then admissible for the exact cone) or circumscribed.
    threshold : array_like
        Tresca thresholds (2D only).
    inner_settings : dict
        ProxQP settings; ``max_iter`` caps each QP (default ProxQP's, 10000).
    **outer_options
        For 2D ``"coulomb"``: forwarded to
        :func:`socp_cd.solvers.desaxce.desaxce_fixed_point` (``polish`` is
        None by default here, so the result is ProxQP's alone).

    Raises
    ------
    UnsupportedError
        For ``coulomb``/``associated``/``tresca`` in 3D (round sets, not QPs).

    Notes
    -----
    The QPs use ``W_s``.  With a non-symmetric ``W`` the single-QP laws are
    re-solved in a splitting ``q + W_a r_k`` on the skew part (``max_iter``
    QPs at most, default 50; ``iterations`` counts QPs) and 2D ``coulomb``
    moves ``W_a`` into the De Saxcé shift.  In 2D ``associated`` and
    ``faceted`` are the same law (the wedge is already polyhedral).
    """
    check_unknown("proxsuite", options, OPTIONS)
    inner_settings = dict(inner_settings or {})
    qp_max_iter = inner_settings.pop("max_iter", None)
    if inner_settings:
        check_unknown("proxsuite (inner_settings)", inner_settings, ("max_iter",))
    if time_limit is not None and formulation == "coulomb":
        options.setdefault("time_limit", float(time_limit))
    if problem.dim == 3 and formulation in ("coulomb", "associated", "tresca"):
        raise UnsupportedError(
            f"solver 'proxsuite' cannot solve {formulation!r} in 3D: the 3D "
            + ("Coulomb cone" if formulation != "tresca" else "Tresca disc")
            + " is round, not polyhedral, so it is not a QP. Use formulation='faceted' "
              "(polyhedral cone, option facets=) or solver='clarabel'/'cvxpy'.")
    outer_cap = DEFAULT_MAX_ITER if max_iter is None else max_iter
    if formulation == "frictionless":
        _no_options(options)
        return _solve_law(problem, frictionless_qp(problem, qp_max_iter=qp_max_iter), tol,
                          outer_cap, lambda r: LAW_RESIDUALS["frictionless"](problem, r))
    if formulation == "tresca":
        threshold = options.pop("threshold")
        _no_options(options)
        return _solve_law(problem, tresca_qp(problem, threshold, qp_max_iter=qp_max_iter), tol,
                          outer_cap, lambda r: LAW_RESIDUALS["tresca"](problem, r,
                                                                       threshold=threshold))
    if formulation in ("associated", "faceted"):
        nf, placement = check_facets(options.pop("facets", DEFAULT_FACETS),
                                     options.pop("placement", "inscribed"))
        _no_options(options)

        def residual(r):
            return faceted_error(problem, r, None, nf, placement)

        res = _solve_law(problem, cone_qp(problem, None, nf, placement, qp_max_iter), tol,
                         outer_cap, residual)
        if formulation == "faceted":
            res.info["law_residual"] = residual(res.r)
            res.info.update(facets=nf if problem.dim == 3 else 2, placement=placement)
        return res
    # 2D coulomb: De Saxcé fixed point, every inner problem a QP on the exact wedge
    from .desaxce import desaxce_fixed_point
    options["polish"] = resolve_polish(options.get("polish"))

    def factory(prob, W_sym):
        return cone_qp(prob, W_sym, qp_max_iter=qp_max_iter)

    return desaxce_fixed_point(problem, factory, tol=tol,
                               max_iter=DEFAULT_MAX_ITER if max_iter is None else max_iter,
                               r0=r0, history=history, **options)


def _no_options(options):
    check_unknown("proxsuite (this formulation)", options, ())


SPEC = SolverSpec(
    "proxsuite", solve_proxsuite, ("frictionless", "faceted", "coulomb", "associated", "tresca"),
    dims=(2, 3),
    description="ProxQP on polyhedral laws: frictionless (2D/3D), faceted cone (3D), "
                "coulomb/associated/tresca (2D only)",
    default_max_iter=DEFAULT_MAX_ITER, options=OPTIONS,
    inner_settings="ProxQP settings: max_iter (per QP)")

__all__ = ["SPEC", "OPTIONS", "STATUS_MAP", "ProxQPInner", "frictionless_qp", "cone_qp", "tresca_qp", "solve_proxsuite",
           "DEFAULT_FACETS"]
