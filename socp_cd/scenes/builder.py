"""From a validated :class:`~socp_cd.scenes.schema.SceneSpec` to ``socp_cd.dynamics`` objects.

3D boxes and polyhedra, per-body ``material`` names and the per-pair material
table use the parts of :mod:`socp_cd.dynamics` that provide them
(``Box``, ``ConvexPolyhedron``, ``FixedBox``, ``FixedPolyhedron``,
``Scene(materials=...)``); when the installed version lacks one, the scene
entry that needs it gets a :class:`~socp_cd.scenes.schema.SceneFileError`.
"""
from __future__ import annotations

import dataclasses
import inspect

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from .schema import SceneFileError, SceneSpec, load_scene_file


def _dyn():
    from .. import dynamics
    return dynamics


def has_boxes() -> bool:
    """Whether :mod:`socp_cd.dynamics` provides 3D boxes (``Box``)."""
    return hasattr(_dyn(), "Box")


def _accepts(cls, name: str) -> bool:
    if dataclasses.is_dataclass(cls):
        return name in {f.name for f in dataclasses.fields(cls)}
    return name in inspect.signature(cls).parameters


def _class(spec: SceneSpec, entry: dict, name: str):
    cls = getattr(_dyn(), name, None)
    if cls is None:
        raise SceneFileError(spec.source, f"{entry['path']}.shape",
                             f"shape {entry['shape']!r} in {spec.dim}D needs socp_cd.dynamics.{name}, "
                             "which this version of socp_cd does not have")
    return cls


def _material_kw(spec: SceneSpec, cls, entry: dict) -> dict:
    kw = {"mu": entry["mu"], "restitution": entry["restitution"]}
    if entry.get("material") is not None:
        if _accepts(cls, "material"):
            kw["material"] = entry["material"]
        elif spec.materials:
            raise SceneFileError(spec.source, f"{entry['path']}.material",
                                 f"{cls.__name__} of this socp_cd version has no 'material'")
    return kw


def _rotated_2d(V, angle: float, position) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.asarray(V) @ np.array([[c, s], [-s, c]]) + np.asarray(position)


def _box_vertices_2d(size) -> np.ndarray:
    w, h = 0.5 * np.asarray(size)
    return np.array([[-w, -h], [w, -h], [w, h], [-w, h]])


def make_body(spec: SceneSpec, b: dict):
    """One dynamic body of ``socp_cd.dynamics`` from a normalised body entry."""
    shape, dim = b["shape"], spec.dim
    common = dict(position=b["position"], velocity=b["velocity"], omega=b["omega"], mass=b["mass"],
                  density=b["density"])
    if dim == 2:
        cls = _class(spec, b, "Polygon" if shape in ("polygon", "box") else "Disk")
        kw = dict(common, angle=b["angle"], fixed_rotation=b["fixed_rotation"], **_material_kw(spec, cls, b))
        if shape == "disk":
            return cls(b["radius"], **kw)
        V = _box_vertices_2d(b["size"]) if shape == "box" else b["vertices"]
        return cls(V, **kw)
    if shape == "sphere":
        cls = _class(spec, b, "Sphere")
        # a sphere's orientation never matters for contact; it is not stored
        return cls(b["radius"], fixed_rotation=b["fixed_rotation"], **common, **_material_kw(spec, cls, b))
    if b["fixed_rotation"]:
        raise SceneFileError(spec.source, f"{b['path']}.fixed_rotation", f"not available for a {shape}")
    cls = _class(spec, b, "Box" if shape == "box" else "ConvexPolyhedron")
    geom = {"size": tuple(b["size"])} if shape == "box" else {"vertices": b["vertices"]}
    return cls(**geom, orientation=tuple(b["orientation"]), **common, **_material_kw(spec, cls, b))


def make_obstacle(spec: SceneSpec, o: dict):
    """One fixed obstacle of ``socp_cd.dynamics`` from a normalised obstacle entry."""
    shape, dim = o["shape"], spec.dim
    if shape in ("line", "plane"):
        cls = _class(spec, o, "Line" if shape == "line" else "Plane")
        return cls(o["point"], o["normal"], **_material_kw(spec, cls, o))
    if shape in ("disk", "sphere"):
        cls = _class(spec, o, "FixedDisk" if shape == "disk" else "FixedSphere")
        return cls(o["radius"], o["position"], **_material_kw(spec, cls, o))
    if dim == 2:
        cls = _class(spec, o, "FixedPolygon")
        V = _box_vertices_2d(o["size"]) if shape == "box" else o["vertices"]
        return cls(_rotated_2d(V, o["angle"], o["position"]), **_material_kw(spec, cls, o))
    cls = _class(spec, o, "FixedBox" if shape == "box" else "FixedPolyhedron")
    geom = {"size": tuple(o["size"])} if shape == "box" else {"vertices": o["vertices"]}
    return cls(**geom, position=tuple(o["position"]), orientation=tuple(o["orientation"]),
               **_material_kw(spec, cls, o))


def build_scene(spec: SceneSpec):
    """A :class:`socp_cd.dynamics.Scene` from a validated spec.

    Raises
    ------
    SceneFileError
        An entry the dynamics rejects (e.g. a non-convex polygon) or needs a
        feature this version lacks; the message names the entry's key path.
    """
    dyn = _dyn()
    bodies, obstacles = [], []
    for lst, entries, make in ((bodies, spec.bodies, make_body), (obstacles, spec.obstacles, make_obstacle)):
        for e in entries:
            try:
                lst.append(make(spec, e))
            except SceneFileError:
                raise
            except InvalidProblemError as exc:
                raise SceneFileError(spec.source, e["path"], f"{exc.field}: {exc.reason}") from None
    kw = dict(obstacles=obstacles, gravity=tuple(spec.gravity), mu=spec.mu, restitution=spec.restitution)
    if spec.materials:
        if not _accepts(dyn.Scene, "materials"):
            raise SceneFileError(spec.source, "materials",
                                 "this socp_cd version's Scene has no per-pair material table")
        kw["materials"] = {k: dict(v) for k, v in spec.materials.items()}
    try:
        return dyn.Scene(bodies, **kw)
    except InvalidProblemError as exc:
        raise SceneFileError(spec.source, exc.field, exc.reason) from None


def simulation_options(spec: SceneSpec) -> dict:
    """Keyword arguments of :class:`socp_cd.dynamics.Simulation` from ``[simulation]``."""
    s = spec.simulation
    return {"h": s["h"], "theta": s["theta"], "solver": s["solver"], "tol": s["tol"],
            "max_iter": s["max_iter"], "form": s["form"]}


def load_simulation(path, solver: str | None = None):
    """Read a scene file and return ``(spec, Simulation)`` ready to step.

    ``solver``: a name of :func:`socp_cd.solvers` run instead of the file's
    ``simulation.solver`` (its other settings kept; an unknown name raises
    :class:`~socp_cd.errors.UnsupportedError`, as :func:`socp_cd.solve` does)."""
    from ..solvers import solvers

    spec = load_scene_file(path)
    names = solvers()
    if solver is not None and solver not in names:
        raise UnsupportedError(f"solver: unknown solver {solver!r} (available: {', '.join(names)})")
    scene = build_scene(spec)
    opts = simulation_options(spec)
    if solver is not None:
        opts["solver"] = solver
    elif opts["solver"] not in names:
        raise SceneFileError(spec.source, "simulation.solver",
                             f"unknown solver {opts['solver']!r} (available: {', '.join(names)})")
    try:
        sim = _dyn().Simulation(scene, opts.pop("h"), **opts)
    except InvalidProblemError as exc:
        raise SceneFileError(spec.source, f"simulation.{exc.field}" if exc.field in opts or exc.field == "h"
                             else exc.field, exc.reason) from None
    return spec, sim


__all__ = ["build_scene", "make_body", "make_obstacle", "simulation_options", "load_simulation", "has_boxes"]
