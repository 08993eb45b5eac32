"""Validation cases with closed-form solutions.

Each case function ``case_xxx(solver="nsgs", quick=False)`` builds a scene,
integrates it with :class:`~socp_cd.dynamics.stepper.Simulation` and returns
a list of :class:`Row` comparing computed quantities with their exact values.
``quick=True`` shortens the run (used by the test-suite) without changing the
stated tolerances' justification (the tolerances are recomputed from ``h``).

Error measure: ``|computed - exact| / max(|exact|, scale)`` where ``scale``
is the row's reference magnitude (used when the exact value is 0, e.g. the
velocity of a sticking block, measured against the velocity it would reach
in free sliding).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bodies import Box, Disk, Force, Line, Plane, Polygon, Sphere, Spring
from .scene import Scene
from .stepper import Simulation

G = 9.81
SOLVER_TOL = 1e-10


@dataclass
class Row:
    """One line of the validation table."""

    case: str
    quantity: str
    exact: float
    computed: float
    tol: float
    solver: str
    scale: float = 0.0
    why: str = ""

    @property
    def error(self) -> float:
        return abs(self.computed - self.exact) / max(abs(self.exact), self.scale, 1e-300)

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.computed) and self.error <= self.tol)


def _sim(scene, h, solver, **kw) -> Simulation:
    return Simulation(scene, h, solver=solver, tol=kw.pop("tol", SOLVER_TOL), **kw)


def _solver_tol_rows_ok(sim) -> bool:
    return all(s.converged for s in sim.stats)


# ----------------------------------------------------------------------------- particle pushed
def case_pushed_particle(solver="nsgs", quick=False):
    """A non-rotating particle on a rough line pushed by a constant force F.

    Exact: it sticks iff ``|F| <= mu m g``; otherwise ``a = (F - mu m g)/m``.
    The θ-scheme integrates constant forces exactly, so both are met to the
    solver tolerance (tol 1e-6).
    """
    mu, m, h = 0.4, 2.0, 1e-2
    n = 20 if quick else 100
    T = n * h
    rows = []
    for label, ratio in (("stick", 0.8), ("slip", 1.5)):
        F = ratio * mu * m * G
        sc = Scene([Disk(0.1, (0.0, 0.1), mass=m, fixed_rotation=True)], [Line()], mu=mu,
                   forces=[Force(0, lambda t, F=F: (F, 0.0))])
        sim = _sim(sc, h, solver)
        sim.run(n, progress=False)
        vx = sim.sys.vel[0, 0]
        exact = 0.0 if ratio <= 1 else (F - mu * m * G) / m
        rows.append(Row(f"pushed particle ({label}, F={ratio}·mu m g)", "acceleration v(T)/T",
                        exact, vx / T, 1e-6, solver, scale=mu * G,
                        why="tol 1e-6 = solver level: constant forces are integrated exactly by the θ-scheme"))
    return rows


# ----------------------------------------------------------------------------- block on incline
def _block_on_incline(alpha, mu):
    w, hb = 1.0, 0.5
    line = Line.inclined(alpha)
    t = np.array([np.cos(alpha), np.sin(alpha)])
    c = 1.0 * t + 0.5 * hb * line.normal
    return Scene([Polygon.box(w, hb, c, angle=alpha)], [line], mu=mu), t


def _incline_rows(name, build, mu, solver, quick):
    """Stick (20°) / slip (35°) rows for a block built by ``build(alpha) -> (scene, unit vector up the slope)``."""
    h = 1e-2
    n = 20 if quick else 100
    T = n * h
    rows = []
    for alpha_deg in (20.0, 35.0):
        a = np.radians(alpha_deg)
        sc, t = build(a)
        sim = _sim(sc, h, solver)
        sim.run(n, progress=False)
        v = sim.sys.vel[0, :t.size] @ t
        exact = max(0.0, G * (np.sin(a) - mu * np.cos(a)))
        label = "stick" if np.tan(a) <= mu else "slip"
        rows.append(Row(f"{name} {alpha_deg:g}° mu={mu} ({label})", "acceleration along slope",
                        exact, -v / T, 1e-6, solver, scale=G * np.sin(a),
                        why="tol 1e-6 = solver level: constant forces are integrated exactly by the θ-scheme"))
    return rows


def case_block_incline(solver="nsgs", quick=False):
    """A box (polygon, two vertex contacts) on an inclined rough line.

    Exact: sticks iff ``tan(alpha) <= mu``; else ``a = g (sin alpha - mu cos alpha)``.
    Constant forces → exact in the θ-scheme; tolerance 1e-6 (solver level).
    """
    mu = 0.5
    return _incline_rows("box on incline", lambda a: _block_on_incline(a, mu), mu, solver, quick)


# ----------------------------------------------------------------------------- spring-driven particle
def case_sweeping(solver="nsgs", quick=False):
    """A particle dragged through a spring whose end moves at speed V (sweeping process).

    Quasi-static exact solution ``x = max(x0, u(t) - mu m g / k)``.  Inertia
    makes the particle oscillate about it with amplitude at most ``V/omega``
    (``omega = sqrt(k/m)``); the θ-scheme adds O(hV).  Tolerance on ``x(T) - x0``:
    ``(V/omega + 2 h V) / (x_qs(T) - x0)``; on the onset time ``t_s = mu m g/(k V)``: ``2h / t_s``.
    """
    mu, m, k, V, h = 0.3, 1.0, 1000.0, 0.01, 5e-3
    T = 2.0 if quick else 10.0
    n = int(round(T / h))
    x0 = 0.0
    drv = lambda t: (x0 + V * t, 0.1)  # noqa: E731
    sc = Scene([Disk(0.1, (x0, 0.1), mass=m, fixed_rotation=True)], [Line()], mu=mu,
               springs=[Spring(0, drv, k)])
    sim = _sim(sc, h, solver)
    xs, ts = [], []
    sim.run(n, progress=False, callback=lambda s, st: (xs.append(s.sys.pos[0, 0]), ts.append(s.t)))
    xs, ts = np.array(xs), np.array(ts)
    delta = mu * m * G / k
    x_qs = max(x0, x0 + V * T - delta)
    omega = np.sqrt(k / m)
    ts_exact = delta / V
    moved = np.flatnonzero(xs - x0 > 1e-9)
    ts_comp = ts[moved[0]] if moved.size else np.inf
    return [
        Row("spring-dragged particle (sweeping)", "x(T) - x0", x_qs - x0, xs[-1] - x0,
            (V / omega + 2 * h * V) / (x_qs - x0), solver,
            why="tol = (V/ω + 2hV)/(x_qs(T) - x0): inertial deviation from the quasi-static limit <= V/ω (ω = √(k/m)), plus O(hV)"),
        Row("spring-dragged particle (sweeping)", "slip onset time", ts_exact, ts_comp,
            2 * h / ts_exact, solver, why="tol = 2h/t_s: onset resolved to within the step, O(h)"),
    ]


# ----------------------------------------------------------------------------- bouncing ball
def case_bouncing_ball(solver="nsgs", quick=False):
    """A ball dropped from height h0 on a floor with restitution e (frictionless).

    Exact: apex heights ``e^{2n} h0``; time to rest ``sqrt(2 h0/g)(1+e)/(1-e)``.
    Impacts are applied at the step where the predicted gap closes, i.e. up to
    ``h V_n`` before contact: apex error <= ``2 h V_n`` (O(h)); the rest time
    accumulates one-step errors over the ~log(hg/V0)/log(e) bounces:
    tolerance ``20 h / T_rest``.
    """
    e, h0, R = 0.5, 1.0, 0.1
    h = 1e-3 if quick else 5e-4
    T_rest = np.sqrt(2 * h0 / G) * (1 + e) / (1 - e)
    T = 1.2 * T_rest if not quick else 1.1
    n = int(round(T / h))
    sc = Scene([Disk(R, (0.0, R + h0))], [Line()], restitution=e)
    sim = _sim(sc, h, solver)
    ys, vs, ts = [], [], []
    sim.run(n, progress=False, callback=lambda s, st: (ys.append(s.sys.pos[0, 1] - R),
                                                        vs.append(s.sys.vel[0, 1]), ts.append(s.t)))
    ys, vs, ts = np.array(ys), np.array(vs), np.array(ts)
    # apexes: velocity changes sign from + to -
    up = np.flatnonzero((vs[:-1] > 0) & (vs[1:] <= 0))
    rows = []
    V0 = np.sqrt(2 * G * h0)
    for k in (1, 2):
        exact = e ** (2 * k) * h0
        comp = ys[up[k - 1]:up[k - 1] + 2].max() if len(up) >= k else np.nan
        rows.append(Row(f"bouncing ball e={e}", f"apex height {k}", exact, comp,
                        2 * h * V0 * e ** (k - 1) / exact, solver,
                        why="tol = 2 h V_n / apex_n: impact applied up to one step before contact, O(h)"))
    if not quick:
        moving = np.flatnonzero(np.abs(vs) > 2 * G * h)
        t_rest = ts[moving[-1]] if moving.size else 0.0
        rows.append(Row(f"bouncing ball e={e}", "time to rest", T_rest, t_rest, 20 * h / T_rest, solver,
                        why="tol = 20 h / T_rest: one-step timing error per bounce, ~10 bounces before |v| < 2gh, O(h)"))
    return rows


# ----------------------------------------------------------------------------- sliding → rolling
def case_sliding_disk(solver="nsgs", quick=False):
    """A disk launched sliding (v0, omega=0) on a rough plane: friction spins it up.

    Exact: rolling starts at ``t* = v0/(3 mu g)`` with speed ``2 v0 / 3``
    (angular momentum about the contact point is conserved, so the final speed
    is met to solver tolerance, 1e-6); t* is detected to within a step: tol ``2h/t*``.
    """
    mu, v0, R, h = 0.2, 2.0, 0.1, 1e-3
    return _sliding_to_rolling(
        f"disk sliding→rolling mu={mu}", Scene([Disk(R, (0.0, R), velocity=(v0, 0.0))], [Line()], mu=mu),
        t_star=v0 / (3 * mu * G), v_final=2 * v0 / 3, v0=v0, h=h, solver=solver, quick=quick,
        slip=lambda vel: vel[0, 0] + vel[0, 2] * R)


def case_sliding_sphere(solver="nsgs", quick=False):
    """3D: a sphere launched sliding: ``t* = 2 v0/(7 mu g)``, final speed ``5 v0/7``."""
    mu, v0, R, h = 0.2, 2.0, 0.1, 1e-3
    # contact point velocity x-component: v_x + (omega x (-R e_z))_x = v_x - omega_y R
    return _sliding_to_rolling(
        f"sphere sliding→rolling mu={mu} (3D)",
        Scene([Sphere(R, (0.0, 0.0, R), velocity=(v0, 0.0, 0.0))], [Plane()], mu=mu),
        t_star=2 * v0 / (7 * mu * G), v_final=5 * v0 / 7, v0=v0, h=h, solver=solver, quick=quick,
        slip=lambda vel: vel[0, 0] - vel[0, 4] * R)


def _sliding_to_rolling(case, scene, *, t_star, v_final, v0, h, solver, quick, slip):
    """Run a body launched sliding until it rolls; compare onset time and final speed."""
    T = t_star * (1.2 if quick else 1.5)
    sim = _sim(scene, h, solver)
    slips, ts = [], []
    sim.run(int(round(T / h)), progress=False,
            callback=lambda s, st: (slips.append(slip(s.sys.vel)), ts.append(s.t)))
    rolled = np.flatnonzero(np.abs(np.array(slips)) <= 1e-6 * v0)
    t_comp = ts[rolled[0]] if rolled.size else np.inf
    return [
        Row(case, "rolling onset t*", t_star, t_comp, 2 * h / t_star, solver,
            why="tol = 2h/t*: stick–slip transition resolved to within a step, O(h)"),
        Row(case, "final speed", v_final, sim.sys.vel[0, 0], 1e-6, solver,
            why="tol 1e-6 = solver level: angular momentum about the contact point is conserved exactly by the scheme"),
    ]


# ----------------------------------------------------------------------------- rolling down an incline
def case_rolling_incline(solver="nsgs", quick=False):
    """A disk released on an incline with ``mu >= tan(alpha)/3`` rolls without slipping.

    Exact ``a = (2/3) g sin(alpha)``; constant forces → exact in the θ-scheme
    (tol 1e-6, solver level).  Measured from the displacement ``2 s(T)/T²``.
    """
    alpha, mu, R, h = np.radians(30.0), 0.3, 0.1, 1e-2
    n = 20 if quick else 100
    T = n * h
    line = Line.inclined(alpha)
    t = np.array([np.cos(alpha), np.sin(alpha)])
    c0 = 1.0 * t + R * line.normal
    sc = Scene([Disk(R, c0)], [line], mu=mu)
    sim = _sim(sc, h, solver)
    sim.run(n, progress=False)
    s = -(sim.sys.pos[0] - c0) @ t
    return [Row(f"disk rolling down 30° incline mu={mu}", "acceleration 2s/T²", 2 / 3 * G * np.sin(alpha),
                2 * s / T ** 2, 1e-6, solver, why="tol 1e-6 = solver level: constant forces are integrated exactly by the θ-scheme")]


# ----------------------------------------------------------------------------- stack of boxes
def case_box_stack(solver="nsgs", quick=False):
    """n boxes stacked at rest on the floor: interface k from the top carries ``k m g``.

    Exact statics from the first step; redundant (two-point) interfaces make
    individual impulses non-unique but their sums unique: tol 1e-6 (solver level).
    """
    nbox, w, hb, mu, h = 4, 1.0, 0.5, 0.5, 1e-3
    bodies = [Polygon.box(w, hb, (0.0, hb / 2 + k * hb), density=2.0) for k in range(nbox)]
    m = bodies[0].mass
    sc = Scene(bodies, [Line()], mu=mu)
    sim = _sim(sc, h, solver)
    sim.run(3 if quick else 10, progress=False)
    cf = sim.last_contacts
    fn = cf.normal_force
    rows = []
    for k in range(1, nbox + 1):
        lower = nbox - k - 1          # body index below interface k (-1: floor)
        upper = nbox - k
        sel = (cf.pairs[:, 0] == upper) & (cf.pairs[:, 1] == lower) | \
              (cf.pairs[:, 0] == lower) & (cf.pairs[:, 1] == upper) if lower >= 0 else \
              (cf.pairs[:, 0] == upper) & (cf.pairs[:, 1] == -1)
        rows.append(Row(f"stack of {nbox} boxes", f"interface {k} load / (m g)", float(k),
                        fn[sel].sum() / (m * G), 1e-6, solver, why="tol 1e-6 = solver level: statics exact from the first step"))
    return rows


# ----------------------------------------------------------------------------- Newton's cradle
def case_newton_cradle(solver="nsgs", quick=False):
    """Three equal balls, the first hitting the two others (touching) with speed v, e = 1.

    Moreau's simultaneous impact law ``u_N⁺ + e u_N⁻ >= 0 ⊥ r_N >= 0`` on both
    contacts gives velocities ``(-1/3, 2/3, 2/3) v`` (momentum and energy
    conserved).  Single impact step, no discretization error: tol 1e-6.
    """
    R, v, h = 0.1, 1.0, 1e-3
    gap = 0.5 * v * h
    bodies = [Disk(R, (0.0, 0.0), velocity=(v, 0.0)), Disk(R, (2 * R + gap, 0.0)), Disk(R, (4 * R + gap, 0.0))]
    sc = Scene(bodies, [], gravity=(0.0, 0.0), restitution=1.0)
    sim = _sim(sc, h, solver)
    sim.run(5, progress=False)
    return [Row("Newton's cradle, 3 balls, e=1", f"v{k + 1}/v after impact", ex, sim.sys.vel[k, 0] / v, 1e-6,
                solver, scale=1.0, why="tol 1e-6 = solver level: one impact step, the law is solved exactly")
            for k, ex in enumerate((-1 / 3, 2 / 3, 2 / 3))]


# ----------------------------------------------------------------------------- 3D blocks
def _box_on_incline_3d(alpha, size, mu, density=1.0):
    """A :class:`Box` resting on the plane of slope ``alpha`` (rising along +x), body x up the slope.

    Returns the scene and the unit vector up the slope.
    """
    n = np.array([-np.sin(alpha), 0.0, np.cos(alpha)])
    t = np.array([np.cos(alpha), 0.0, np.sin(alpha)])
    q = (np.cos(alpha / 2), 0.0, -np.sin(alpha / 2), 0.0)       # rotation -alpha about y: body z -> n
    box = Box(size, 1.0 * t + 0.5 * size[2] * n, orientation=q, density=density)
    return Scene([box], [Plane((0.0, 0.0, 0.0), n)], mu=mu), t


def case_block_incline_3d(solver="nsgs", quick=False):
    """3D: a box (face contact, 4 points) on a rough incline.

    Exact: sticks iff ``tan(alpha) <= mu``; else ``a = g (sin alpha - mu cos alpha)``.
    Constant forces → exact in the θ-scheme; tolerance 1e-6 (solver level).
    """
    mu = 0.5
    return _incline_rows("3D box on incline", lambda a: _box_on_incline_3d(a, (1.0, 1.0, 0.5), mu), mu,
                         solver, quick)


def case_box_stack_3d(solver="nsgs", quick=False):
    """3D: 4 boxes stacked at rest on a plane: interface k from the top carries ``k m g``.

    Four-point face contacts make individual impulses non-unique, their sum is
    unique: tol 1e-6 (solver level).
    """
    nbox, L, mu, h = 4, 0.5, 0.5, 1e-3
    bodies = [Box((1.0, 0.8, L), (0.0, 0.0, L / 2 + k * L), density=2.0) for k in range(nbox)]
    m = bodies[0].mass
    sim = _sim(Scene(bodies, [Plane()], mu=mu), h, solver)
    sim.run(3 if quick else 10, progress=False)
    cf = sim.last_contacts
    fn = cf.normal_force
    rows = []
    for k in range(1, nbox + 1):
        upper, lower = nbox - k, nbox - k - 1
        pair = np.sort(cf.pairs, axis=1)
        sel = (pair[:, 0] == lower) & (pair[:, 1] == upper) if lower >= 0 else \
            (cf.pairs[:, 0] == upper) & (cf.pairs[:, 1] == -1)
        rows.append(Row(f"3D stack of {nbox} boxes", f"interface {k} load / (m g)", float(k),
                        fn[sel].sum() / (m * G), 1e-6, solver,
                        why="tol 1e-6 = solver level: statics exact from the first step"))
    return rows


def case_tipping_box(solver="nsgs", quick=False):
    """3D: a tall box (width w along the slope, height H) on a rough incline (no sliding).

    Exact: it topples iff ``tan(alpha) > w/H`` (the weight's line leaves the
    base).  Below, it stays at rest (angular velocity 0, solver level, measured
    against the tipping case's ``ω̇ T``); above, it starts rotating about its
    lower edge with ``ω̇ = m g (H/2 sin alpha - w/2 cos alpha) / I_edge``,
    ``I_edge = m (w² + H²)/3``.  The torque changes as the box turns: tol
    ``3 (∂τ/∂φ) φ(T) / τ`` (O(φ), φ the tilt reached at T).
    """
    w, H, depth, mu, h = 0.5, 1.0, 0.6, 1.0, 1e-3
    n = 20
    T = n * h
    alpha_c = np.arctan(w / H)
    rows = []
    for d_deg in (1.0, 5.0):
        d = np.radians(d_deg)
        tau = G * (H / 2 * np.sin(alpha_c + d) - w / 2 * np.cos(alpha_c + d))   # torque / m about the edge
        dtau = G * (H / 2 * np.cos(alpha_c + d) + w / 2 * np.sin(alpha_c + d))
        wdot = tau / ((w ** 2 + H ** 2) / 3)
        phi = 0.5 * wdot * T ** 2
        for label, alpha in (("rests", alpha_c - d), ("topples", alpha_c + d)):
            sc, _ = _box_on_incline_3d(alpha, (w, depth, H), mu)
            sim = _sim(sc, h, solver)
            sim.run(n, progress=False)
            om = -sim.sys.vel[0, 4] / T             # tipping downhill: negative rotation about y
            case = f"tipping box w/H={w / H:g}, alpha = atan(w/H) {'-' if label == 'rests' else '+'} {d_deg:g}° ({label})"
            if label == "rests":
                rows.append(Row(case, "angular acceleration", 0.0, om, 1e-6, solver, scale=wdot,
                                why="tol 1e-6 = solver level: static equilibrium, exact from the first step"))
            else:
                rows.append(Row(case, "angular acceleration", wdot, om, 3 * dtau * phi / tau, solver,
                                why="tol = 3 (∂τ/∂φ) φ(T)/τ: the gravity torque about the edge changes as the box tilts, O(φ)"))
    return rows


CASES = {
    "pushed_particle": case_pushed_particle,
    "block_incline": case_block_incline,
    "sweeping": case_sweeping,
    "bouncing_ball": case_bouncing_ball,
    "sliding_disk": case_sliding_disk,
    "sliding_sphere": case_sliding_sphere,
    "rolling_incline": case_rolling_incline,
    "box_stack": case_box_stack,
    "newton_cradle": case_newton_cradle,
    "block_incline_3d": case_block_incline_3d,
    "box_stack_3d": case_box_stack_3d,
    "tipping_box": case_tipping_box,
}

__all__ = ["Row", "CASES"] + [f.__name__ for f in CASES.values()]
