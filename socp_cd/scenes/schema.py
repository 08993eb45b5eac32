"""Reading and validating TOML scene files (schema in ``docs/scenes.md``).

:func:`load_scene_file` parses a file with the standard library's
:mod:`tomllib`, checks every table against the schema and returns a
:class:`SceneSpec`: plain, validated Python values (no ``socp_cd.dynamics``
objects yet; :mod:`socp_cd.scenes.builder` makes those).  Every defect raises
:class:`SceneFileError`, which names the file, the key path (``bodies[3].size``)
and the reason; a TOML syntax error also gives the line.

Angles in scene files are in **degrees**; 3D orientations are given by one of
``quaternion = [w, x, y, z]``, ``axis_angle = [ax, ay, az, degrees]`` or
``euler = [rx, ry, rz]`` (degrees, extrinsic x then y then z:
``R = Rz Ry Rx``), and stored as a unit quaternion ``(w, x, y, z)``.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InvalidProblemError
from .rotations import quat_from_axis_angle, quat_from_euler

SHAPES_2D = ("disk", "polygon", "box")
SHAPES_3D = ("sphere", "box", "polyhedron")
OBSTACLES_2D = ("line", "disk", "polygon", "box")
OBSTACLES_3D = ("plane", "sphere", "box", "polyhedron")
FORMS = ("local", "global")


class SceneFileError(InvalidProblemError):
    """A scene file is malformed: names the file, the key path and the reason.

    Attributes
    ----------
    source : str
        The scene file.
    field : str
        Key path inside the file, e.g. ``"bodies[3].size"`` (``""`` for the whole file).
    reason : str
    line : int or None
        Line of a TOML syntax error.
    """

    def __init__(self, source: str, key: str, reason: str, line: int | None = None):
        super().__init__(key, reason, source)
        self.line = line
        where = f"{source}" + (f", line {line}" if line else "")
        self.args = (f"{where}: {key + ': ' if key else ''}{reason}",)


# ----------------------------------------------------------------------------- checker
class Checker:
    """Typed access to a parsed TOML table, raising :class:`SceneFileError` on defects."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, reason: str):
        raise SceneFileError(self.source, path, reason)

    def table(self, value, path: str, allowed, required=()) -> dict:
        """Check ``value`` is a table whose keys are in ``allowed`` and include ``required``."""
        if not isinstance(value, dict):
            self.fail(path, f"must be a table, got {_tname(value)}")
        for k in value:
            if k not in allowed:
                self.fail(_join(path, k), f"unknown key (allowed: {', '.join(sorted(allowed))})")
        for k in required:
            if k not in value:
                self.fail(_join(path, k), "missing required key")
        return value

    def number(self, value, path: str, *, positive=False, nonneg=False, lo=None, hi=None,
               integer=False) -> float:
        """A finite number (``int`` when ``integer``), optionally bounded."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"must be a number, got {_tname(value)}")
        if integer and not isinstance(value, int):
            self.fail(path, f"must be an integer, got {value!r}")
        if not math.isfinite(value):
            self.fail(path, f"must be finite, got {value!r}")
        if positive and not value > 0:
            self.fail(path, f"must be positive, got {value!r}")
        if nonneg and not value >= 0:
            self.fail(path, f"must be >= 0, got {value!r}")
        if lo is not None and value < lo:
            self.fail(path, f"must be >= {lo}, got {value!r}")
        if hi is not None and value > hi:
            self.fail(path, f"must be <= {hi}, got {value!r}")
        return int(value) if integer else float(value)

    def vector(self, value, path: str, n: int | tuple, *, positive=False) -> np.ndarray:
        """A list of ``n`` finite numbers (``n`` may be a tuple of allowed lengths)."""
        ns = (n,) if isinstance(n, int) else tuple(n)
        if not isinstance(value, list) or len(value) not in ns:
            want = " or ".join(str(k) for k in ns)
            self.fail(path, f"must be a list of {want} numbers, got {_short(value)}")
        return np.array([self.number(x, f"{path}[{k}]", positive=positive) for k, x in enumerate(value)])

    def points(self, value, path: str, d: int, min_count: int) -> np.ndarray:
        """A list of at least ``min_count`` points of ``d`` numbers."""
        if not isinstance(value, list) or len(value) < min_count:
            self.fail(path, f"must be a list of at least {min_count} points, got {_short(value)}")
        return np.array([self.vector(p, f"{path}[{k}]", d) for k, p in enumerate(value)])

    def string(self, value, path: str, choices=None) -> str:
        if not isinstance(value, str):
            self.fail(path, f"must be a string, got {_tname(value)}")
        if choices is not None and value not in choices:
            self.fail(path, f"must be one of {', '.join(choices)}, got {value!r}")
        return value

    def boolean(self, value, path: str) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"must be true or false, got {_tname(value)}")
        return value

    def array_of_tables(self, value, path: str) -> list:
        if not isinstance(value, list) or not all(isinstance(x, dict) for x in value):
            self.fail(path, f"must be an array of tables ([[{path}]]), got {_tname(value)}")
        return value


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _tname(v) -> str:
    return {dict: "a table", list: "a list", str: "a string", bool: "a boolean"}.get(type(v), type(v).__name__)


def _short(v) -> str:
    s = repr(v)
    return s if len(s) < 60 else s[:57] + "..."


# ----------------------------------------------------------------------------- spec
@dataclass
class SceneSpec:
    """A validated scene file.

    Attributes
    ----------
    source : str
    name : str
        ``scene.name`` or the file stem (used to name output files).
    dim : int
    gravity : ndarray (dim,)
    mu, restitution : float
        Scene defaults.
    materials : dict
        ``{(a, b): {"mu": .., "restitution": ..}}`` per unordered pair (``a <= b``).
    bodies, obstacles : list of dict
        Normalised entries: ``shape``, geometry (``radius``/``size``/``vertices``),
        ``position``, ``angle`` (2D, rad) or ``orientation`` (3D quaternion),
        ``velocity``, ``omega``, ``density``, ``mass``, ``material``, ``mu``,
        ``restitution``, ``fixed_rotation``; ``path`` is the key path it came from.
    simulation : dict
        ``h, theta, steps, solver, tol, max_iter, form, record_every``.
    """

    source: str
    name: str
    dim: int
    gravity: np.ndarray
    mu: float
    restitution: float
    materials: dict = field(default_factory=dict)
    bodies: list = field(default_factory=list)
    obstacles: list = field(default_factory=list)
    simulation: dict = field(default_factory=dict)


_TOP = {"scene", "simulation", "materials", "bodies", "obstacles", "generate"}
_SCENE = {"name", "dim", "gravity", "mu", "restitution"}
_SIM = {"h", "theta", "steps", "solver", "tol", "max_iter", "form", "record_every"}
_MATERIAL = {"pair", "mu", "restitution"}
_BODY_COMMON = {"shape", "position", "velocity", "omega", "density", "mass", "material", "mu",
                "restitution", "fixed_rotation", "angle", "quaternion", "axis_angle", "euler"}
_BODY_GEOM = {"radius", "size", "vertices", "sides"}
_OBSTACLE = {"shape", "point", "normal", "inclination", "position", "radius", "size", "vertices",
             "sides", "angle", "quaternion", "axis_angle", "euler", "material", "mu", "restitution"}
SIM_DEFAULTS = {"h": 1e-3, "theta": 0.5, "steps": 100, "solver": "auto", "tol": 1e-8,
                "max_iter": None, "form": "local", "record_every": 1}


def parse_toml(path) -> dict:
    """Read a TOML file; a syntax error becomes a :class:`SceneFileError` with its line."""
    import tomllib

    path = Path(path)
    try:
        text = path.read_bytes()
    except OSError as exc:
        raise SceneFileError(str(path), "", f"cannot read file ({exc.strerror or exc})") from None
    try:
        return tomllib.loads(text.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneFileError(str(path), "", f"not UTF-8 text ({exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"line (\d+)", msg)
        raise SceneFileError(str(path), "", f"TOML syntax error: {msg}",
                             line=int(m.group(1)) if m else None) from None


def load_scene_file(path) -> SceneSpec:
    """Parse and validate a scene file.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    SceneSpec

    Raises
    ------
    SceneFileError
        Unreadable file, TOML syntax error (with line), unknown/missing keys,
        wrong types, NaN/Inf, non-positive sizes, inconsistent dimensions.
    """
    return validate_scene(parse_toml(path), source=str(path), default_name=Path(path).stem)


def validate_scene(data: dict, source: str = "<scene>", default_name: str = "scene") -> SceneSpec:
    """Validate an already parsed scene table (see :func:`load_scene_file`)."""
    from .generators import expand_generator

    ck = Checker(source)
    ck.table(data, "", _TOP, required=("scene",))
    sc = ck.table(data["scene"], "scene", _SCENE, required=("dim",))
    dim = ck.number(sc["dim"], "scene.dim", integer=True)
    if dim not in (2, 3):
        ck.fail("scene.dim", f"must be 2 or 3, got {dim}")
    name = ck.string(sc.get("name", default_name), "scene.name")
    if not re.fullmatch(r"[A-Za-z0-9_.+-]+", name):
        ck.fail("scene.name", f"must use letters, digits and _ . + - only (it names output files), got {name!r}")
    g = np.zeros(dim)
    g[-1] = -9.81
    if "gravity" in sc:
        g = ck.vector(sc["gravity"], "scene.gravity", dim)
    mu = ck.number(sc.get("mu", 0.0), "scene.mu", nonneg=True)
    e = ck.number(sc.get("restitution", 0.0), "scene.restitution", lo=0.0, hi=1.0)
    sim = dict(SIM_DEFAULTS)
    if "simulation" in data:
        sim.update(_simulation(ck, data["simulation"]))
    materials = {}
    for k, m in enumerate(ck.array_of_tables(data.get("materials", []), "materials")):
        p = f"materials[{k}]"
        ck.table(m, p, _MATERIAL, required=("pair",))
        pair = m["pair"]
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(x, str) for x in pair)):
            ck.fail(f"{p}.pair", f"must be two material names, got {_short(pair)}")
        key = tuple(sorted(pair))
        if key in materials:
            ck.fail(f"{p}.pair", f"pair {list(key)} is defined twice")
        entry = {}
        if "mu" in m:
            entry["mu"] = ck.number(m["mu"], f"{p}.mu", nonneg=True)
        if "restitution" in m:
            entry["restitution"] = ck.number(m["restitution"], f"{p}.restitution", lo=0.0, hi=1.0)
        if not entry:
            ck.fail(p, "give mu and/or restitution")
        materials[key] = entry
    bodies = [body_entry(ck, b, f"bodies[{k}]", dim)
              for k, b in enumerate(ck.array_of_tables(data.get("bodies", []), "bodies"))]
    obstacles = [_obstacle(ck, o, f"obstacles[{k}]", dim)
                 for k, o in enumerate(ck.array_of_tables(data.get("obstacles", []), "obstacles"))]
    for k, gtab in enumerate(ck.array_of_tables(data.get("generate", []), "generate")):
        new_b, new_o = expand_generator(ck, gtab, f"generate[{k}]", dim, body_entry)
        bodies += new_b
        obstacles += new_o
    if not bodies:
        ck.fail("bodies", "the scene has no bodies (give [[bodies]] or [[generate]])")
    known = {m for pair in materials for m in pair}
    for b in bodies + obstacles:
        if b.get("material") is not None and materials and b["material"] not in known:
            ck.fail(f"{b['path']}.material", f"material {b['material']!r} appears in no [[materials]] pair")
    return SceneSpec(source=source, name=name, dim=dim, gravity=g, mu=mu, restitution=e,
                     materials=materials, bodies=bodies, obstacles=obstacles, simulation=sim)


def _simulation(ck: Checker, s) -> dict:
    ck.table(s, "simulation", _SIM)
    out = {}
    if "h" in s:
        out["h"] = ck.number(s["h"], "simulation.h", positive=True)
    if "theta" in s:
        out["theta"] = ck.number(s["theta"], "simulation.theta", positive=True, hi=1.0)
    if "steps" in s:
        out["steps"] = ck.number(s["steps"], "simulation.steps", integer=True, nonneg=True)
    if "solver" in s:
        out["solver"] = ck.string(s["solver"], "simulation.solver")
    if "tol" in s:
        out["tol"] = ck.number(s["tol"], "simulation.tol", positive=True)
    if "max_iter" in s:
        out["max_iter"] = ck.number(s["max_iter"], "simulation.max_iter", integer=True, positive=True)
    if "form" in s:
        out["form"] = ck.string(s["form"], "simulation.form", FORMS)
    if "record_every" in s:
        out["record_every"] = ck.number(s["record_every"], "simulation.record_every", integer=True, positive=True)
    return out


def _orientation(ck: Checker, t: dict, path: str, dim: int) -> dict:
    """``angle`` (2D, rad) or ``orientation`` (3D unit quaternion) from the orientation keys."""
    given = [k for k in ("angle", "quaternion", "axis_angle", "euler") if k in t]
    if dim == 2:
        bad = [k for k in given if k != "angle"]
        if bad:
            ck.fail(_join(path, bad[0]), "2D orientations are given by 'angle' (degrees)")
        return {"angle": math.radians(ck.number(t.get("angle", 0.0), _join(path, "angle")))}
    if "angle" in given:
        ck.fail(_join(path, "angle"), "3D orientations are given by quaternion, axis_angle or euler")
    if len(given) > 1:
        ck.fail(_join(path, given[1]), f"give only one of quaternion, axis_angle, euler (also got {given[0]})")
    q = np.array([1.0, 0.0, 0.0, 0.0])
    if given == ["quaternion"]:
        q = ck.vector(t["quaternion"], _join(path, "quaternion"), 4)
        nq = np.linalg.norm(q)
        if abs(nq - 1.0) > 1e-6:
            ck.fail(_join(path, "quaternion"), f"must be a unit quaternion [w, x, y, z], norm is {nq:.6g}")
        q = q / nq
    elif given == ["axis_angle"]:
        a = ck.vector(t["axis_angle"], _join(path, "axis_angle"), 4)
        if np.linalg.norm(a[:3]) == 0:
            ck.fail(_join(path, "axis_angle"), "the axis [ax, ay, az] must be nonzero")
        q = quat_from_axis_angle(a[:3], math.radians(a[3]))
    elif given == ["euler"]:
        q = quat_from_euler(*np.radians(ck.vector(t["euler"], _join(path, "euler"), 3)))
    return {"orientation": q}


def _geometry(ck: Checker, t: dict, path: str, shape: str, dim: int) -> dict:
    """Shape-specific geometry keys (and rejection of the others)."""
    need = {"disk": ("radius",), "sphere": ("radius",), "box": ("size",), "polyhedron": ("vertices",),
            "polygon": ()}[shape]
    allowed = {"disk": {"radius"}, "sphere": {"radius"}, "box": {"size"}, "polyhedron": {"vertices"},
               "polygon": {"vertices", "sides", "radius"}}[shape]
    for k in ("radius", "size", "vertices", "sides"):
        if k in t and k not in allowed:
            ck.fail(_join(path, k), f"not a key of shape {shape!r} (it uses {', '.join(sorted(allowed))})")
    for k in need:
        if k not in t:
            ck.fail(_join(path, k), f"missing required key for shape {shape!r}")
    out = {}
    if "radius" in t:
        out["radius"] = ck.number(t["radius"], _join(path, "radius"), positive=True)
    if shape == "box":
        out["size"] = ck.vector(t["size"], _join(path, "size"), dim, positive=True)
    if shape == "polyhedron":
        V = ck.points(t["vertices"], _join(path, "vertices"), 3, 4)
        if np.linalg.matrix_rank(V[1:] - V[0], tol=1e-12 * max(1.0, np.abs(V).max())) < 3:
            ck.fail(_join(path, "vertices"), "the vertices are coplanar (no volume)")
        out["vertices"] = V
    if shape == "polygon":
        if ("vertices" in t) == ("sides" in t):
            ck.fail(path, "a polygon needs either 'vertices' or 'sides' + 'radius' (a regular polygon)")
        if "vertices" in t:
            out["vertices"] = ck.points(t["vertices"], _join(path, "vertices"), 2, 3)
            a = np.asarray(out["vertices"])
            area = 0.5 * np.sum(a[:, 0] * np.roll(a[:, 1], -1) - np.roll(a[:, 0], -1) * a[:, 1])
            if abs(area) <= 1e-300:
                ck.fail(_join(path, "vertices"), "polygon has zero area")
        else:
            n = ck.number(t["sides"], _join(path, "sides"), integer=True, lo=3, hi=1000)
            if "radius" not in t:
                ck.fail(_join(path, "radius"), "missing required key for a regular polygon ('sides' given)")
            a = 2 * np.pi * np.arange(n) / n
            out["vertices"] = out.pop("radius") * np.c_[np.cos(a), np.sin(a)]
    return out


def _material_keys(ck: Checker, t: dict, path: str) -> dict:
    out = {"material": None, "mu": None, "restitution": None}
    if "material" in t:
        out["material"] = ck.string(t["material"], _join(path, "material"))
    if "mu" in t:
        out["mu"] = ck.number(t["mu"], _join(path, "mu"), nonneg=True)
    if "restitution" in t:
        out["restitution"] = ck.number(t["restitution"], _join(path, "restitution"), lo=0.0, hi=1.0)
    return out


def body_entry(ck: Checker, t, path: str, dim: int, *, require_position: bool = True) -> dict:
    """Validate one body table (also used for generator templates, without a position)."""
    ck.table(t, path, _BODY_COMMON | _BODY_GEOM, required=("shape",))
    shape = ck.string(t["shape"], _join(path, "shape"), SHAPES_2D if dim == 2 else SHAPES_3D)
    out = {"shape": shape, "path": path}
    out.update(_geometry(ck, t, path, shape, dim))
    if "position" in t:
        out["position"] = ck.vector(t["position"], _join(path, "position"), dim)
    elif require_position:
        ck.fail(_join(path, "position"), "missing required key")
    out["velocity"] = ck.vector(t.get("velocity", [0.0] * dim), _join(path, "velocity"), dim)
    if dim == 2:
        out["omega"] = ck.number(t.get("omega", 0.0), _join(path, "omega"))
    else:
        out["omega"] = ck.vector(t.get("omega", [0.0] * 3), _join(path, "omega"), 3)
    out["density"] = ck.number(t.get("density", 1.0), _join(path, "density"), positive=True)
    out["mass"] = ck.number(t["mass"], _join(path, "mass"), positive=True) if "mass" in t else None
    out["fixed_rotation"] = ck.boolean(t.get("fixed_rotation", False), _join(path, "fixed_rotation"))
    out.update(_orientation(ck, t, path, dim))
    out.update(_material_keys(ck, t, path))
    return out


def _obstacle(ck: Checker, t, path: str, dim: int) -> dict:
    ck.table(t, path, _OBSTACLE, required=("shape",))
    shape = ck.string(t["shape"], _join(path, "shape"), OBSTACLES_2D if dim == 2 else OBSTACLES_3D)
    out = {"shape": shape, "path": path}
    out.update(_material_keys(ck, t, path))
    if shape in ("line", "plane"):
        for k in t:
            if k not in ("shape", "point", "normal", "inclination", "material", "mu", "restitution"):
                ck.fail(_join(path, k), f"not a key of a {shape} (it uses point, normal or inclination)")
        out["point"] = ck.vector(t.get("point", [0.0] * dim), _join(path, "point"), dim)
        if "normal" in t and "inclination" in t:
            ck.fail(_join(path, "inclination"), "give either normal or inclination")
        if "inclination" in t:
            if dim != 2:
                ck.fail(_join(path, "inclination"), "only 2D lines have an inclination; give a normal")
            a = math.radians(ck.number(t["inclination"], _join(path, "inclination"), lo=-90, hi=90))
            out["normal"] = np.array([-math.sin(a), math.cos(a)])
        else:
            n = ck.vector(t.get("normal", [0.0] * (dim - 1) + [1.0]), _join(path, "normal"), dim)
            if not np.any(n):
                ck.fail(_join(path, "normal"), "must be nonzero")
            out["normal"] = n / np.linalg.norm(n)
        return out
    if "point" in t or "normal" in t or "inclination" in t:
        bad = next(k for k in ("point", "normal", "inclination") if k in t)
        ck.fail(_join(path, bad), f"not a key of a fixed {shape} (it uses position)")
    shape_b = {"sphere": "sphere", "disk": "disk"}.get(shape, shape)
    out.update(_geometry(ck, t, path, shape_b, dim))
    if "position" not in t and shape != "polygon":
        ck.fail(_join(path, "position"), "missing required key")
    out["position"] = ck.vector(t.get("position", [0.0] * dim), _join(path, "position"), dim)
    out.update(_orientation(ck, t, path, dim))
    return out


__all__ = ["SceneFileError", "SceneSpec", "Checker", "load_scene_file", "validate_scene", "parse_toml",
           "body_entry", "SIM_DEFAULTS"]
