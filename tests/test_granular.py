"""Tests of socp_cd.granular on hand-built equilibria with hand-computed tensors."""
from __future__ import annotations

import numpy as np
import pytest

from socp_cd.errors import InvalidProblemError
from socp_cd.granular import (GranularState, asymmetry, cauchy_deviation, continuum_traction,
                              coordination_number, cut_sweep, cut_traction, external_stress,
                              fabric_tensor, force_distribution, internal_moment, moreau_stress,
                              principal, rattlers, stress_report, weber_stress)

R, M, G = 0.5, 2.0, 9.81
GRAV = np.array([0.0, -G])


def single_disk():
    """Disk of radius R, mass M on the floor y = 0: floor pushes M g up at (0, 0)."""
    return GranularState(centers=[[0.0, R]], masses=[M], volumes=[np.pi * R**2],
                         pairs=[[0, -1]], points=[[0.0, 0.0]], forces=[[0.0, M * G]],
                         normals=[[0.0, 1.0]], gravity=GRAV)


def stacked(P=3.0):
    """Two disks stacked between the floor and a top wall carrying the load P."""
    return GranularState(
        centers=[[0.0, R], [0.0, 3 * R]], masses=[M, M], volumes=[np.pi * R**2] * 2,
        pairs=[[0, -1], [1, 0], [1, -1]],
        points=[[0.0, 0.0], [0.0, 2 * R], [0.0, 4 * R]],
        forces=[[0.0, P + 2 * M * G], [0.0, P + M * G], [0.0, -P]],
        normals=[[0, 1.0], [0, 1.0], [0, -1.0]], gravity=GRAV)


def square(F=2.0, Gf=5.0, extra=False):
    """2x2 disks at (±R, ±R) in a 4R x 4R box; walls push F along x, Gf along y."""
    c = [[-R, -R], [R, -R], [-R, R], [R, R]]
    pairs = [[1, 0], [3, 2], [2, 0], [3, 1],           # internal: horizontal, vertical
             [0, -1], [2, -1], [1, -1], [3, -1],       # left, right walls
             [0, -1], [1, -1], [2, -1], [3, -1]]       # bottom, top walls
    points = [[0, -R], [0, R], [-R, 0], [R, 0],
              [-2 * R, -R], [-2 * R, R], [2 * R, -R], [2 * R, R],
              [-R, -2 * R], [R, -2 * R], [-R, 2 * R], [R, 2 * R]]
    forces = [[F, 0], [F, 0], [0, Gf], [0, Gf],
              [F, 0], [F, 0], [-F, 0], [-F, 0],
              [0, Gf], [0, Gf], [0, -Gf], [0, -Gf]]
    normals = np.array(forces, float) / np.linalg.norm(forces, axis=1, keepdims=True)
    nb = 4
    if extra:                                          # a rattler with no contact
        c = c + [[10.0, 10.0]]
        nb = 5
    return GranularState(centers=c, masses=[M] * nb, volumes=[np.pi * R**2] * nb,
                         pairs=pairs, points=points, forces=forces, normals=normals)


def cross2(a, b):
    return a[0] * b[1] - a[1] * b[0]


def random_equilibrium(seed=0, nb=12):
    """Random disks with random (frictional) internal forces, each grain balanced
    (force and torque) by one wall contact placed where its moment cancels."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 10, (nb, 2))
    m = rng.uniform(1, 2, nb)
    pairs = np.array([(i, j) for i in range(nb) for j in range(i) if rng.random() < 0.35])
    pts = 0.5 * (x[pairs[:, 0]] + x[pairs[:, 1]]) + rng.normal(0, 0.2, (len(pairs), 2))
    f = rng.normal(0, 1, (len(pairs), 2))
    F = m[:, None] * GRAV
    tau = np.zeros(nb)
    for (i, j), p, fk in zip(pairs, pts, f):
        F[i] += fk
        F[j] -= fk
        tau[i] += cross2(p - x[i], fk)
        tau[j] -= cross2(p - x[j], fk)
    # wall force -F at x + a with a x (-F) = -tau  <=>  a = tau/|F|^2 (F_y, -F_x)
    a = (tau / np.sum(F**2, axis=1))[:, None] * np.stack([F[:, 1], -F[:, 0]], axis=1)
    return GranularState(
        centers=x, masses=m, volumes=np.full(nb, 0.3),
        pairs=np.vstack([pairs, np.stack([np.arange(nb), -np.ones(nb, int)], 1)]),
        points=np.vstack([pts, x + a]), forces=np.vstack([f, -F]), gravity=GRAV)


# ------------------------------------------------------------------ Moreau / Weber
def test_single_disk_hand_values():
    s = single_disk()
    V = 2.0
    expect = np.array([[0, 0], [0, -M * G * R / V]])
    np.testing.assert_allclose(moreau_stress(s, V), expect, atol=1e-14)
    np.testing.assert_allclose(moreau_stress(s, V, origin=[3.0, -7.0]), expect, atol=1e-13)
    np.testing.assert_allclose(weber_stress(s, V), 0.0)
    np.testing.assert_allclose(external_stress(s, V), expect, atol=1e-14)


def test_stacked_disks_hand_values():
    P = 3.0
    s = stacked(P)
    V = 4 * R * 2 * R
    np.testing.assert_allclose(moreau_stress(s, V), [[0, 0], [0, -4 * R * (P + M * G) / V]],
                               atol=1e-13)
    np.testing.assert_allclose(weber_stress(s, V), [[0, 0], [0, -2 * R * (P + M * G) / V]],
                               atol=1e-13)
    np.testing.assert_allclose(external_stress(s, V), [[0, 0], [0, -2 * R * (P + M * G) / V]],
                               atol=1e-13)
    # sub-sample {upper disk}: the lower disk's contact becomes an external action
    np.testing.assert_allclose(internal_moment(s, sample=[1]),
                               [[0, 0], [0, -(2 * R * P + R * M * G)]], atol=1e-13)
    np.testing.assert_allclose(internal_moment(s, sample=[1], origin=[1.0, 2.0]),
                               [[0, 0], [0, -(2 * R * P + R * M * G)]], atol=1e-13)


def test_square_hand_values_and_decomposition():
    F, Gf = 2.0, 5.0
    s = square(F, Gf)
    V = 16 * R**2
    sig = moreau_stress(s, V)
    np.testing.assert_allclose(sig, np.diag([-F / (2 * R), -Gf / (2 * R)]), atol=1e-14)
    np.testing.assert_allclose(weber_stress(s, V), np.diag([-4 * R * F, -4 * R * Gf]) / V,
                               atol=1e-14)
    rep = stress_report(s, V)
    assert rep.weber_difference == pytest.approx(0.5)      # half from walls, half internal
    assert rep.decomposition_residual < 1e-14
    assert rep.equilibrium_residual < 1e-14
    vals, vecs = principal(sig)
    np.testing.assert_allclose(vals, [-F / (2 * R), -Gf / (2 * R)])
    assert abs(vecs[0, 0]) == pytest.approx(1.0)


def test_random_equilibrium_symmetry_reference_and_gauss():
    s = random_equilibrium()
    V = 50.0
    assert np.abs(s.resultants()).max() < 1e-12
    sig = moreau_stress(s, V)
    assert asymmetry(sig) < 1e-13
    np.testing.assert_allclose(moreau_stress(s, V, origin=[100.0, -40.0]), sig, atol=1e-11)
    # Gauss–Ostrogradsky: only walls and gravity remain, summed by an explicit loop
    expect = np.zeros((2, 2))
    for (i, j), p, f in zip(s.pairs, s.points, s.forces):
        if j < 0:
            expect += np.outer(p, f)
    for x, m in zip(s.centers, s.masses):
        expect += np.outer(x, m * GRAV)
    np.testing.assert_allclose(sig * V, expect, atol=1e-11)
    np.testing.assert_allclose(external_stress(s, V) + weber_stress(s, V), sig, atol=1e-12)
    assert asymmetry(weber_stress(s, V)) > 1e-3                 # frictional: Weber skew
    # any sub-sample of balanced grains also has a symmetric, origin-free moment
    sub = np.arange(0, 12, 2)
    Msub = internal_moment(s, sample=sub)
    assert asymmetry(Msub) < 1e-12
    np.testing.assert_allclose(internal_moment(s, sample=sub, origin=[5, 5]), Msub, atol=1e-11)


def test_weber_depends_on_reference_points_decomposition_does_not():
    s = random_equilibrium()
    V = 50.0
    sig = moreau_stress(s, V)
    ref = s.centers + np.random.default_rng(3).uniform(-0.2, 0.2, s.centers.shape)
    w0, w1 = weber_stress(s, V), weber_stress(s, V, reference=ref)
    assert np.linalg.norm(w1 - w0) > 1e-3 * np.linalg.norm(sig)      # Weber moves
    # ... but σ̄ = σ_ext + σ_W holds for any reference points
    np.testing.assert_allclose(external_stress(s, V, reference=ref) + w1, sig, atol=1e-12)
    with pytest.raises(InvalidProblemError):
        weber_stress(s, V, reference=ref[:-1])


def test_boundary_traction_balances_body_forces():
    from socp_cd.granular import region_balance
    s = random_equilibrium()
    lo, hi = s.centers.min(0), s.centers.max(0)
    box = np.array([lo + 0.3 * (hi - lo), [hi[0], lo[1]] + 0.3 * (hi - lo) * [-1, 1],
                    hi - 0.3 * (hi - lo), [lo[0], hi[1]] + 0.3 * (hi - lo) * [1, -1]])
    boundary, load, inside = region_balance(s, box)
    assert 0 < inside.sum() < s.n_bodies
    np.testing.assert_allclose(boundary, -load, atol=1e-12 * np.abs(s.forces).max())
    # without the supports (wall contact points) inside, the balance would fail
    assert np.linalg.norm(boundary + s.body_forces()[inside].sum(0)) > 1e-3
    # the same region traversed clockwise gives the same balance
    b2, _, _ = region_balance(s, box[::-1])
    np.testing.assert_allclose(b2, boundary, atol=1e-12)
    with pytest.raises(InvalidProblemError):
        region_balance(s, box[:2])


def test_inertia_term_restores_reference_independence():
    n = np.array([0.6, 0.8])
    f = 4.0 * n
    x = np.array([1.0, 2.0])
    s = GranularState(centers=[x], masses=[M], volumes=[1.0], pairs=[[0, -1]],
                      points=[x - R * n], forces=[f], accelerations=[f / M])
    expect = -R * np.outer(n, f)
    np.testing.assert_allclose(moreau_stress(s, 1.0), expect, atol=1e-14)
    np.testing.assert_allclose(moreau_stress(s, 1.0, origin=[9, 9]), expect, atol=1e-13)
    static = GranularState(centers=[x], masses=[M], volumes=[1.0], pairs=[[0, -1]],
                           points=[x - R * n], forces=[f])
    assert not np.allclose(moreau_stress(static, 1.0), moreau_stress(static, 1.0, origin=[9, 9]))


# ------------------------------------------------------------------ cuts
def test_cut_traction_square():
    F, Gf = 2.0, 5.0
    s = square(F, Gf)
    np.testing.assert_allclose(cut_traction(s, [0, 0], [1, 0], 4 * R), [-F / (2 * R), 0])
    np.testing.assert_allclose(cut_traction(s, [0, 0], [-1, 0], 4 * R), [F / (2 * R), 0])
    np.testing.assert_allclose(cut_traction(s, [0, 0], [0, 1], 4 * R), [0, -Gf / (2 * R)])
    # short vertical cut through the upper row only: one contact over length 2R
    np.testing.assert_allclose(cut_traction(s, [0, R], [1, 0], 2 * R), [-F / (2 * R), 0])
    # cut near the left wall crosses the centre-to-wall-point segments
    np.testing.assert_allclose(cut_traction(s, [-1.5 * R, 0], [1, 0], 4 * R), [-F / (2 * R), 0])
    sw = cut_sweep(s, [0, 0], 4 * R, angles=[0.0, np.pi / 2])
    t, nn, sh = continuum_traction(moreau_stress(s, 16 * R**2), sw.angles)
    np.testing.assert_allclose(sw.tractions, t, atol=1e-12)
    np.testing.assert_allclose(sw.normal, [-F / (2 * R), -Gf / (2 * R)], atol=1e-12)
    np.testing.assert_allclose(sw.shear, 0, atol=1e-12)
    assert cauchy_deviation(sw, moreau_stress(s, 16 * R**2)) < 1e-12
    assert list(sw.n_crossing) == [2, 2]


def test_continuum_traction_mohr_formula():
    A, B, phi = -1.0, -3.0, 0.4
    Q = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    S = Q @ np.diag([A, B]) @ Q.T
    th = np.linspace(0, np.pi, 7)
    _, nn, sh = continuum_traction(S, th)
    np.testing.assert_allclose(nn, (A + B) / 2 + (A - B) / 2 * np.cos(2 * (th - phi)))
    np.testing.assert_allclose(sh, -(A - B) / 2 * np.sin(2 * (th - phi)))


def test_cut_traction_3d_two_spheres():
    f = 7.0
    s = GranularState(centers=[[0, 0, 1.0], [0, 0, 3.0]], masses=[1, 1], volumes=[1, 1],
                      pairs=[[1, 0], [0, -1], [1, -1]],
                      points=[[0, 0, 2.0], [0, 0, 0.0], [0, 0, 4.0]],
                      forces=[[0, 0, f], [0, 0, f], [0, 0, -f]])
    D = 1.5
    np.testing.assert_allclose(cut_traction(s, [0, 0, 2.2], [0, 0, 1], D),
                               [0, 0, -f / (np.pi * D**2 / 4)])
    np.testing.assert_allclose(cut_traction(s, [2.0, 0, 2.2], [0, 0, 1], D), 0.0)


# ------------------------------------------------------------------ statistics
def test_stats_square():
    s = square(1.0, 3.0, extra=True)
    assert coordination_number(s, sample=[0, 1, 2, 3]) == pytest.approx(2.0)
    assert coordination_number(s) == pytest.approx(8 / 5)
    assert coordination_number(s, exclude_rattlers=True) == pytest.approx(2.0)
    assert coordination_number(s, sample=[0, 1, 2, 3], walls=True) == pytest.approx(4.0)
    np.testing.assert_array_equal(rattlers(s), [False] * 4 + [True])
    fd = force_distribution(s)
    assert fd.mean == pytest.approx(2.0)
    assert fd.fraction_above_mean == pytest.approx(0.5)
    assert fd.share_of_strong == pytest.approx(6 / 8)
    assert np.sum(fd.density * np.diff(fd.edges)) == pytest.approx(1.0)
    np.testing.assert_allclose(fabric_tensor(s), np.diag([0.5, 0.5]))
    np.testing.assert_allclose(fabric_tensor(s, weighted=True), np.diag([0.25, 0.75]))


def test_rattler_removal_is_iterated():
    # chain wall - 0 - 1 - 2: grain 2 has one contact -> rattler, then 1, then 0
    s = GranularState(centers=[[0, 1.0], [0, 3.0], [0, 5.0]], masses=[1] * 3, volumes=[1] * 3,
                      pairs=[[0, -1], [1, 0], [2, 1]], points=[[0, 0], [0, 2.0], [0, 4.0]],
                      forces=[[0, 1.0], [0, 1.0], [0, 1.0]])
    np.testing.assert_array_equal(rattlers(s), [True, True, True])
    np.testing.assert_array_equal(rattlers(s, min_contacts=1), [False] * 3)


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize("change, field", [
    (dict(masses=[1.0, 2.0]), "masses"),
    (dict(pairs=[[0, 3]]), "pairs"),
    (dict(forces=[[np.nan, 0.0]]), "forces"),
    (dict(centers=[[0.0, 0, 0, 0]]), "centers"),
])
def test_invalid_state(change, field):
    base = dict(centers=[[0.0, R]], masses=[M], volumes=[1.0], pairs=[[0, -1]],
                points=[[0.0, 0.0]], forces=[[0.0, 1.0]])
    base.update(change)
    with pytest.raises(InvalidProblemError) as e:
        GranularState(**base)
    assert e.value.field.startswith(field)


def test_invalid_volume_and_cut():
    s = single_disk()
    with pytest.raises(InvalidProblemError):
        moreau_stress(s, 0.0)
    with pytest.raises(InvalidProblemError):
        cut_traction(s, [0, 0], [0, 0], 1.0)
    with pytest.raises(InvalidProblemError):
        cut_traction(s, [0, 0, 0], [0, 1], 1.0)


# ------------------------------------------------------------------ simulator-built packing
@pytest.fixture(scope="module")
def settled_packing():
    """24 polydisperse frictional disks settled under gravity in a box (Moreau–Jean, NSGS)."""
    from socp_cd.dynamics.bodies import Disk, Line
    from socp_cd.dynamics.scene import Scene
    from socp_cd.dynamics.stepper import Simulation
    from socp_cd.granular.samples import relax

    rng = np.random.default_rng(3)
    disks = [Disk(radius=rng.uniform(0.28, 0.36), mu=0.3,
                  position=((k % 4 + 0.5) * 0.75 + rng.uniform(-0.03, 0.03), 0.4 + (k // 4) * 0.75))
             for k in range(24)]
    W = 3.0
    scene = Scene(bodies=disks, obstacles=[Line((0, 0), (0, 1)), Line((0, 0), (1, 0)),
                                           Line((W, 0), (-1, 0))], mu=0.3)
    sim = Simulation(scene, h=5e-3, tol=1e-10, max_iter=2000)
    steps, prev, vmax = relax(sim, 600, 1e-3, min_steps=100)
    return sim, prev, vmax, W * 6 * 0.75


def test_simulated_packing_symmetric_and_reference_free(settled_packing):
    from socp_cd.granular import from_simulation
    sim, prev, vmax, V = settled_packing
    assert vmax < 1e-3                                   # the packing is at rest
    s = from_simulation(sim, prev_vel=prev)
    assert s.n_contacts >= 20
    sig = moreau_stress(s, V)
    scale = np.linalg.norm(sig)
    # Moreau–Jean impulse balance m(v+ - v-) = h m g + Σ r holds per step, so with the
    # inertia term every grain is balanced to round-off and the origin does not matter
    assert np.abs(s.resultants()).max() < 1e-9 * np.abs(s.forces).max()
    assert np.linalg.norm(moreau_stress(s, V, origin=[7.0, -3.0]) - sig) < 1e-10 * scale
    # symmetric to the solver tolerance (rotational inertia is not in the formula)
    assert asymmetry(sig) < 1e-7
    # compressive under gravity: both principal values negative, vertical dominates
    assert sig[1, 1] < sig[0, 0] < 0
    # Gauss–Ostrogradsky: walls ⊗ points + (gravity - inertia) ⊗ centres, explicit loop
    expect = np.zeros((2, 2))
    for (i, j), p, f in zip(s.pairs, s.points, s.forces):
        if j < 0:
            expect += np.outer(p, f)
    for x, m, a in zip(s.centers, s.masses, s.accelerations):
        expect += np.outer(x, m * (s.gravity - a))
    np.testing.assert_allclose(sig * V, expect, atol=1e-9 * scale * V)
    rep = stress_report(s, V)
    assert rep.decomposition_residual < 1e-10


def test_hdf5_frame_matches_live_state(settled_packing, tmp_path):
    from socp_cd.granular import from_hdf5, from_simulation
    sim, _, _, V = settled_packing
    v_before = sim.sys.vel.copy()
    sim.run(1, record_every=1, progress=False, path=tmp_path / "traj.h5")
    live = from_simulation(sim, prev_vel=v_before)
    disk = from_hdf5(tmp_path / "traj.h5", -1, gravity=sim.sys.gravity)
    np.testing.assert_allclose(disk.accelerations, live.accelerations, atol=1e-12)
    np.testing.assert_allclose(disk.volumes, np.pi * np.asarray(disk.radii) ** 2)
    np.testing.assert_allclose(moreau_stress(disk, V), moreau_stress(live, V), atol=1e-12)


def test_from_frame_mapping_with_impulses():
    from socp_cd.granular import from_frame
    h = 0.01
    frame = {"positions": [[0.0, R, 0.3]], "pairs": [[0, -1]], "points": [[0.0, 0.0]],
             "impulses": [[0.0, M * G * h]], "h": h}
    s = from_frame(frame, masses=[M], volumes=[1.0], gravity=GRAV)
    np.testing.assert_allclose(s.centers, [[0.0, R]])          # angle column dropped
    np.testing.assert_allclose(s.forces, [[0.0, M * G]])
    np.testing.assert_allclose(moreau_stress(s, 1.0), [[0, 0], [0, -M * G * R]], atol=1e-12)
    with pytest.raises(InvalidProblemError):
        from_frame({"positions": [[0.0, R]], "pairs": [[0, -1]], "points": [[0.0, 0.0]],
                    "impulses": [[0.0, 1.0]]}, masses=[M], volumes=[1.0])


def test_trajectory_gravity_is_read_from_its_metadata(tmp_path):
    """Regression (issue 11): gravity (0, -3.7) recorded in the file, not the default -9.81."""
    from socp_cd.dynamics import Disk, Line, Scene, Simulation
    from socp_cd.granular import from_hdf5, from_simulation
    g = np.array([0.0, -3.7])
    disks = [Disk(radius=0.3, position=(0.3 + 0.6 * k, 0.3), mu=0.3) for k in range(3)]
    scene = Scene(bodies=disks, obstacles=[Line((0, 0), (0, 1))], gravity=tuple(g), mu=0.3)
    sim = Simulation(scene, h=5e-3, tol=1e-10, max_iter=500)
    for _ in range(20):
        sim.step()
    v_before = sim.sys.vel.copy()
    sim.run(1, record_every=1, progress=False, path=tmp_path / "mars.h5")
    disk = from_hdf5(tmp_path / "mars.h5")
    live = from_simulation(sim, prev_vel=v_before)
    np.testing.assert_allclose(disk.gravity, g)
    np.testing.assert_allclose(disk.body_forces(), live.body_forces(), atol=1e-12)
    # the floor carries m g with g = 3.7: each grain balanced, stress = the live one
    assert np.abs(disk.resultants()).max() < 1e-9 * np.abs(disk.forces).max()
    np.testing.assert_allclose(disk.forces[:, 1].sum(), 3.7 * disk.masses.sum(), rtol=1e-6)
    np.testing.assert_allclose(moreau_stress(disk, 1.8 * 0.6), moreau_stress(live, 1.8 * 0.6),
                               atol=1e-12)
    with pytest.raises(InvalidProblemError):
        from_hdf5(tmp_path / "mars.h5", gravity=[0.0, -3.7, 0.0])
