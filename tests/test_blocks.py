"""3D convex polyhedra: hulls, inertia, quaternions, detectors, manifolds, stepper hooks."""
import warnings

import numpy as np
import pytest

from socp_cd.dynamics import (Box, ConvexPolyhedron, FixedBox, FixedPolyhedron, FixedSphere, OverlapWarning, Plane,
                              Scene, Simulation, Sphere, Trajectory, compile_scene, detect)
from socp_cd.dynamics.assembly import assemble_H, block_inverse_mass, delassus, world_inverse_inertia
from socp_cd.dynamics.geometry3d import (convex_hull, hull_mass_properties, quat_from_rotvec, quat_integrate,
                                         quat_multiply, quat_to_matrix)
from socp_cd.errors import InvalidProblemError


def _qaxis(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis]


# ------------------------------------------------------------------ geometry and inertia
def test_box_hull_topology_and_inertia():
    b = Box((1.0, 2.0, 3.0), mass=12.0)
    assert len(b.hull.faces) == 6 and len(b.hull.edges) == 12 and len(b.hull.directions) == 3
    assert all(len(f) == 4 for f in b.hull.faces)
    assert np.allclose(b.inertia, np.diag([13.0, 10.0, 5.0]), atol=1e-12)     # m/12 (ly²+lz², ...)
    assert b.volume == pytest.approx(6.0)


def test_prism_inertia_analytic_and_recentring():
    R, H, rho = 0.7, 0.4, 3.0
    off = np.array([0.3, -0.2, 1.0])
    p = ConvexPolyhedron.prism(6, R, H, density=rho)
    A = 1.5 * np.sqrt(3) * R ** 2
    m = rho * A * H
    assert p.mass == pytest.approx(m, rel=1e-12)
    # regular hexagon: polar moment (5/12) m R², in-plane axes half of it
    assert np.allclose(p.inertia, np.diag([m * (5 * R ** 2 / 24 + H ** 2 / 12)] * 2 + [m * 5 / 12 * R ** 2]),
                       rtol=1e-12, atol=1e-12)
    # vertices given off-centre: re-centred on the centroid, position moved to it
    q = ConvexPolyhedron(p.vertices + off, position=(1.0, 2.0, 3.0), orientation=_qaxis((0, 0, 1), np.pi / 2))
    assert np.allclose(q.vertices.mean(axis=0), 0.0, atol=1e-12)
    assert np.allclose(q.position, np.array([1.0, 2.0, 3.0]) + quat_to_matrix(q.orientation) @ off)


def test_hull_of_random_points_mass_properties_by_sampling():
    rng = np.random.default_rng(0)
    P = rng.normal(size=(30, 3))
    h = convex_hull(P)
    vol, c, J = hull_mass_properties(h)
    # Monte Carlo reference on the bounding box (loose: sampling error ~1e-2)
    X = rng.uniform(P.min(0), P.max(0), size=(400_000, 3))
    inside = np.all((X - 0.0) @ h.normals.T <= np.array([n @ h.vertices[f[0]] for n, f in zip(h.normals, h.faces)]), 1)
    box_vol = np.prod(P.max(0) - P.min(0))
    assert vol == pytest.approx(box_vol * inside.mean(), rel=2e-2)
    assert np.allclose(c, X[inside].mean(0), atol=2e-2)
    assert np.allclose(J, J.T) and np.all(np.linalg.eigvalsh(J) > 0)


def test_bad_polyhedra_raise():
    with pytest.raises(InvalidProblemError, match="vertices"):
        ConvexPolyhedron(np.zeros((3, 3)))
    with pytest.raises(InvalidProblemError, match="coplanar"):
        ConvexPolyhedron(np.c_[np.random.default_rng(1).normal(size=(6, 2)), np.zeros(6)])
    with pytest.raises(InvalidProblemError, match="Box.size"):
        Box((1.0, -1.0, 1.0))
    with pytest.raises(InvalidProblemError, match="orientation"):
        Box((1, 1, 1), orientation=(0, 0, 0, 0))
    with pytest.raises(InvalidProblemError, match="inertia"):
        Box((1, 1, 1), inertia=(1.0, -1.0, 1.0))


# ------------------------------------------------------------------ quaternions
def test_quaternion_algebra_and_exact_integration():
    rng = np.random.default_rng(2)
    a = quat_from_rotvec(rng.normal(size=3))
    b = quat_from_rotvec(rng.normal(size=3))
    assert np.allclose(quat_to_matrix(quat_multiply(a, b)), quat_to_matrix(a) @ quat_to_matrix(b))
    Rm = quat_to_matrix(a)
    assert np.allclose(Rm @ Rm.T, np.eye(3)) and np.linalg.det(Rm) == pytest.approx(1.0)
    # constant world angular velocity: the exponential update is exact for any step
    w = np.array([[0.3, -1.2, 0.5]])
    q = np.array([[1.0, 0, 0, 0]])
    for _ in range(50):
        q = quat_integrate(q, w, 0.1)
    assert np.allclose(quat_to_matrix(q[0]), quat_to_matrix(quat_from_rotvec(5.0 * w[0])), atol=1e-12)


def test_free_rotation_about_principal_axis_and_energy():
    # torque-free body spinning about a principal axis: omega constant, energy constant
    b = Box((1.0, 2.0, 3.0), omega=(0.0, 0.0, 2.0), orientation=_qaxis((1, 1, 0), 0.7))
    axis = quat_to_matrix(b.orientation) @ np.array([0.0, 0.0, 1.0])
    b.omega = 2.0 * axis
    sim = Simulation(Scene([b], gravity=(0, 0, 0)), 1e-2)
    E0 = sim.energy()
    sim.run(100, progress=False)
    assert np.allclose(sim.sys.vel[0, 3:], 2.0 * axis, atol=1e-10)
    assert sim.energy() == pytest.approx(E0, rel=1e-12)
    # the orientation turned by 2 rad about that axis
    R = quat_to_matrix(sim.sys.orientation[0]) @ quat_to_matrix(b.orientation).T
    assert np.allclose(R, quat_to_matrix(quat_from_rotvec(2.0 * axis)), atol=1e-10)


# ------------------------------------------------------------------ detectors
def test_box_plane_tilted_corner_depth():
    ang = 0.3
    b = Box((1.0, 1.0, 1.0), (0.0, 0.0, 0.0), orientation=_qaxis((0, 1, 0), ang))
    C = detect(compile_scene(Scene([b], [Plane((0, 0, -0.6))])), 0.0)
    low = 0.5 * (np.cos(ang) + np.sin(ang))            # depth of the lowest corners below the centre
    assert C.n == 2
    assert np.allclose(C.gap, 0.6 - low)
    assert np.allclose(C.normal, [0, 0, 1])


def test_box_box_face_manifold_rotated_top():
    # top box turned 45° about z on a larger one: the clipped octagon is reduced to 4 points
    s = 0.8
    top = Box((s, s, 0.5), (0.0, 0.0, 0.75 - 1e-4), orientation=_qaxis((0, 0, 1), np.pi / 4))
    C = detect(compile_scene(Scene([Box((1.0, 1.0, 1.0)), top])), 1e-3)
    assert C.n == 4
    assert np.allclose(C.gap, -1e-4) and np.allclose(C.normal, [0, 0, -1])       # into body 0 (below)
    assert np.allclose(C.point[:, 2], 0.5 - 0.5e-4)
    # every point lies inside both squares
    xy = C.point[:, :2]
    assert np.all(np.abs(xy) <= 0.5 + 1e-12)
    rot = xy @ np.array([[np.cos(np.pi / 4), -np.sin(np.pi / 4)], [np.sin(np.pi / 4), np.cos(np.pi / 4)]])
    assert np.all(np.abs(rot) <= s / 2 + 1e-12)
    assert len(set(C.key.tolist())) == 4


def test_box_box_edge_edge():
    # two long bars crossing at right angles, each turned 45° about its own axis: edge on edge
    a = Box((3.0, 1.0, 1.0), (0, 0, 0), orientation=_qaxis((1, 0, 0), np.pi / 4))
    gap = 0.01
    zb = 2 * np.sqrt(0.5) + gap
    b = Box((1.0, 3.0, 1.0), (0, 0, zb), orientation=_qaxis((0, 1, 0), np.pi / 4))
    C = detect(compile_scene(Scene([a, b])), 0.1)
    assert C.n == 1
    assert C.gap[0] == pytest.approx(gap, abs=1e-12)
    assert np.allclose(C.normal[0], [0, 0, -1])
    assert np.allclose(C.point[0], [0, 0, np.sqrt(0.5) + gap / 2])


@pytest.mark.parametrize("centre, dist, normal", [
    ((0.1, 0.2, 0.5 + 0.3), 0.3, (0, 0, 1)),                                    # above a face
    ((0.5 + 0.2, 0.0, 0.5 + 0.2), 0.2 * np.sqrt(2), (np.sqrt(.5), 0, np.sqrt(.5))),    # beside an edge
    ((0.6, 0.6, 0.6), 0.1 * np.sqrt(3), np.ones(3) / np.sqrt(3)),              # off a corner
    ((0.0, 0.0, 0.4), -0.1, (0, 0, 1)),                                         # centre inside
])
def test_sphere_box_distances(centre, dist, normal):
    Rs = 0.05
    C = detect(compile_scene(Scene([Sphere(Rs, centre), Box((1, 1, 1))])), 1.0)
    c = C.subset(C.j == 1) if np.any(C.j == 1) else C.subset(C.i == 1)
    assert c.n == 1
    assert c.gap[0] == pytest.approx(dist - Rs, abs=1e-12)
    sgn = 1.0 if c.i[0] == 0 else -1.0                 # normal points into member i
    assert np.allclose(sgn * c.normal[0], normal, atol=1e-12)


def test_fixed_obstacles_and_polyhedron_pairs():
    prism = ConvexPolyhedron.prism(6, 0.5, 0.4, position=(0, 0, 0.2 + 1.0 - 2e-4))
    sc = Scene([prism, Sphere(0.1, (2.0, 0.0, 1.1 - 1e-4))],
               [FixedBox((4.0, 4.0, 1.0), (0, 0, 0.5)), FixedSphere(0.2, (0, 0, 1.6 + 1e-3))])
    C = detect(compile_scene(sc), 2e-3)
    on_floor = C.subset((C.i == 0) & (C.obstacle == 0))
    assert on_floor.n == 4 and np.allclose(on_floor.gap, -2e-4) and np.allclose(on_floor.normal, [0, 0, 1])
    sph = C.subset((C.i == 1) & (C.obstacle == 0))
    assert sph.n == 1 and sph.gap[0] == pytest.approx(-1e-4)
    top = C.subset((C.i == 0) & (C.obstacle == 1))
    assert top.n == 1 and top.gap[0] == pytest.approx(1.2e-3) and np.allclose(top.normal, [0, 0, -1])


def test_manifold_stable_under_small_perturbation():
    def contacts(eps):
        rng = np.random.default_rng(5)
        top = Box((0.6, 0.5, 0.4), (0.1 + eps * rng.normal(), 0.05, 0.7 - 1e-4),
                  orientation=quat_from_rotvec(eps * rng.normal(size=3) + [0, 0, 0.2]))
        return detect(compile_scene(Scene([Box((1, 1, 1)), top], [Plane((0, 0, -0.5))])), 1e-3)
    A, B = contacts(0.0), contacts(1e-6)
    assert A.n == B.n == 8
    oa, ob = np.argsort(A.key), np.argsort(B.key)
    assert np.array_equal(A.key[oa], B.key[ob])                     # same feature ids
    assert np.abs(A.point[oa] - B.point[ob]).max() < 1e-5           # points move by O(eps)


def test_keys_persist_over_steps_and_warm_start_hits():
    boxes = [Box((0.2, 0.2, 0.2), (0, 0, 0.1 + 0.2 * k)) for k in range(3)]
    sim = Simulation(Scene(boxes, [Plane()], mu=0.5), 2e-3)
    sim.step()
    keys = np.sort(sim.last_contacts.key)
    its = []
    for _ in range(20):
        its.append(sim.step().iterations)
        assert np.array_equal(np.sort(sim.last_contacts.key), keys)
    assert keys.size == 12
    assert max(its[5:]) < its[0] or its[0] <= 2


# ------------------------------------------------------------------ assembly with full inertia
def test_H_and_block_W_for_rotated_boxes_match_dense():
    rng = np.random.default_rng(3)
    boxes = [Box((1, 0.6, 0.4), (0, 0, 0.2 - 1e-4), orientation=quat_from_rotvec([0, 0, 0.3]),
                 velocity=rng.normal(size=3), omega=rng.normal(size=3)),
             Box((0.5, 0.5, 0.5), (0.1, 0.0, 0.65 - 2e-4), orientation=quat_from_rotvec([0.0, 0.0, 1.0]),
                 velocity=rng.normal(size=3), omega=rng.normal(size=3))]
    sys = compile_scene(Scene(boxes, [Plane()]))
    C = detect(sys, 1e-3)
    H, E = assemble_H(sys, C)
    u = (H.T @ sys.vel.reshape(-1)).reshape(-1, 3)
    for c in range(C.n):
        vi = sys.vel[C.i[c], :3] + np.cross(sys.vel[C.i[c], 3:], C.point[c] - sys.pos[C.i[c]])
        vj = 0.0 if C.j[c] < 0 else sys.vel[C.j[c], :3] + np.cross(sys.vel[C.j[c], 3:], C.point[c] - sys.pos[C.j[c]])
        assert np.allclose(u[c], E[c] @ (vi - vj))
    R = quat_to_matrix(sys.orientation)
    Minv = block_inverse_mass(1 / sys.mass, world_inverse_inertia(R, sys.inertia_body, np.zeros(2, bool)))
    dense = np.zeros((12, 12))
    for b in range(2):
        dense[6 * b:6 * b + 3, 6 * b:6 * b + 3] = np.eye(3) / sys.mass[b]
        dense[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = np.linalg.inv(R[b] @ sys.inertia_body[b] @ R[b].T)
    Hd = H.toarray()
    assert np.allclose(delassus(H, Minv).toarray(), Hd.T @ dense @ Hd, atol=1e-12)


# ------------------------------------------------------------------ stepper hooks
def test_state_roundtrip_reproduces_the_run():
    def scene():
        return Scene([Box((0.2, 0.2, 0.2), (0, 0, 0.12), omega=(1.0, 0.5, 0.0)),
                      Box((0.2, 0.2, 0.2), (0.05, 0, 0.35))], [Plane()], mu=0.4)
    a = Simulation(scene(), 2e-3)
    a.run(30, progress=False)
    state = a.get_state()
    a.run(30, progress=False)
    b = Simulation(scene(), 2e-3)
    b.set_state(state)
    b.run(30, progress=False)
    assert np.array_equal(a.sys.pos, b.sys.pos) and np.array_equal(a.sys.orientation, b.sys.orientation)
    assert a.last_problem is not None and a.last_result is not None and a.last_active.n == a.last_contacts.n
    assert a.last_problem.W.shape[0] == 3 * a.last_contacts.n
    with pytest.raises(InvalidProblemError, match="pos"):
        b.set_state({**state, "pos": np.zeros((3, 3))})


def test_use_solver_switches_the_next_steps():
    sim = Simulation(Scene([Box((0.2, 0.2, 0.2), (0, 0, 0.1))], [Plane()], mu=0.4), 2e-3,
                     solver="nsgs", tol=1e-4, max_iter=7, solver_options={"time_limit": 5.0})
    sim.run(3, progress=False)
    assert sim.last_result.solver == "nsgs"
    from socp_cd.solvers import newton
    newton.warmup()     # (a cold numba cache would spend the 2 s limit below compiling)
    sim.use_solver("newton", tol=1e-10, time_limit=2.0)
    assert sim.max_iter is None and sim.solver_options == {"time_limit": 2.0} and sim.tol == 1e-10
    sim.run(1, progress=False)
    assert sim.last_result.solver == "newton" and sim.last_result.converged
    assert sim.last_problem.n_contacts >= 3            # the box rests on its contacts
    assert sim.last_result.error <= 1e-10
    sim.use_solver("nsgs", max_iter=3)                       # no time limit, tol kept
    assert sim.solver_options == {} and sim.tol == 1e-10 and sim.max_iter == 3
    sim.use_solver("nsgs", options={"omega": 1.2})
    assert sim.solver_options == {"omega": 1.2}
    sim.use_solver("newton")                                 # nsgs's omega is not carried over
    assert sim.solver_options == {}
    for bad in (dict(tol=0.0), dict(tol="x"), dict(time_limit=-1.0), dict(form="mixed"),
                dict(max_iter=0), dict(max_iter=2.5)):
        with pytest.raises(InvalidProblemError):
            sim.use_solver("nsgs", **bad)


def test_trajectory_keeps_orientations(tmp_path):
    sim = Simulation(Scene([Box((0.2, 0.2, 0.2), (0, 0, 0.5), omega=(0, 0, 3.0))], [Plane()]), 1e-2)
    traj = sim.run(5, progress=False)
    assert traj.orientation.shape == (6, 1, 4)
    back = Trajectory.load(traj.save(tmp_path / "t.h5"))
    assert np.array_equal(back.orientation, traj.orientation)
    assert "hull_vertices" in back.geometry


def test_materials_table_precedence():
    sc = Scene([Box((0.2, 0.2, 0.2), (0, 0, 0.1), material="wood", mu=0.9),
                Box((0.2, 0.2, 0.2), (0, 0, 0.3), material="steel", mu=0.7),
                Box((0.2, 0.2, 0.2), (1, 0, 0.1), mu=0.2)],
               [Plane(material="wood", mu=0.8)], mu=0.1,
               materials={("steel", "wood"): {"mu": 0.25, "restitution": 0.0}, ("wood", "wood"): {"mu": 0.6}})
    C = detect(compile_scene(sc), 1e-3)
    mu = {(int(i), int(j), int(o)): m for i, j, o, m in zip(C.i, C.j, C.obstacle, C.mu)}
    assert mu[(0, 1, -1)] == 0.25          # pair table (unordered) wins over body values
    assert mu[(0, -1, 0)] == 0.6           # wood–wood from the table
    assert mu[(2, -1, 0)] == 0.2           # no material on body 2: min of member values
    with pytest.raises(InvalidProblemError, match="materials"):
        compile_scene(Scene([Box()], materials={("a", "b"): {"friction": 1.0}}))


def test_initial_overlap_warns_and_projection_removes_it():
    sc = Scene([Box((0.2, 0.2, 0.2), (0, 0, 0.1 - 3e-3)), Box((0.2, 0.2, 0.2), (0.5, 0, 0.2))], [Plane()])
    with pytest.warns(OverlapWarning, match=r"bodies\[0\] \(Box\) and obstacles\[0\] \(Plane\) overlap by 0.003"):
        sim = Simulation(sc, 1e-3)
    sim.step()
    C = detect(sim.sys, 0.0)
    assert C.n == 0 or C.gap.min() > -sim.projection_tol
    with warnings.catch_warnings():
        warnings.simplefilter("error", OverlapWarning)
        Simulation(Scene([Box((0.2, 0.2, 0.2), (0, 0, 0.1))], [Plane()]), 1e-3)


def test_resting_stack_penetration_stays_small():
    L = 0.1
    boxes = [Box((L, L, L), (0, 0, L / 2 + k * L), density=1000.0) for k in range(5)]
    sim = Simulation(Scene(boxes, [Plane()], mu=0.5), 2e-3, tol=1e-8)
    worst = 0.0
    for _ in range(300):
        sim.step()
        worst = max(worst, -sim.last_contacts.gap.min())
    assert worst < 1e-3 * L
    assert np.abs(sim.sys.vel).max() < 1e-4


def test_global_form_matches_local_form_with_full_inertia():
    def sim(form):
        boxes = [Box((0.3, 0.2, 0.1), (0, 0, 0.05), orientation=quat_from_rotvec([0.1, 0.0, 0.4]),
                      omega=(0.0, 0.0, 0.5)),
                 Box((0.2, 0.2, 0.2), (0.0, 0.0, 0.2), orientation=quat_from_rotvec([0.0, 0.0, 0.3]))]
        s = Simulation(Scene(boxes, [Plane()], mu=0.4), 1e-3, solver="clarabel", tol=1e-10, form=form,
                       check_overlap=False)
        s.run(5, progress=False)
        return s
    a, b = sim("local"), sim("global")
    assert np.allclose(a.sys.vel, b.sys.vel, atol=1e-7)
    assert np.allclose(a.sys.orientation, b.sys.orientation, atol=1e-10)
