"""Generators of common setups in scene files (``[[generate]]`` tables).

Each generator copies a *template* body (``body = {shape = ..., ...}``, a body
table without ``position``) to many positions:

* ``random_packing`` — ``count`` non-overlapping bodies at uniform random
  positions in the box ``lo``–``hi`` (``seed``; ``radius_range = [rmin, rmax]``
  draws a radius per body for disks/spheres/regular polygons; ``random_orientation =
  true`` turns each body by a uniformly random rotation after its template's own, drawn
  after the positions; the packing then uses disks/spheres that hold a body under any
  rotation about its position, so the positions are those of the same seed without it
  unless the template's vertices are off-centre);
* ``hopper`` — a pile to be deposited: ``count`` bodies on a lattice inside a
  funnel above the outlet ``outlet`` of width ``opening``, whose walls make
  ``wall_angle`` degrees with the vertical (2D: two thin fixed boxes; 3D: four,
  which need fixed 3D boxes); ``jitter`` randomises the lattice (``seed``);
* ``stack`` — ``count`` bodies in a vertical column resting on ``base`` (the
  bottom point of the lowest body), ``gap`` between neighbours; ``tilt`` (degrees)
  rotates the whole column about ``base`` (2D: counter-clockwise; 3D: about the
  y axis, so ``tilt = a`` stands it on a plane of normal ``(sin a, 0, cos a)``);
* ``wall`` — ``rows × columns`` blocks in running bond (every other row shifted
  by half a block) from ``origin`` (bottom-left corner; 3D: the wall runs along x);
* ``kapla_tower`` — ``levels`` of ``per_level`` planks (3D boxes ``size = [L, W, H]``)
  centred on ``center``, alternately along x and y;
* ``row`` — ``count`` bodies equally spaced from centre ``start`` to centre ``end``
  (e.g. with ``fixed = true``, the rough bed of a talus).

All positions are body centres; generated entries keep the template's other
keys (velocity, density, material, ...).  ``fixed = true`` (any kind) makes
the generated bodies fixed obstacles instead (disks, spheres, polygons, boxes,
polyhedra; velocities and densities are then ignored).
"""
from __future__ import annotations

import math

import numpy as np

from .rotations import quat_from_axis_angle, quat_mul, random_quaternion

_KINDS = {
    "random_packing": {"lo", "hi", "count", "seed", "radius_range", "random_orientation"},
    "hopper": {"outlet", "opening", "wall_angle", "count", "seed", "jitter", "walls", "wall_thickness",
               "wall_height"},
    "stack": {"base", "count", "gap", "tilt"},
    "wall": {"origin", "rows", "columns", "gap"},
    "kapla_tower": {"center", "levels", "per_level", "gap"},
    "row": {"start", "end", "count"},
}


def expand_generator(ck, t, path: str, dim: int, body_entry) -> tuple[list, list]:
    """Validate a ``[[generate]]`` table and return ``(bodies, obstacles)`` entries.

    Parameters
    ----------
    ck : socp_cd.scenes.schema.Checker
    t : dict
        The parsed table.
    path : str
        Its key path (``generate[k]``), used in error messages and as the
        generated entries' ``path``.
    dim : int
    body_entry : callable
        The schema's body-table validator
        (:func:`socp_cd.scenes.schema.body_entry`), applied to the template;
        passed in so that this module does not import the schema that
        imports it.
    """
    if not isinstance(t, dict) or "kind" not in t:
        ck.table(t, path, {"kind", "body"}, required=("kind",))
    kind = ck.string(t["kind"], f"{path}.kind", tuple(_KINDS))
    ck.table(t, path, {"kind", "body", "fixed"} | _KINDS[kind], required=("body",))
    fixed = ck.boolean(t.get("fixed", False), f"{path}.fixed")
    tmpl = body_entry(ck, t["body"], f"{path}.body", dim, require_position=False)
    if "position" in t["body"]:
        ck.fail(f"{path}.body.position", "a generator's template has no position")
    fn = {"random_packing": _random_packing, "hopper": _hopper, "stack": _stack, "wall": _wall,
          "kapla_tower": _kapla, "row": _row}[kind]
    bodies, obstacles = fn(ck, t, path, dim, tmpl)
    for k, b in enumerate(bodies):
        b["path"] = f"{path}#{k}"
    if fixed:
        if tmpl["fixed_rotation"]:
            ck.fail(f"{path}.body.fixed_rotation", "fixed obstacles do not move at all")
        return [], obstacles + bodies
    return bodies, obstacles


def _count(ck, t, path, key="count", lo=1):
    if key not in t:
        ck.fail(f"{path}.{key}", "missing required key")
    n = ck.number(t[key], f"{path}.{key}", integer=True, lo=lo)
    if n > 1_000_000:
        ck.fail(f"{path}.{key}", f"at most 1000000 bodies per generator, got {n}")
    return n


def _need(ck, t, path, key):
    if key not in t:
        ck.fail(f"{path}.{key}", "missing required key")
    return t[key]


def half_extent(b: dict, dim: int) -> np.ndarray:
    """Half extent of a (non-rotated) template along each axis."""
    if "size" in b:
        return 0.5 * np.asarray(b["size"], dtype=np.float64)
    if "vertices" in b:
        V = np.asarray(b["vertices"], dtype=np.float64)
        return 0.5 * (V.max(0) - V.min(0))
    return np.full(dim, b["radius"])


def bounding_radius(b: dict, dim: int) -> float:
    if "radius" in b:
        return float(b["radius"])
    if "size" in b:
        return float(0.5 * np.linalg.norm(b["size"]))
    V = np.asarray(b["vertices"], dtype=np.float64)
    return float(np.max(np.linalg.norm(V - V.mean(0), axis=1)))


def _place(tmpl: dict, position, **over) -> dict:
    b = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in tmpl.items()}
    b["position"] = np.asarray(position, dtype=np.float64)
    b.update(over)
    return b


def _scaled(tmpl: dict, r: float) -> dict:
    """Template rescaled to bounding radius ``r`` (disk/sphere radius, polygon vertices)."""
    if "radius" in tmpl:
        return {**tmpl, "radius": r}
    s = r / bounding_radius(tmpl, 0)
    out = dict(tmpl)
    for k in ("vertices", "size"):
        if k in tmpl:
            out[k] = np.asarray(tmpl[k]) * s
    return out


def _random_packing(ck, t, path, dim, tmpl):
    lo = ck.vector(_need(ck, t, path, "lo"), f"{path}.lo", dim)
    hi = ck.vector(_need(ck, t, path, "hi"), f"{path}.hi", dim)
    if np.any(hi <= lo):
        ck.fail(f"{path}.hi", "must exceed lo in every coordinate")
    n = _count(ck, t, path)
    rng = np.random.default_rng(ck.number(t.get("seed", 0), f"{path}.seed", integer=True, nonneg=True))
    radii = None
    if "radius_range" in t:
        rr = ck.vector(t["radius_range"], f"{path}.radius_range", 2, positive=True)
        if rr[1] < rr[0]:
            ck.fail(f"{path}.radius_range", "must be [rmin, rmax] with rmin <= rmax")
        if tmpl["shape"] in ("box", "polyhedron"):
            ck.fail(f"{path}.radius_range", "applies to disks, spheres and polygons only")
        radii = rng.uniform(rr[0], rr[1], n)
    R = radii if radii is not None else np.full(n, bounding_radius(tmpl, dim))
    turned = ck.boolean(t.get("random_orientation", False), f"{path}.random_orientation")
    if turned:
        # each body then turns about its position: placed by the disk or sphere there that holds
        # it under any rotation (the bounding one unless the template's vertices are off-centre)
        R = R * _turning_reach(tmpl, dim)
    if np.any(2 * R[:, None] > (hi - lo)[None]):
        ck.fail(f"{path}.hi", "the region is smaller than a body")
    # random sequential placement jams near these fractions of bounding disks/spheres
    region = np.prod(hi - lo - 2 * R.min())
    unit = math.pi if dim == 2 else 4 * math.pi / 3
    fraction = unit * float(np.sum(R ** dim)) / region
    if fraction > (0.54 if dim == 2 else 0.38):
        ck.fail(f"{path}.count", f"{n} bodies would fill {fraction:.0%} of the region; random sequential "
                f"placement jams near {'54' if dim == 2 else '38'}% (enlarge lo–hi or lower count)")
    # rejection sampling on a uniform grid of cells of size 2 r_max (neighbour search)
    cell = 2 * float(R.max())
    grid: dict = {}
    pos = np.zeros((n, dim))
    attempts = 0
    for k in range(n):
        while True:
            attempts += 1
            if attempts > 50 * n + 1000:
                ck.fail(f"{path}.count", f"could place only {k} of {n} bodies in the region "
                        "(too dense for random sequential placement; enlarge lo–hi)")
            p = rng.uniform(lo + R[k], hi - R[k])
            c = tuple(np.floor(p / cell).astype(int))
            ok = True
            for off in np.ndindex(*(3,) * dim):
                for j in grid.get(tuple(ci + oi - 1 for ci, oi in zip(c, off)), ()):
                    if np.linalg.norm(pos[j] - p) < R[j] + R[k]:
                        ok = False
                        break
                if not ok:
                    break
            if ok:
                pos[k] = p
                grid.setdefault(c, []).append(k)
                break
    bodies = ([_place(tmpl, p) for p in pos] if radii is None
              else [_place(_scaled(tmpl, r), p) for p, r in zip(pos, radii)])
    if turned:
        for b in bodies:
            if dim == 2:
                b["angle"] = float(b.get("angle", 0.0) + rng.uniform(0.0, 2.0 * math.pi))
            else:
                b["orientation"] = quat_mul(random_quaternion(rng), b["orientation"])
    return bodies, []


def _turning_reach(tmpl: dict, dim: int) -> float:
    """How far a body of template ``tmpl`` reaches from its position under any rotation, over
    its bounding radius (:func:`bounding_radius`, measured from the mean of its vertices): at
    least 1.  A body turns about its position, its vertices' origin, so a template whose
    vertices are not centred there reaches ``max |V|`` past it, more than the bounding
    radius when the centring is off."""
    if "vertices" not in tmpl:
        return 1.0
    far = float(np.max(np.linalg.norm(np.asarray(tmpl["vertices"], dtype=np.float64), axis=1)))
    return max(1.0, far / bounding_radius(tmpl, dim))


def _hopper(ck, t, path, dim, tmpl):
    outlet = ck.vector(_need(ck, t, path, "outlet"), f"{path}.outlet", dim)
    opening = ck.number(_need(ck, t, path, "opening"), f"{path}.opening", positive=True)
    ang = math.radians(ck.number(t.get("wall_angle", 30.0), f"{path}.wall_angle", lo=0.0, hi=80.0))
    n = _count(ck, t, path)
    rng = np.random.default_rng(ck.number(t.get("seed", 0), f"{path}.seed", integer=True, nonneg=True))
    rb = bounding_radius(tmpl, dim)
    jitter = ck.number(t.get("jitter", 0.05), f"{path}.jitter", lo=0.0, hi=0.5)
    walls = ck.boolean(t.get("walls", True), f"{path}.walls")
    thick = ck.number(t.get("wall_thickness", rb), f"{path}.wall_thickness", positive=True)
    sp = 2.2 * rb
    pos = []
    z = 2 * rb
    while len(pos) < n:
        half = opening / 2 + z * math.tan(ang) - 1.1 * rb
        m = max(1, int(2 * half // sp) + 1)
        xs = (np.arange(m) - (m - 1) / 2) * sp
        for x in xs:
            for y in (xs if dim == 3 else [None]):
                if len(pos) == n:
                    break
                p = outlet.copy()
                p[0] += x
                if dim == 3:
                    p[1] += y
                p[-1] += z
                p += jitter * rb * rng.uniform(-1, 1, dim)
                pos.append(p)
        z += sp
    bodies = [_place(tmpl, p) for p in pos]
    obstacles = []
    if walls:
        height = ck.number(t.get("wall_height", z + rb), f"{path}.wall_height", positive=True)
        L = height / math.cos(ang)
        for side in (-1.0, 1.0):
            for ax in ((0,) if dim == 2 else (0, 1)):
                # slab centre: from the outlet edge, up and outwards along the wall
                c = outlet.copy()
                c[ax] += side * (opening / 2 + 0.5 * height * math.tan(ang) + 0.5 * thick / math.cos(ang))
                c[-1] += 0.5 * height
                if dim == 2:
                    size = np.array([thick, L])
                    obstacles.append({"shape": "box", "size": size, "position": c, "angle": -side * ang,
                                      "path": f"{path}.walls", "material": tmpl["material"], "mu": None,
                                      "restitution": None})
                else:
                    size = np.array([thick, opening + 2 * height * math.tan(ang) + 2 * thick, L])
                    axis = np.array([0.0, 1.0, 0.0]) if ax == 0 else np.array([-1.0, 0.0, 0.0])
                    if ax == 1:
                        size = size[[1, 0, 2]]
                    obstacles.append({"shape": "box", "size": size, "position": c,
                                      "orientation": quat_from_axis_angle(axis, side * ang),
                                      "path": f"{path}.walls", "material": tmpl["material"], "mu": None,
                                      "restitution": None})
    return bodies, obstacles


def _stack(ck, t, path, dim, tmpl):
    base = ck.vector(_need(ck, t, path, "base"), f"{path}.base", dim)
    n = _count(ck, t, path)
    gap = ck.number(t.get("gap", 0.0), f"{path}.gap", nonneg=True)
    tilt = math.radians(ck.number(t.get("tilt", 0.0), f"{path}.tilt", lo=-90.0, hi=90.0))
    hz = half_extent(tmpl, dim)[-1]
    c, s = math.cos(tilt), math.sin(tilt)
    up = np.array([-s, c]) if dim == 2 else np.array([s, 0.0, c])
    out = []
    for k in range(n):
        p = base + (hz + k * (2 * hz + gap)) * up
        if dim == 2:
            out.append(_place(tmpl, p, angle=tmpl["angle"] + tilt))
        else:
            out.append(_place(tmpl, p, orientation=quat_mul(quat_from_axis_angle([0.0, 1.0, 0.0], tilt),
                                                           tmpl["orientation"])))
    return out, []


def _wall(ck, t, path, dim, tmpl):
    if tmpl["shape"] != "box":
        ck.fail(f"{path}.body.shape", "a wall is made of boxes")
    origin = ck.vector(_need(ck, t, path, "origin"), f"{path}.origin", dim)
    rows = _count(ck, t, path, "rows")
    cols = _count(ck, t, path, "columns")
    if rows * cols > 1_000_000:
        ck.fail(f"{path}.rows", f"at most 1000000 bodies per generator, got {rows} x {cols}")
    gap = ck.number(t.get("gap", 0.0), f"{path}.gap", nonneg=True)
    size = np.asarray(tmpl["size"])
    out = []
    for i in range(rows):
        shift = 0.5 * size[0] if i % 2 else 0.0
        for j in range(cols - (1 if i % 2 else 0)):
            p = origin.copy()
            p[0] += shift + (j + 0.5) * size[0] + j * gap
            p[-1] += (i + 0.5) * size[-1] + i * gap
            if dim == 3:
                p[1] += 0.5 * size[1]
            out.append(_place(tmpl, p))
    return out, []


def _kapla(ck, t, path, dim, tmpl):

    if dim != 3 or tmpl["shape"] != "box":
        ck.fail(f"{path}.body.shape", "a Kapla tower is made of 3D boxes (size = [L, W, H])")
    center = ck.vector(_need(ck, t, path, "center"), f"{path}.center", 3)
    levels = _count(ck, t, path, "levels")
    per = ck.number(t.get("per_level", 2), f"{path}.per_level", integer=True, lo=1, hi=1000)
    if levels * per > 1_000_000:
        ck.fail(f"{path}.levels", f"at most 1000000 bodies per generator, got {levels} x {per}")
    gap = ck.number(t.get("gap", 0.0), f"{path}.gap", nonneg=True)
    L, W, H = np.asarray(tmpl["size"])
    if per * W > L:
        ck.fail(f"{path}.per_level", f"{per} planks of width {W} do not fit under a plank of length {L}")
    offsets = (np.arange(per) - (per - 1) / 2) * ((L - W) / max(per - 1, 1)) if per > 1 else np.zeros(1)
    rot = quat_from_axis_angle([0.0, 0.0, 1.0], math.pi / 2)
    out = []
    for lev in range(levels):
        along_x = lev % 2 == 0
        for o in offsets:
            p = center.copy()
            p[2] += (lev + 0.5) * H + lev * gap
            p[1 if along_x else 0] += o
            out.append(_place(tmpl, p, orientation=(tmpl["orientation"] if along_x else
                                                    quat_mul(rot, tmpl["orientation"]))))
    return out, []


def _row(ck, t, path, dim, tmpl):
    a = ck.vector(_need(ck, t, path, "start"), f"{path}.start", dim)
    b = ck.vector(_need(ck, t, path, "end"), f"{path}.end", dim)
    n = _count(ck, t, path)
    return [_place(tmpl, a + (b - a) * (k / max(n - 1, 1))) for k in range(n)], []


__all__ = ["expand_generator", "half_extent", "bounding_radius"]
