"""A plain, simulator-independent snapshot of a granular sample.

:class:`GranularState` holds what the stress/cut/statistics functions of
:mod:`socp_cd.granular` need and nothing else: body centres (centres of mass),
masses, volumes (areas in 2D), optional accelerations, gravity, and the list of
contacts in the *global* frame.

Contact convention
------------------
Contact ``k`` joins body ``pairs[k, 0] = i`` and body ``pairs[k, 1] = j``;
``j = -1`` means a fixed obstacle (wall, fixed grain, rough line...).
``forces[k]`` is the force **exerted by j on i** (global frame); body ``j``
(when it is a body) receives ``-forces[k]`` at the same point ``points[k]``.
``normals[k]`` (optional) is the unit contact normal pointing **from j towards
i**, so that a compressive contact has ``forces[k] · normals[k] > 0``.

Simulators report impulses over a time step ``h``; the adapters divide by
``h`` (mean force over the step, which is the force at a static equilibrium).
:func:`from_frame` reads a generic frame; the adapters for
:mod:`socp_cd.dynamics` objects are in :mod:`socp_cd.granular.adapters`
(which imports this module, never the reverse).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import InvalidProblemError

__all__ = ["GranularState", "from_frame"]


def _arr(value, name, shape, source, dtype=np.float64):
    """Validate an array field and return it as a contiguous ndarray."""
    try:
        a = np.ascontiguousarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise InvalidProblemError(name, f"cannot be read as an array ({exc})", source) from None
    if a.ndim != len(shape) or any(s is not None and a.shape[k] != s for k, s in enumerate(shape)):
        want = "(" + ", ".join("?" if s is None else str(s) for s in shape) + ")"
        raise InvalidProblemError(name, f"shape {a.shape}, expected {want}", source)
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise InvalidProblemError(name, "contains NaN or Inf", source)
    return a


@dataclass(frozen=True)
class GranularState:
    """Snapshot of a granular sample: bodies, contacts (global frame), gravity.

    Parameters
    ----------
    centers : array_like, shape (nb, d)
        Centres of mass, ``d`` = 2 or 3.
    masses : array_like, shape (nb,)
    volumes : array_like, shape (nb,)
        Grain areas (2D) or volumes (3D).
    pairs : array_like of int, shape (nc, 2)
        ``(i, j)``; ``j = -1`` for fixed obstacles.  ``i`` must be a body.
    points : array_like, shape (nc, d)
        Contact points.
    forces : array_like, shape (nc, d)
        Force exerted by ``j`` on ``i``.
    normals : array_like, shape (nc, d), optional
        Unit normals from ``j`` towards ``i``.
    gravity : array_like, shape (d,), optional
        Gravity acceleration vector (default zero).
    accelerations : array_like, shape (nb, d), optional
        Centre-of-mass accelerations; the inertia force ``-m a`` is applied at
        the centre (dynamic version of Moreau's formula).
    radii : array_like, shape (nb,), optional
        Disk/sphere radii, or circumradii of polygons (used for plots/stats).
    shapes : list of (nv, d) arrays, optional
        Polygon vertices in the global frame (plots only).
    source : str, optional
        Where the data came from (for error messages).
    """

    centers: np.ndarray
    masses: np.ndarray
    volumes: np.ndarray
    pairs: np.ndarray
    points: np.ndarray
    forces: np.ndarray
    normals: np.ndarray | None = None
    gravity: np.ndarray | None = None
    accelerations: np.ndarray | None = None
    radii: np.ndarray | None = None
    shapes: list | None = field(default=None, repr=False)
    source: str | None = None

    def __post_init__(self):
        src = self.source or "GranularState"
        c = _arr(self.centers, "centers", (None, None), src)
        nb, d = c.shape
        if d not in (2, 3):
            raise InvalidProblemError("centers", f"dimension d={d}, expected 2 or 3", src)
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 (frozen dataclass)
        set_("centers", c)
        set_("masses", _arr(self.masses, "masses", (nb,), src))
        set_("volumes", _arr(self.volumes, "volumes", (nb,), src))
        if np.any(self.masses < 0) or np.any(self.volumes < 0):
            raise InvalidProblemError("masses/volumes", "must be >= 0", src)
        pairs = np.asarray(self.pairs)
        if pairs.size == 0:
            pairs = pairs.reshape(0, 2)
        pairs = _arr(pairs, "pairs", (None, 2), src, dtype=np.int64)
        nc = pairs.shape[0]
        if nc and (pairs.min() < -1 or pairs.max() >= nb):
            raise InvalidProblemError("pairs", f"body index out of range [-1, {nb})", src)
        if nc and np.any(pairs[:, 0] < 0):
            raise InvalidProblemError("pairs", "first body of a contact must be a body (>= 0)", src)
        if nc and np.any(pairs[:, 0] == pairs[:, 1]):
            raise InvalidProblemError("pairs", "a body in contact with itself", src)
        set_("pairs", pairs)
        set_("points", _arr(np.reshape(self.points, (-1, d)) if nc == 0 else self.points,
                            "points", (nc, d), src))
        set_("forces", _arr(np.reshape(self.forces, (-1, d)) if nc == 0 else self.forces,
                            "forces", (nc, d), src))
        if self.normals is not None:
            set_("normals", _arr(np.reshape(self.normals, (-1, d)) if nc == 0 else self.normals,
                                 "normals", (nc, d), src))
        g = np.zeros(d) if self.gravity is None else self.gravity
        set_("gravity", _arr(g, "gravity", (d,), src))
        if self.accelerations is not None:
            set_("accelerations", _arr(self.accelerations, "accelerations", (nb, d), src))
        if self.radii is not None:
            set_("radii", _arr(self.radii, "radii", (nb,), src))

    # ------------------------------------------------------------------ sizes
    @property
    def dim(self) -> int:
        """Space dimension ``d``."""
        return self.centers.shape[1]

    @property
    def n_bodies(self) -> int:
        return self.centers.shape[0]

    @property
    def n_contacts(self) -> int:
        return self.pairs.shape[0]

    @property
    def wall_contacts(self) -> np.ndarray:
        """Boolean mask of contacts with fixed obstacles (``j = -1``)."""
        return self.pairs[:, 1] < 0

    def normal_forces(self) -> np.ndarray:
        """Normal force magnitudes ``f · n`` (``|f|`` when normals are unknown)."""
        if self.normals is None:
            return np.linalg.norm(self.forces, axis=1)
        return np.einsum("kd,kd->k", self.forces, self.normals)

    def body_forces(self) -> np.ndarray:
        """Non-contact forces at the centres: gravity ``m g`` and inertia ``-m a``."""
        f = self.masses[:, None] * self.gravity[None, :]
        if self.accelerations is not None:
            f = f - self.masses[:, None] * self.accelerations
        return f

    def resultants(self) -> np.ndarray:
        """Net force on each body (contacts + gravity + inertia), shape (nb, d).

        Zero for every body at (dynamic) equilibrium.
        """
        out = self.body_forces().copy()
        np.add.at(out, self.pairs[:, 0], self.forces)
        inner = self.pairs[:, 1] >= 0
        np.add.at(out, self.pairs[inner, 1], -self.forces[inner])
        return out

    def subset(self, contact_mask) -> "GranularState":
        """A copy keeping only the contacts selected by ``contact_mask``."""
        m = np.asarray(contact_mask, dtype=bool)
        return replace(self, pairs=self.pairs[m], points=self.points[m], forces=self.forces[m],
                       normals=None if self.normals is None else self.normals[m])

    def active(self, threshold: float = 0.0) -> "GranularState":
        """A copy without contacts whose force norm is ``<= threshold``."""
        return self.subset(np.linalg.norm(self.forces, axis=1) > threshold)


# ---------------------------------------------------------------- adapters
def _get(obj, *names, default=None):
    """First attribute / mapping key of ``obj`` among ``names``."""
    for n in names:
        if isinstance(obj, dict) and n in obj:
            return obj[n]
        if hasattr(obj, n):
            return getattr(obj, n)
    return default


def from_frame(frame, *, masses=None, volumes=None, gravity=None, h=None, radii=None,
               source=None) -> GranularState:
    """Build a :class:`GranularState` from a simulator frame (object or mapping).

    Recognised fields (first name found wins): centres ``positions``/
    ``centers``/``q`` (only the first ``d`` columns are used: a 2D frame may
    carry ``(x, y, theta)``), ``masses``/``mass``, ``volumes``/``areas``,
    ``pairs``/``bodies``, ``points``, ``normals``, ``forces`` or
    ``impulses`` (divided by ``h``), ``gravity``, ``accelerations``,
    ``radii``.  Keyword arguments override missing fields.

    Raises
    ------
    InvalidProblemError
        A required field is missing or inconsistent.
    """
    src = source or type(frame).__name__
    pos = _get(frame, "centers", "positions", "q")
    if pos is None:
        raise InvalidProblemError("centers", "frame has no centers/positions", src)
    pos = np.asarray(pos, dtype=float)
    pts = np.asarray(_get(frame, "points", "contact_points"), dtype=float)
    d = pts.shape[1] if pts.ndim == 2 and pts.shape[0] else (2 if pos.shape[1] == 3 else pos.shape[1])
    pos = pos[:, :d]
    m = masses if masses is not None else _get(frame, "masses", "mass")
    v = volumes if volumes is not None else _get(frame, "volumes", "areas", "volume", "area")
    if m is None or v is None:
        raise InvalidProblemError("masses/volumes", "missing: pass masses= and volumes=", src)
    f = _get(frame, "forces", "contact_forces")
    if f is None:
        imp = _get(frame, "impulses", "contact_impulses")
        step = h if h is not None else _get(frame, "h", "dt", "time_step")
        if imp is None or step is None:
            raise InvalidProblemError("forces", "frame has neither forces nor impulses with h", src)
        f = np.asarray(imp, dtype=float) / float(step)
    g = gravity if gravity is not None else _get(frame, "gravity")
    return GranularState(
        centers=pos, masses=m, volumes=v, pairs=_get(frame, "pairs", "bodies"), points=pts,
        forces=f, normals=_get(frame, "normals", "contact_normals"),
        gravity=None if g is None else np.asarray(g, float)[:d],
        accelerations=_get(frame, "accelerations"),
        radii=radii if radii is not None else _get(frame, "radii"), source=src)
