"""Rigid bodies, fixed obstacles and loads of a contact-dynamics scene.

Every object is a plain dataclass; a :class:`~socp_cd.dynamics.scene.Scene`
is a list of them.  Units are SI-like but arbitrary (consistent).

Dynamic bodies
--------------
* :class:`Disk`     — 2D disk, dofs ``(x, y, angle)``, velocity ``(vx, vy, omega)``.
* :class:`Polygon`  — 2D convex polygon (vertices counter-clockwise, in the body
  frame, re-centred on the area centroid), same dofs as a disk.
* :class:`Sphere`   — 3D sphere, velocity ``(vx, vy, vz, wx, wy, wz)`` (world-frame
  angular velocity; its orientation is tracked for output only).
* :class:`ConvexPolyhedron`, :class:`Box` — 3D convex polyhedra, same velocity,
  orientation a unit quaternion ``(w, x, y, z)``, full inertia tensor.

Fixed obstacles (index ``-1`` in contact pairs)
-----------------------------------------------
* :class:`Line`  — 2D half-space ``{x : n·(x - p) >= 0}`` (``n`` points to the free side).
* :class:`Plane` — 3D half-space, same convention.
* :class:`FixedDisk`, :class:`FixedPolygon`, :class:`FixedSphere` — immobile grains
  (e.g. the rough bed of a talus); :class:`FixedPolyhedron`, :class:`FixedBox` in 3D.

Loads
-----
* :class:`Spring` — zero-rest-length linear spring between a body's centre and a
  driven point ``x_driver(t)``; treated implicitly by the θ-scheme.
* :class:`Force`  — user force ``func(t) -> (fx, fy[, torque])`` (2D) or
  ``(fx, fy, fz[, tx, ty, tz])`` (3D) applied at the centre, explicit.

Material parameters ``mu`` (Coulomb friction) and ``restitution`` (Newton's
``e``) may be set on any body or obstacle, and so may a ``material`` name.
A contact's values, by precedence: the scene's pair table
``Scene.materials[(name_a, name_b)]`` when both members name a material and
the (unordered) pair is listed; else the minimum of the values set on its two
members; else the scene default.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from ..errors import InvalidProblemError
from .geometry3d import Hull, box_vertices, convex_hull, hull_mass_properties, quat_normalize, quat_to_matrix


def _vec(x, d: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64).reshape(-1)
    if a.shape != (d,) or not np.all(np.isfinite(a)):
        raise InvalidProblemError(name, f"must be {d} finite numbers, got {x!r}")
    return a


def _positive(x, name: str) -> float:
    x = float(x)
    if not (np.isfinite(x) and x > 0):
        raise InvalidProblemError(name, f"must be a positive finite number, got {x!r}")
    return x


def _material(obj, name: str) -> None:
    if obj.mu is not None and not (np.isfinite(obj.mu) and obj.mu >= 0):
        raise InvalidProblemError(f"{name}.mu", f"must be >= 0, got {obj.mu!r}")
    if obj.restitution is not None and not (0 <= obj.restitution <= 1):
        raise InvalidProblemError(f"{name}.restitution", f"must lie in [0, 1], got {obj.restitution!r}")
    if obj.material is not None and not isinstance(obj.material, str):
        raise InvalidProblemError(f"{name}.material", f"must be a string or None, got {obj.material!r}")


def polygon_properties(vertices) -> tuple[float, np.ndarray, float]:
    """Area, centroid and polar second moment (about the centroid, unit density).

    Parameters
    ----------
    vertices : array_like, shape (n, 2)
        Counter-clockwise vertices.

    Returns
    -------
    area : float
    centroid : ndarray, shape (2,)
    J : float
        ``∫ |x - c|² dA``; the moment of inertia is ``density * J``.
    """
    V = np.asarray(vertices, dtype=np.float64)
    x, y = V[:, 0], V[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    area = 0.5 * cr.sum()
    cx = ((x + xn) * cr).sum() / (6 * area)
    cy = ((y + yn) * cr).sum() / (6 * area)
    Jo = ((x * x + x * xn + xn * xn + y * y + y * yn + yn * yn) * cr).sum() / 12.0
    J = Jo - area * (cx * cx + cy * cy)
    return float(area), np.array([cx, cy]), float(J)


def convex_ccw(vertices, name: str = "vertices") -> np.ndarray:
    """Validate a convex polygon and return its vertices counter-clockwise.

    Raises
    ------
    InvalidProblemError
        Fewer than 3 vertices, non-finite, zero area or not convex.
    """
    V = np.asarray(vertices, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != 2 or V.shape[0] < 3 or not np.all(np.isfinite(V)):
        raise InvalidProblemError(name, f"must be an (n >= 3, 2) finite array, got shape {V.shape}")
    area, _, _ = polygon_properties(V)
    if abs(area) < 1e-300:
        raise InvalidProblemError(name, "polygon has zero area")
    if area < 0:
        V = V[::-1].copy()
    E = np.roll(V, -1, axis=0) - V
    cr = E[:, 0] * np.roll(E, -1, axis=0)[:, 1] - E[:, 1] * np.roll(E, -1, axis=0)[:, 0]
    if np.any(cr < -1e-12 * np.max(np.abs(E)) ** 2):
        raise InvalidProblemError(name, "polygon is not convex")
    return V


# ----------------------------------------------------------------------------- bodies
@dataclass
class Disk:
    """A 2D rigid disk.

    Parameters
    ----------
    radius : float
    position, velocity : (2,) sequences
    angle, omega : float
        Orientation (rad) and angular velocity (rad/s).
    mass : float, optional
        Defaults to ``density * pi * radius**2``.
    density : float
    inertia : float, optional
        Defaults to ``mass * radius**2 / 2``.
    fixed_rotation : bool
        Lock the rotation (a "particle" that slides but never rolls).
    mu, restitution : float, optional
        Material values (see module docstring).
    """

    radius: float
    position: Sequence[float] = (0.0, 0.0)
    velocity: Sequence[float] = (0.0, 0.0)
    angle: float = 0.0
    omega: float = 0.0
    mass: Optional[float] = None
    density: float = 1.0
    inertia: Optional[float] = None
    fixed_rotation: bool = False
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 2
    kind = "disk"

    def __post_init__(self):
        self.radius = _positive(self.radius, "Disk.radius")
        self.position = _vec(self.position, 2, "Disk.position")
        self.velocity = _vec(self.velocity, 2, "Disk.velocity")
        if self.mass is None:
            self.mass = _positive(self.density, "Disk.density") * np.pi * self.radius ** 2
        self.mass = _positive(self.mass, "Disk.mass")
        if self.inertia is None:
            self.inertia = 0.5 * self.mass * self.radius ** 2
        self.inertia = _positive(self.inertia, "Disk.inertia")
        _material(self, "Disk")

    @property
    def bounding_radius(self) -> float:
        return self.radius


@dataclass
class Polygon:
    """A 2D convex rigid polygon.

    Parameters
    ----------
    vertices : array_like, shape (n, 2)
        Vertices in the body frame, relative to ``position``; they are reordered
        counter-clockwise and re-centred on the centroid (``position`` is moved
        to the world centroid accordingly).
    position, velocity, angle, omega, mass, density, inertia, fixed_rotation, mu, restitution
        As for :class:`Disk` (``mass`` defaults to density × area, ``inertia``
        to the polygon's exact polar moment).
    """

    vertices: np.ndarray
    position: Sequence[float] = (0.0, 0.0)
    velocity: Sequence[float] = (0.0, 0.0)
    angle: float = 0.0
    omega: float = 0.0
    mass: Optional[float] = None
    density: float = 1.0
    inertia: Optional[float] = None
    fixed_rotation: bool = False
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 2
    kind = "polygon"

    def __post_init__(self):
        V = convex_ccw(self.vertices, "Polygon.vertices")
        area, c, J = polygon_properties(V)
        self.vertices = V - c
        pos = _vec(self.position, 2, "Polygon.position")
        ca, sa = np.cos(self.angle), np.sin(self.angle)
        self.position = pos + np.array([ca * c[0] - sa * c[1], sa * c[0] + ca * c[1]])
        self.velocity = _vec(self.velocity, 2, "Polygon.velocity")
        if self.mass is None:
            self.mass = _positive(self.density, "Polygon.density") * area
        self.mass = _positive(self.mass, "Polygon.mass")
        if self.inertia is None:
            self.inertia = self.mass * J / area
        self.inertia = _positive(self.inertia, "Polygon.inertia")
        _material(self, "Polygon")

    @property
    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices, axis=1)))

    @classmethod
    def box(cls, width: float, height: float, position=(0.0, 0.0), **kw) -> "Polygon":
        """An axis-aligned (before ``angle``) ``width × height`` rectangle centred at ``position``."""
        w, h = _positive(width, "width") / 2, _positive(height, "height") / 2
        return cls(np.array([[-w, -h], [w, -h], [w, h], [-w, h]]), position=position, **kw)

    @classmethod
    def regular(cls, n: int, radius: float, position=(0.0, 0.0), **kw) -> "Polygon":
        """A regular ``n``-gon of circumradius ``radius`` centred at ``position``."""
        a = 2 * np.pi * np.arange(int(n)) / int(n)
        return cls(radius * np.c_[np.cos(a), np.sin(a)], position=position, **kw)


@dataclass
class Sphere:
    """A 3D rigid sphere (velocity ``(vx, vy, vz)``, world angular velocity ``omega`` (3,)).

    ``orientation`` (unit quaternion ``(w, x, y, z)``) is tracked for output
    only: it never affects a sphere's contacts.
    """

    radius: float
    position: Sequence[float] = (0.0, 0.0, 0.0)
    velocity: Sequence[float] = (0.0, 0.0, 0.0)
    omega: Sequence[float] = (0.0, 0.0, 0.0)
    mass: Optional[float] = None
    density: float = 1.0
    inertia: Optional[float] = None
    fixed_rotation: bool = False
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None
    orientation: Sequence[float] = (1.0, 0.0, 0.0, 0.0)

    dim = 3
    kind = "disk"   # round body: same narrow phase as a disk, in 3D
    angle = 0.0

    def __post_init__(self):
        self.orientation = quat_normalize(_vec(self.orientation, 4, "Sphere.orientation"), "Sphere.orientation")
        self.radius = _positive(self.radius, "Sphere.radius")
        self.position = _vec(self.position, 3, "Sphere.position")
        self.velocity = _vec(self.velocity, 3, "Sphere.velocity")
        self.omega = _vec(self.omega, 3, "Sphere.omega")
        if self.mass is None:
            self.mass = _positive(self.density, "Sphere.density") * 4 / 3 * np.pi * self.radius ** 3
        self.mass = _positive(self.mass, "Sphere.mass")
        if self.inertia is None:
            self.inertia = 0.4 * self.mass * self.radius ** 2
        self.inertia = _positive(self.inertia, "Sphere.inertia")
        _material(self, "Sphere")

    @property
    def bounding_radius(self) -> float:
        return self.radius


def _inertia_tensor(val, name: str) -> np.ndarray:
    """A symmetric positive definite 3×3 tensor from (3,) principal values or a (3, 3) array."""
    a = np.asarray(val, dtype=np.float64)
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)) or not np.allclose(a, a.T, rtol=1e-10, atol=0):
        raise InvalidProblemError(name, f"must be (3,) principal moments or a symmetric (3, 3) tensor, got {val!r}")
    if np.linalg.eigvalsh(a).min() <= 0:
        raise InvalidProblemError(name, "inertia tensor must be positive definite")
    return a


@dataclass
class ConvexPolyhedron:
    """A 3D convex rigid polyhedron.

    Parameters
    ----------
    vertices : array_like, shape (k, 3)
        Points in the body frame, relative to ``position``; their convex hull
        is taken and re-centred on the solid's centroid (``position`` moves to
        the world centroid accordingly).
    position, velocity : (3,) sequences
    orientation : (4,) sequence
        Unit quaternion ``(w, x, y, z)`` (normalized on input), body → world.
    omega : (3,) sequence
        World-frame angular velocity.
    mass : float, optional
        Defaults to ``density × volume``.
    density : float
    inertia : (3,) or (3, 3), optional
        Body-frame inertia tensor about the centroid (principal values or full
        tensor); defaults to the exact tensor of the solid with this mass.
    fixed_rotation : bool
    mu, restitution, material
        Material values (see module docstring).
    """

    vertices: np.ndarray
    position: Sequence[float] = (0.0, 0.0, 0.0)
    orientation: Sequence[float] = (1.0, 0.0, 0.0, 0.0)
    velocity: Sequence[float] = (0.0, 0.0, 0.0)
    omega: Sequence[float] = (0.0, 0.0, 0.0)
    mass: Optional[float] = None
    density: float = 1.0
    inertia: Optional[np.ndarray] = None
    fixed_rotation: bool = False
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 3
    kind = "hull"
    angle = 0.0

    def __post_init__(self):
        name = type(self).__name__
        hull = convex_hull(self.vertices, f"{name}.vertices")
        vol, c, J = hull_mass_properties(hull)
        self.hull = Hull(hull.vertices - c, hull.faces, hull.normals, hull.edges, hull.edge_dir, hull.directions)
        self.vertices = self.hull.vertices
        self.volume = vol
        self.orientation = quat_normalize(_vec(self.orientation, 4, f"{name}.orientation"), f"{name}.orientation")
        self.position = _vec(self.position, 3, f"{name}.position") + quat_to_matrix(self.orientation) @ c
        self.velocity = _vec(self.velocity, 3, f"{name}.velocity")
        self.omega = _vec(self.omega, 3, f"{name}.omega")
        if self.mass is None:
            self.mass = _positive(self.density, f"{name}.density") * vol
        self.mass = _positive(self.mass, f"{name}.mass")
        if self.inertia is None:
            self.inertia = self.mass * J / vol
        self.inertia = _inertia_tensor(self.inertia, f"{name}.inertia")
        _material(self, name)

    @property
    def bounding_radius(self) -> float:
        return self.hull.bounding_radius

    @classmethod
    def box(cls, size, position=(0.0, 0.0, 0.0), **kw) -> "ConvexPolyhedron":
        """A box of edge lengths ``size = (lx, ly, lz)`` (body axes) centred at ``position``."""
        return cls(box_vertices(_vec(size, 3, "size")), position=position, **kw)

    @classmethod
    def prism(cls, n: int, radius: float, height: float, position=(0.0, 0.0, 0.0), **kw) -> "ConvexPolyhedron":
        """A right prism on a regular ``n``-gon of circumradius ``radius``, axis along body z."""
        a = 2 * np.pi * np.arange(int(n)) / int(n)
        ring = np.c_[radius * np.cos(a), radius * np.sin(a)]
        V = np.vstack([np.c_[ring, np.full(int(n), -height / 2)], np.c_[ring, np.full(int(n), height / 2)]])
        return cls(V, position=position, **kw)


class Box(ConvexPolyhedron):
    """A 3D rigid box: ``Box(size=(lx, ly, lz), position, orientation, velocity, omega, ...)``.

    A :class:`ConvexPolyhedron` with the 8 corners of ``size``; other
    parameters as for :class:`ConvexPolyhedron` (exact inertia
    ``m/12 (ly² + lz², lx² + lz², lx² + ly²)`` by default).
    """

    def __init__(self, size=(1.0, 1.0, 1.0), position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0),
                 velocity=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0), mass=None, density=1.0, inertia=None,
                 fixed_rotation=False, mu=None, restitution=None, material=None):
        self.size = _vec(size, 3, "Box.size")
        for k in range(3):
            _positive(self.size[k], f"Box.size[{k}]")
        super().__init__(box_vertices(self.size), position, orientation, velocity, omega, mass, density,
                         inertia, fixed_rotation, mu, restitution, material)


# ----------------------------------------------------------------------------- obstacles
@dataclass
class Line:
    """Fixed 2D half-space ``{x : normal·(x - point) >= 0}`` (a wall or floor line)."""

    point: Sequence[float] = (0.0, 0.0)
    normal: Sequence[float] = (0.0, 1.0)
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 2
    kind = "halfspace"

    def __post_init__(self):
        self.point = _vec(self.point, self.dim, f"{type(self).__name__}.point")
        n = _vec(self.normal, self.dim, f"{type(self).__name__}.normal")
        nn = np.linalg.norm(n)
        if nn == 0:
            raise InvalidProblemError(f"{type(self).__name__}.normal", "must be nonzero")
        self.normal = n / nn
        _material(self, type(self).__name__)

    @classmethod
    def inclined(cls, angle: float, point=(0.0, 0.0), **kw) -> "Line":
        """The line through ``point`` making ``angle`` (rad) with the x-axis (rising to the right)."""
        return cls(point, (-np.sin(angle), np.cos(angle)), **kw)


@dataclass
class Plane(Line):
    """Fixed 3D half-space ``{x : normal·(x - point) >= 0}``."""

    point: Sequence[float] = (0.0, 0.0, 0.0)
    normal: Sequence[float] = (0.0, 0.0, 1.0)

    dim = 3


@dataclass
class FixedDisk:
    """An immobile disk (2D)."""

    radius: float
    position: Sequence[float] = (0.0, 0.0)
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 2
    kind = "disk"

    def __post_init__(self):
        self.radius = _positive(self.radius, f"{type(self).__name__}.radius")
        self.position = _vec(self.position, self.dim, f"{type(self).__name__}.position")
        _material(self, type(self).__name__)

    @property
    def bounding_radius(self) -> float:
        return self.radius


@dataclass
class FixedSphere(FixedDisk):
    """An immobile sphere (3D)."""

    position: Sequence[float] = (0.0, 0.0, 0.0)
    dim = 3


@dataclass
class FixedPolygon:
    """An immobile convex polygon given by its world vertices (2D)."""

    vertices: np.ndarray
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 2
    kind = "polygon"

    def __post_init__(self):
        self.vertices = convex_ccw(self.vertices, "FixedPolygon.vertices")
        _, self.position, _ = polygon_properties(self.vertices)
        _material(self, "FixedPolygon")

    @property
    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices - self.position, axis=1)))


@dataclass
class FixedPolyhedron:
    """An immobile convex polyhedron: hull of ``vertices`` (body frame) placed at ``position``/``orientation``."""

    vertices: np.ndarray
    position: Sequence[float] = (0.0, 0.0, 0.0)
    orientation: Sequence[float] = (1.0, 0.0, 0.0, 0.0)
    mu: Optional[float] = None
    restitution: Optional[float] = None
    material: Optional[str] = None

    dim = 3
    kind = "hull"

    def __post_init__(self):
        name = type(self).__name__
        hull = convex_hull(self.vertices, f"{name}.vertices")
        _, c, _ = hull_mass_properties(hull)
        self.hull = Hull(hull.vertices - c, hull.faces, hull.normals, hull.edges, hull.edge_dir, hull.directions)
        self.vertices = self.hull.vertices
        self.orientation = quat_normalize(_vec(self.orientation, 4, f"{name}.orientation"), f"{name}.orientation")
        self.position = _vec(self.position, 3, f"{name}.position") + quat_to_matrix(self.orientation) @ c
        _material(self, name)

    @property
    def bounding_radius(self) -> float:
        return self.hull.bounding_radius


class FixedBox(FixedPolyhedron):
    """An immobile box ``FixedBox(size, position, orientation, mu, restitution, material)``."""

    def __init__(self, size=(1.0, 1.0, 1.0), position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0),
                 mu=None, restitution=None, material=None):
        self.size = _vec(size, 3, "FixedBox.size")
        for k in range(3):
            _positive(self.size[k], f"FixedBox.size[{k}]")
        super().__init__(box_vertices(self.size), position, orientation, mu, restitution, material)


# ----------------------------------------------------------------------------- loads
@dataclass
class Spring:
    """Zero-rest-length spring pulling body ``body``'s centre towards ``driver(t)``.

    The force is ``stiffness * (driver(t) - x_body)``; it is linear in the
    position and is integrated implicitly (``M + h²θ² K`` iteration matrix).
    """

    body: int
    driver: Callable[[float], Sequence[float]]
    stiffness: float

    def __post_init__(self):
        self.stiffness = _positive(self.stiffness, "Spring.stiffness")
        if not callable(self.driver):
            raise InvalidProblemError("Spring.driver", "must be a callable t -> point")


@dataclass
class Force:
    """External force (and torque) on body ``body``: ``func(t)`` evaluated at ``t + θh``."""

    body: int
    func: Callable[[float], Sequence[float]]

    def __post_init__(self):
        if not callable(self.func):
            raise InvalidProblemError("Force.func", "must be a callable t -> force")


BODY_TYPES = (Disk, Polygon, Sphere, ConvexPolyhedron)
OBSTACLE_TYPES = (Line, Plane, FixedDisk, FixedSphere, FixedPolygon, FixedPolyhedron)

__all__ = ["Disk", "Polygon", "Sphere", "ConvexPolyhedron", "Box", "Line", "Plane", "FixedDisk", "FixedSphere",
           "FixedPolygon", "FixedPolyhedron", "FixedBox", "Spring", "Force", "polygon_properties", "convex_ccw",
           "BODY_TYPES", "OBSTACLE_TYPES"]
