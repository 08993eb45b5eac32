"""Prototype: an infeasible primal-dual interior-point method on the Coulomb conic
complementarity problem itself (not on a De Saxcé SOCP), for the Kapla-tower cases.

Per contact, with ``x = (mu r_N, r_T)`` and ``y = (v_N, mu v_T)`` both in the Lorentz cone
``L`` (``r in K`` and ``v in K*``), and ``v = u + mu phi_tau(u_T) e_N``, ``u = W r + q``,
``phi_tau(z) = sqrt(|z|^2 + tau^2)`` (a smoothing of ``|u_T|`` that goes to 0 with the
duality measure), the method follows ``x o y = nu e`` (Jordan product) to ``nu = 0`` with
Mehrotra's predictor-corrector; ``v`` is a separate unknown (infeasible start).  Newton's
system, ``v`` eliminated::

    [L(y) Sx + L(x) Sy D W] dr = -(x o y - nu e) + L(x) Sy (v - c(r))

with ``D = I + mu e_N w^T`` (``w = (0, u_T / phi_tau)``), ``Sx = diag(mu, 1, 1)``,
``Sy = diag(1, mu, mu)``.  The answer is then handed to ``newton`` (the polish).

Study only (session 36): not a solver of the library.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.residuals import error as siconos_error
from socp_cd.solvers.clarabel_backend import ClarabelInner


def jordan(x, y):
    """Per-row Jordan product of the Lorentz cone, x, y of shape (n, 3)."""
    out = np.empty_like(x)
    out[:, 0] = np.einsum("ij,ij->i", x, y)
    out[:, 1:] = x[:, :1] * y[:, 1:] + y[:, :1] * x[:, 1:]
    return out


def arrow_blocks(x):
    """L(x) per row: (n, 3, 3)."""
    n = x.shape[0]
    L = np.zeros((n, 3, 3))
    L[:, 0, 0] = x[:, 0]
    L[:, 0, 1:] = x[:, 1:]
    L[:, 1:, 0] = x[:, 1:]
    L[:, 1, 1] = x[:, 0]
    L[:, 2, 2] = x[:, 0]
    return L


def max_step(x, dx):
    """Largest a in (0, 1] with x + a dx in the Lorentz cone (every row)."""
    # x0 + a dx0 >= |x1 + a dx1|  <=>  quadratic in a
    a = np.ones(x.shape[0])
    x0, x1, d0, d1 = x[:, 0], x[:, 1:], dx[:, 0], dx[:, 1:]
    A = d0 ** 2 - np.einsum("ij,ij->i", d1, d1)
    B = 2 * (x0 * d0 - np.einsum("ij,ij->i", x1, d1))
    C = x0 ** 2 - np.einsum("ij,ij->i", x1, x1)
    for i in range(x.shape[0]):
        roots = np.roots([A[i], B[i], C[i]]) if abs(A[i]) > 1e-300 else (
            [-C[i] / B[i]] if B[i] != 0 else [])
        for t in np.atleast_1d(roots):
            if np.isreal(t) and t.real > 0:
                s = t.real
                # the root where the cone is left (x0 + s d0 stays >= 0 on the branch)
                a[i] = min(a[i], s)
        if x0[i] + d0[i] < 0:
            a[i] = min(a[i], -x0[i] / d0[i])
    return float(a.min())


def nt_scaling(s, z):
    """Nesterov-Todd scaling of Lorentz-cone pairs (rows): W (symmetric), W^-1, lambda = W z."""
    J = np.array([1.0, -1.0, -1.0])
    sJs = s[:, 0] ** 2 - np.einsum("ij,ij->i", s[:, 1:], s[:, 1:])
    zJz = z[:, 0] ** 2 - np.einsum("ij,ij->i", z[:, 1:], z[:, 1:])
    sb = s / np.sqrt(sJs)[:, None]
    zb = z / np.sqrt(zJz)[:, None]
    gam = np.sqrt((1 + np.einsum("ij,ij->i", sb, zb)) / 2)
    wb = (sb + zb * J) / (2 * gam)[:, None]
    eta = (sJs / zJz) ** 0.25
    a, qv = wb[:, 0], wb[:, 1:]
    H = np.einsum("ni,nj->nij", qv, qv) / (1 + a)[:, None, None] + np.eye(2)
    Wn = np.empty((s.shape[0], 3, 3))
    Wn[:, 0, 0] = a
    Wn[:, 0, 1:] = qv
    Wn[:, 1:, 0] = qv
    Wn[:, 1:, 1:] = H
    Wi = Wn.copy()
    Wi[:, 0, 1:] *= -1
    Wi[:, 1:, 0] *= -1
    Wn *= eta[:, None, None]
    Wi /= eta[:, None, None]
    lam = np.einsum("nij,nj->ni", Wn, z)
    return Wn, Wi, lam


def blockdiag(blocks):
    n = blocks.shape[0]
    rows = np.repeat(np.arange(3 * n).reshape(n, 3), 3, axis=1).ravel()
    cols = np.tile(np.arange(3 * n).reshape(n, 1, 3), (1, 3, 1)).ravel()
    return sp.csr_matrix((blocks.ravel(), (rows, cols)), shape=(3 * n, 3 * n))


def ipm(p, max_iter=100, tol=1e-10, verbose=False, time_limit=60.0, frozen_s=False, balance=False):
    t0 = time.perf_counter()
    W = sp.csr_matrix(p.W)
    q = np.asarray(p.q_local, float)
    mu = np.asarray(p.mu, float)
    n = mu.size
    # scaling: W by its largest diagonal, q by its norm (r then ~ |q| / w)
    w_s = float(W.diagonal().max())
    q_s = max(float(np.linalg.norm(q, np.inf)), 1e-300)
    Ws = W / w_s
    qs = q / q_s
    Sx = np.stack([mu, np.ones(n), np.ones(n)], 1)
    Sy = np.stack([np.ones(n), mu, mu], 1)
    r = np.zeros((n, 3)); r[:, 0] = 1.0
    v = np.zeros((n, 3)); v[:, 0] = 1.0
    hist = []
    gap0 = None
    for k in range(max_iter):
        x, y = r * Sx, v * Sy
        gap = float(np.einsum("ij,ij->", x, y)) / n
        gap0 = gap0 or gap
        tau = 1e-2 * np.sqrt(gap / gap0)
        u = (Ws @ r.ravel() + qs).reshape(n, 3)
        phi = np.sqrt(np.einsum("ij,ij->i", u[:, 1:], u[:, 1:]) + tau ** 2)
        c = u.copy(); c[:, 0] += mu * phi
        R1 = v - c
        if k == 0:
            R1_0 = max(float(np.linalg.norm(R1)), 1e-300)
        R2 = jordan(x, y)
        err = siconos_error(p, r.ravel() * q_s / w_s)
        hist.append((k, gap, float(np.linalg.norm(R1)), err))
        if verbose:
            print(f"{k:3d} gap {gap:.2e} |R1| {np.linalg.norm(R1):.2e} err {err:.2e} tau {tau:.1e}")
        if err < tol or time.perf_counter() - t0 > time_limit:
            break
        # D per contact
        D = np.zeros((n, 3, 3)); D[:, 0, 0] = D[:, 1, 1] = D[:, 2, 2] = 1.0
        if not frozen_s:
            D[:, 0, 1:] = (mu / phi)[:, None] * u[:, 1:]
        Wn, Wi, lam = nt_scaling(x, y)
        W2 = np.einsum("nij,njk->nik", Wn, Wn)
        B = np.einsum("nij,njk->nik", W2 * Sy[:, None, :], D)    # Wnt^2 Sy D
        Jm = (sp.diags(Sx.ravel()) + blockdiag(B) @ Ws).tocsc()
        lu = spla.splu(Jm)
        W2R1 = np.einsum("nij,nj->ni", W2, Sy * R1)
        LL = arrow_blocks(lam)

        def direction(a_rhs):
            b = np.linalg.solve(LL, a_rhs[..., None])[..., 0]
            rhs = np.einsum("nij,nj->ni", Wn, b) + W2R1
            dr = lu.solve(rhs.ravel()).reshape(n, 3)
            dv = np.einsum("nij,nj->ni", D, (Ws @ dr.ravel()).reshape(n, 3)) - R1
            return dr, dv

        ll = jordan(lam, lam)
        dr_a, dv_a = direction(-ll)
        a_a = min(max_step(x, dr_a * Sx), max_step(y, dv_a * Sy))
        gap_a = float(np.einsum("ij,ij->", x + a_a * dr_a * Sx, y + a_a * dv_a * Sy)) / n
        sigma = min(1.0, (gap_a / gap) ** 3)
        if balance:     # hold the gap back while the infeasibility lags behind it
            sigma = max(sigma, min(1.0, (np.linalg.norm(R1) / R1_0) * gap0 / gap))
        nu = sigma * gap
        corr = jordan(np.einsum("nij,nj->ni", Wi, dr_a * Sx), np.einsum("nij,nj->ni", Wn, dv_a * Sy))
        a_rhs = -ll - corr
        a_rhs[:, 0] += nu
        dr, dv = direction(a_rhs)
        a = min(1.0, 0.99 * min(max_step(x, dr * Sx), max_step(y, dv * Sy)))
        if verbose:
            print(f"      a_aff {a_a:.2e} sigma {sigma:.2e} a {a:.2e}")
        r = r + a * dr
        v = v + a * dv
    return r.ravel() * q_s / w_s, hist


def shift_fixed_point(p, iterations, report=(10, 20, 40)):
    """The De Saxcé fixed point on the shift ``s = mu |u_T|`` without acceleration, each SOCP
    solved by Clarabel at 1e-12: ``{k: (error, |s_k - s*| / |s*|)}`` at the iterations
    ``report`` (``s*`` from the manufactured solution)."""
    n = p.n_contacts
    us = p.velocity(p.solution.r).reshape(n, 3)
    s_star = p.mu * np.linalg.norm(us[:, 1:], axis=1)
    inner = ClarabelInner(p)
    s = np.zeros(n)
    out = {}
    for k in range(1, iterations + 1):
        sh = np.zeros((n, 3))
        sh[:, 0] = s
        r, _ = inner.solve(p.q_local + sh.ravel(), 1e-12)
        if k in report:
            out[k] = (siconos_error(p, r), float(np.linalg.norm(s - s_star) / np.linalg.norm(s_star)))
        s = p.mu * np.linalg.norm(p.velocity(r).reshape(n, 3)[:, 1:], axis=1)
    return out, sticking_that_slip(p, r)


def sticking_that_slip(p, r):
    """At ``r``: how many contacts that stick in the manufactured solution (``r* != 0``,
    ``u* = 0``) slip (``|u_T|`` above 1 % of the largest ``|u*_T|``), with their largest
    ``|u_T|``, largest ``r_N`` and largest contact error."""
    from socp_cd.residuals import contact_errors
    n = p.n_contacts
    rs, us = p.solution.r.reshape(n, 3), p.velocity(p.solution.r).reshape(n, 3)
    stick = (np.abs(rs).max(axis=1) > 0) & (np.abs(us).max(axis=1) == 0)
    ut = np.linalg.norm(p.velocity(r).reshape(n, 3)[:, 1:], axis=1)
    slip = stick & (ut > 1e-2 * np.linalg.norm(us[:, 1:], axis=1).max())
    if not slip.any():
        return int(stick.sum()), 0, 0.0, 0.0, 0.0
    return (int(stick.sum()), int(slip.sum()), float(ut[slip].max()),
            float(r.reshape(n, 3)[slip, 0].max()), float(contact_errors(p, r)[slip].max()))


def shift_newton_krylov(p, plain_first=5, maxiter=15):
    """scipy's Newton-Krylov (LGMRES, finite-difference directional derivatives) on
    ``G(s) = Phi(s) - s`` after ``plain_first`` plain iterations: ``(best error, SOCPs)``."""
    from scipy.optimize import newton_krylov
    n = p.n_contacts
    inner = ClarabelInner(p)
    best = [np.inf, 0]

    def phi(s):
        sh = np.zeros((n, 3))
        sh[:, 0] = s
        r, _ = inner.solve(p.q_local + sh.ravel(), 1e-12)
        best[0], best[1] = min(best[0], siconos_error(p, r)), best[1] + 1
        return p.mu * np.linalg.norm(p.velocity(r).reshape(n, 3)[:, 1:], axis=1)

    s = np.zeros(n)
    for _ in range(plain_first):
        s = phi(s)
    try:
        newton_krylov(lambda s: phi(s) - s, s, method="lgmres", f_tol=1e-14, maxiter=maxiter)
    except Exception:       # (NoConvergence: the budget of Newton iterations ran out)
        pass
    return best[0], best[1]


def study_cases():
    """``(name, problem)``: a fresh Kapla draw (seed 50, never generated before), the tune
    Kapla sliding case, and a control on BoxesStack1 (fresh seed 50)."""
    from socp_cd.bench import evalset
    from socp_cd.data import shared_problems_dir
    d = shared_problems_dir()
    kapla = socp_cd.read_problem(d / "KaplasTower-i1061-4.hdf5.dat")
    boxes = socp_cd.read_problem(d / "BoxesStack1-i100000-32.hdf5.dat")
    cid = "real-manufactured/KaplasTower-i1061-4.hdf5.dat/mu1-sliding-s2"
    assert evalset.split_of(cid) == "tune", cid
    return [("Kapla mu0.1-mixed-s50 (fresh)", evalset.manufacture(kapla, 0.1, evalset.MIXES["mixed"], 50)),
            ("Kapla mu1-sliding-s2 (tune)", evalset.manufacture(kapla, 1.0, evalset.MIXES["sliding"], 2)),
            ("BoxesStack1 mu0.1-sticking-s50 (control)",
             evalset.manufacture(boxes, 0.1, evalset.MIXES["sticking"], 50))]


VARIANTS = {"ipm": {}, "ipm balanced": {"balance": True}, "ipm frozen shift": {"frozen_s": True}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-iter", type=int, default=60)
    ap.add_argument("--fp-iterations", type=int, default=40)
    ap.add_argument("--newton-krylov", action="store_true",
                    help="also Newton-Krylov on the shift (the first case only; ~2 min)")
    a = ap.parse_args()
    socp_cd.warmup()
    lines = ["# Interior point on the Coulomb complementarity problem, and the shift fixed point "
             "(session 36)", "",
             "`python validation/ipm_study.py` (one process; times indicative). Each IPM run: at "
             f"most {a.max_iter} iterations from `r = e, v = e`, its best error, then `newton` "
             "(10 s) from its last iterate. `newton` cold: 10 s from `r = 0`.", "",
             "| case | method | IPM error (best) | IPM its | IPM [s] | then newton | newton cold |",
             "|---|---|---:|---:|---:|---|---|"]
    fp_lines = ["", "Shift fixed point (no acceleration; Clarabel at 1e-12 per SOCP): error and "
                "`|s_k - s*| / |s*|` after k SOCPs.", "",
                "| case | k | error | rel. distance to s* |", "|---|---:|---:|---:|"]
    slip_lines = ["", "At the fixed point's last iterate: contacts that stick in the manufactured "
                  "solution, those of them that slip (`|u_T|` above 1 % of the largest `|u*_T|`), "
                  "their largest `|u_T|`, `r_N` and contact error.", "",
                  "| case | sticking in r* | slipping here | max ‖u_T‖ | max r_N | max error |",
                  "|---|---:|---:|---:|---:|---:|"]
    for name, p in study_cases():
        cold = socp_cd.solve(p, "newton", time_limit=10.0)
        for label, kw in VARIANTS.items():
            t = time.perf_counter()
            try:
                r, hist = ipm(p, max_iter=a.max_iter, **kw)
                best = min(h[3] for h in hist)
                its = str(len(hist))
            except (RuntimeError, np.linalg.LinAlgError, FloatingPointError) as exc:
                r, best, its = None, float("nan"), f"failed ({type(exc).__name__})"
            dt = time.perf_counter() - t
            then = "—"
            if r is not None and np.all(np.isfinite(r)):
                res = socp_cd.solve(p, "newton", r0=r, time_limit=10.0)
                then = f"{res.status} {res.error:.1e} ({res.time:.1f} s)"
            lines.append(f"| {name} | {label} | {best:.1e} | {its} | {dt:.1f} | {then} | "
                         f"{cold.status} {cold.error:.1e} ({cold.time:.1f} s) |")
            print(lines[-1], flush=True)
        rows, (n_stick, n_slip, ut, rn, ce) = shift_fixed_point(p, a.fp_iterations)
        for k, (e, dist) in rows.items():
            fp_lines.append(f"| {name} | {k} | {e:.1e} | {dist:.1e} |")
            print(fp_lines[-1], flush=True)
        slip_lines.append(f"| {name} | {n_stick} | {n_slip} | {ut:.1e} | {rn:.1e} | {ce:.1e} |")
    if a.newton_krylov:
        name, p = study_cases()[0]
        e, n_socp = shift_newton_krylov(p)
        fp_lines += ["", f"Newton-Krylov on the shift ({name}; 5 plain iterations, then scipy "
                     f"`newton_krylov`, LGMRES, 15 Newton iterations): best error {e:.1e} after "
                     f"{n_socp} SOCPs."]
        print(fp_lines[-1], flush=True)
    out = Path(__file__).with_name("results") / "ipm_study_s36.md"
    out.write_text("\n".join(lines + fp_lines + slip_lines) + "\n")
    print("wrote", out)


if __name__ == "__main__":
    with np.errstate(invalid="ignore", divide="ignore"):
        main()
