"""Narrow/broad phase: every supported pair, touching, deep penetration, parallel edges."""
import numpy as np
import pytest

from socp_cd.dynamics import (Disk, FixedDisk, FixedPolygon, FixedSphere, Line, Plane, Polygon, Scene,
                              Sphere, compile_scene, detect)
from socp_cd.errors import InvalidProblemError


def contacts(bodies, obstacles=(), margin=0.0):
    return detect(compile_scene(Scene(list(bodies), list(obstacles))), margin)


def sorted_by_x(C):
    o = np.argsort(C.point[:, 0])
    return C.subset(o)


def test_disk_disk_touching_and_deep():
    C = contacts([Disk(1.0, (0, 0)), Disk(0.5, (1.5, 0))])
    assert C.n == 1
    assert C.gap[0] == pytest.approx(0.0, abs=1e-14)
    # normal from j into i: pair is (0, 1) with normal pointing into body 0, i.e. -x
    i, j = C.i[0], C.j[0]
    assert (i, j) == (0, 1)
    assert np.allclose(C.normal[0], [-1, 0])
    assert np.allclose(C.point[0], [1.0, 0])
    C = contacts([Disk(1.0, (0, 0)), Disk(1.0, (0.0, 1.2))])
    assert C.gap[0] == pytest.approx(-0.8)
    assert np.allclose(C.normal[0], [0, -1])
    assert np.allclose(C.point[0], [0, 0.6])
    # separated beyond the margin: nothing; inside the margin: detected with positive gap
    assert contacts([Disk(1, (0, 0)), Disk(1, (2.1, 0))]).n == 0
    C = contacts([Disk(1, (0, 0)), Disk(1, (2.1, 0))], margin=0.2)
    assert C.gap[0] == pytest.approx(0.1)


def test_disk_line_inclined_touching_and_deep():
    a = np.radians(30)
    line = Line.inclined(a, point=(1.0, 0.0))
    n = np.array([-np.sin(a), np.cos(a)])
    c = np.array([1.0, 0.0]) + 2.0 * np.array([np.cos(a), np.sin(a)]) + 0.3 * n
    C = contacts([Disk(0.3, c)], [line])
    assert C.n == 1 and C.j[0] == -1 and C.obstacle[0] == 0
    assert C.gap[0] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(C.normal[0], n)
    assert np.allclose(C.point[0], c - 0.3 * n)
    C = contacts([Disk(0.3, c - 0.5 * n)], [line])
    assert C.gap[0] == pytest.approx(-0.5)


def test_disk_polygon_face_vertex_and_inside():
    box = Polygon.box(2.0, 1.0, (0.0, 0.0))
    # above the top face, touching
    C = contacts([Disk(0.5, (0.3, 1.0)), box])
    assert C.n == 1 and (C.i[0], C.j[0]) == (0, 1)
    assert C.gap[0] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(C.normal[0], [0, 1])
    # near the corner (1, 0.5): normal along the diagonal, gap = dist - R
    c = np.array([1.0, 0.5]) + 0.4 * np.array([1, 1]) / np.sqrt(2)
    C = contacts([Disk(0.3, c), box], margin=0.2)
    assert C.gap[0] == pytest.approx(0.1)
    assert np.allclose(C.normal[0], np.array([1, 1]) / np.sqrt(2))
    # centre inside the box, closest face is the right one (distance 0.2)
    C = contacts([Disk(0.25, (0.8, 0.1)), box])
    assert C.gap[0] == pytest.approx(-0.45)
    assert np.allclose(C.normal[0], [1, 0])


def test_polygon_polygon_parallel_edges_two_points():
    lower = Polygon.box(2.0, 1.0, (0.0, 0.5))
    upper = Polygon.box(1.0, 1.0, (0.7, 1.5))
    C = sorted_by_x(contacts([lower, upper]))
    assert C.n == 2
    assert np.allclose(C.gap, 0.0, atol=1e-12)
    # the points are the ends of the overlap [0.2, 1.0] at y = 1
    assert np.allclose(C.point, [[0.2, 1.0], [1.0, 1.0]])
    for k in range(2):
        into_i = np.array([0, 1]) if C.i[k] == 1 else np.array([0, -1])
        assert np.allclose(C.normal[k], into_i)
    # deep penetration by 0.3 keeps two points with gap -0.3
    upper = Polygon.box(1.0, 1.0, (0.7, 1.2))
    C = contacts([lower, upper])
    assert C.n == 2 and np.allclose(C.gap, -0.3)


def test_polygon_vertex_on_face_single_point():
    lower = Polygon.box(2.0, 1.0, (0.0, 0.5))
    diamond = Polygon.regular(4, 0.5, (0.1, 1.5))           # vertex (0.1, 1.0) touches the top face
    C = contacts([lower, diamond])
    assert C.n == 1
    assert C.gap[0] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(C.point[0], [0.1, 1.0])
    sign = 1 if C.i[0] == 1 else -1
    assert np.allclose(C.normal[0], [0, sign])


def test_polygon_line_flat_and_tilted():
    C = sorted_by_x(contacts([Polygon.box(1.0, 0.5, (0.0, 0.25))], [Line()]))
    assert C.n == 2 and np.allclose(C.gap, 0, atol=1e-12)
    assert np.allclose(C.point, [[-0.5, 0.0], [0.5, 0.0]])
    assert np.allclose(C.normal, [[0, 1], [0, 1]])
    # tilted by 10°, lowest corner 0.05 below the line
    b = Polygon.box(1.0, 0.5, (0.0, 0.0), angle=np.radians(10))
    V = b.vertices @ np.array([[np.cos(b.angle), np.sin(b.angle)], [-np.sin(b.angle), np.cos(b.angle)]])
    low = V[:, 1].min()
    b.position = np.array([0.0, -low - 0.05])
    C = contacts([b], [Line()])
    assert C.n == 1 and C.gap[0] == pytest.approx(-0.05)


def test_fixed_obstacles_polygon_and_disk():
    ground = FixedPolygon([[-1, -1], [1, -1], [1, 0], [-1, 0]])
    C = sorted_by_x(contacts([Polygon.box(0.4, 0.2, (0.0, 0.1))], [ground]))
    assert C.n == 2 and np.all(C.j == -1) and np.all(C.obstacle == 0)
    assert np.allclose(C.normal, [[0, 1], [0, 1]]) and np.allclose(C.gap, 0, atol=1e-12)
    C = contacts([Disk(0.2, (0.0, 0.15))], [ground])
    assert C.n == 1 and C.gap[0] == pytest.approx(-0.05) and np.allclose(C.normal[0], [0, 1])
    # polygon resting on a fixed disk: normal from the disk into the polygon (+y)
    C = contacts([Polygon.box(0.4, 0.2, (0.0, 0.6))], [FixedDisk(0.5, (0.0, 0.0))])
    assert C.n == 1 and C.gap[0] == pytest.approx(0.0, abs=1e-12) and np.allclose(C.normal[0], [0, 1])
    C = contacts([Disk(0.5, (0.0, 0.9))], [FixedDisk(0.5, (0.0, 0.0))])
    assert C.gap[0] == pytest.approx(-0.1) and np.allclose(C.normal[0], [0, 1])


def test_spheres_and_planes():
    C = contacts([Sphere(0.5, (0, 0, 0.5)), Sphere(0.5, (0.6, 0.8, 0.5))], [Plane()])
    assert C.n == 3
    ss = C.subset(C.j >= 0)
    assert ss.gap[0] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(np.abs(ss.normal[0]), [0.6, 0.8, 0])
    pl = C.subset(C.j < 0)
    assert np.allclose(pl.gap, 0, atol=1e-12) and np.allclose(pl.normal, [[0, 0, 1]] * 2)
    C = contacts([Sphere(0.5, (0, 0, 0.3))], [FixedSphere(0.2, (0, 0, -0.3)), Plane()])
    assert sorted(np.round(C.gap, 12)) == [-0.2, -0.1]


def test_keys_persist_under_small_motion_and_zero_contacts():
    b = [Polygon.box(2.0, 1.0, (0.0, 0.5)), Polygon.box(1.0, 1.0, (0.7, 1.5)), Disk(0.2, (3, 0.2))]
    k1 = np.sort(contacts(b, [Line()]).key)
    b[1].position = b[1].position + [0.01, -0.001]
    k2 = np.sort(contacts(b, [Line()]).key)
    assert k1.size == 5 and np.array_equal(k1, k2)
    assert contacts([Disk(0.1, (0, 1)), Disk(0.1, (1, 1))], [Line()]).n == 0


def test_invalid_shapes_raise():
    with pytest.raises(InvalidProblemError):
        Disk(-1.0)
    with pytest.raises(InvalidProblemError):
        Polygon([[0, 0], [1, 0], [0.2, 0.2], [0, 1]])      # not convex
    with pytest.raises(InvalidProblemError):
        compile_scene(Scene([Disk(1.0)], [Plane()]))          # 3D obstacle in a 2D scene


def _sat_separation(A, B):
    """Independent separating-axis value: max over all edge normals of min(B·n) - max(A·n)."""
    best = -np.inf
    for P in (A, B):
        E = np.roll(P, -1, axis=0) - P
        N = np.c_[E[:, 1], -E[:, 0]] / np.linalg.norm(E, axis=1)[:, None]
        for n in N:
            best = max(best, min(B @ n) - max(A @ n), min(A @ n) - max(B @ n))
    return best


def test_random_polygon_pairs_depth_matches_sat():
    rng = np.random.default_rng(3)
    checked = 0
    for _ in range(60):
        polys = []
        for c in ((0.0, 0.0), rng.uniform(-0.6, 0.6, 2)):
            k = rng.integers(3, 8)
            a = np.sort(rng.uniform(0, 2 * np.pi, k))
            a = np.unique(np.round(a, 3))
            if len(a) < 3 or np.max(np.diff(np.r_[a, a[0] + 2 * np.pi])) > np.pi * 0.95:
                break
            polys.append(Polygon(0.5 * np.c_[np.cos(a), np.sin(a)], position=c, angle=rng.uniform(0, 6)))
        if len(polys) < 2:
            continue
        sys = compile_scene(Scene(polys))
        W = sys.poly_world()
        A, B = W[0, :sys.poly_nv[0]], W[1, :sys.poly_nv[1]]
        sat = _sat_separation(A, B)
        C = detect(sys, 0.0)
        if sat < -1e-9:
            assert C.n >= 1
            assert C.gap.min() == pytest.approx(sat, abs=1e-10)
            # the normal (from j into i) is the separating axis: along it, min(i) - max(j) = depth
            P = {0: A, 1: B}
            for c in range(C.n):
                n = C.normal[c]
                assert min(P[C.i[c]] @ n) - max(P[C.j[c]] @ n) == pytest.approx(sat, abs=1e-10)
            checked += 1
        elif sat > 1e-9:
            assert C.n == 0
    assert checked >= 10
