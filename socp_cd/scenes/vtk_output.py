"""ParaView time series: VTK XML unstructured grids (``.vtu``) and a ``.pvd`` index.

Written with :mod:`meshio` (pure Python, small; see ``docs/scenes.md`` for the
choice against VTK's own ``vtk`` package).  Per recorded frame ``k``:

* ``bodies_k.vtu`` — every body's surface (2D: one polygon cell per body in the
  plane ``z = 0``; 3D: triangles); cell data ``body`` (index) and ``speed``;
  point data ``velocity`` (rigid-body velocity of each vertex);
* ``contacts_k.vtu`` — one vertex cell per active contact at its point; point
  data ``normal``, ``normal_force`` (``r_N / h``), ``tangential_force``
  (vector), ``force``, ``status`` (:class:`socp_cd.cones.ContactStatus` value:
  see ``status_names`` in the ``.pvd`` comment), ``gap``, ``body_i``, ``body_j``
  (``-1``: obstacle);

``obstacles.vtu`` holds the fixed obstacles once.  ``<name>.pvd`` lists the
three parts (``part`` 0 bodies, 1 contacts, 2 obstacles) at every time.
"""
from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .meshes import BodyMeshes, obstacle_meshes


def _xyz(P) -> np.ndarray:
    P = np.asarray(P, dtype=np.float64).reshape(len(P), -1)
    return np.c_[P, np.zeros(len(P))] if P.shape[1] == 2 else P


def _cells_2d(polys: list) -> tuple[np.ndarray, list, list]:
    """Points and meshio cell blocks of polygons (blocks grouped by vertex count), and the
    polygon index of every cell in block order."""
    pts, blocks, order = [], {}, {}
    off = 0
    for k, V in enumerate(polys):
        pts.append(V)
        blocks.setdefault(len(V), []).append(np.arange(off, off + len(V)))
        order.setdefault(len(V), []).append(k)
        off += len(V)
    keys = sorted(blocks)
    cells = [("polygon" if nv > 3 else "triangle", np.array(blocks[nv])) for nv in keys]
    return np.vstack(pts), cells, [np.array(order[nv]) for nv in keys]


class VtkSeries:
    """Streams frames of a run to a ParaView time series in ``directory``.

    Parameters
    ----------
    directory : str or Path
        Created if needed.
    name : str
        Stem of the ``.pvd`` file.
    bodies, obstacles : lists of ``socp_cd.dynamics`` objects
    dim : int
    """

    def __init__(self, directory, name: str, bodies, obstacles, dim: int):
        self.dir = Path(directory)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.name, self.dim = name, dim
        self.meshes = BodyMeshes.of(bodies, dim)
        self.entries: list = []
        ext = max(1.0, float(np.max(np.abs([b.position for b in bodies]))) * 2)
        self._write_obstacles(obstacle_meshes(obstacles, dim, ext))

    def _write_obstacles(self, meshes) -> None:
        import meshio

        pts, cells, off = [], [], 0
        for V, F, kind in meshes:
            pts.append(_xyz(V))
            if kind == "line":
                cells.append(("line", np.array([[off, off + 1]])))
            elif F is None:
                cells.append(("polygon" if len(V) > 3 else "triangle", np.arange(off, off + len(V))[None]))
            else:
                cells.append(("triangle", F + off))
            off += len(V)
        P = np.vstack(pts) if pts else np.zeros((0, 3))
        meshio.write(self.dir / "obstacles.vtu", meshio.Mesh(P, cells), binary=True)

    def write(self, frame, status=None) -> None:
        """Write one frame (a ``socp_cd.dynamics.Frame``); ``status`` per contact, optional."""
        import meshio

        k = len(self.entries)
        W = self.meshes.world(frame)
        vel = np.asarray(frame.vel)
        d = self.dim
        speed = np.linalg.norm(vel[:, :d], axis=1)

        def point_velocity(b, X):
            v, w = vel[b, :d], vel[b, d:]
            R = X - frame.pos[b]
            if d == 2:
                return np.c_[v[0] - w[0] * R[:, 1], v[1] + w[0] * R[:, 0], np.zeros(len(R))]
            return v + np.cross(w, R)

        if d == 2:
            P, cells, order = _cells_2d(W)
            body = [o.astype(np.int64) for o in order]
        else:
            F = self.meshes.faces
            offs = np.cumsum([0] + [len(V) for V in W])
            P = np.vstack(W)
            cells = [("triangle", np.vstack([F[b] + offs[b] for b in range(len(W))]))]
            body = [np.concatenate([np.full(len(F[b]), b) for b in range(len(W))])]
        pv = np.vstack([point_velocity(b, V) for b, V in enumerate(W)])
        mesh = meshio.Mesh(_xyz(P), cells, point_data={"velocity": pv},
                           cell_data={"body": body, "speed": [speed[b] for b in body]})
        fb = f"bodies_{k:05d}.vtu"
        meshio.write(self.dir / fb, mesh, binary=True)
        c = frame.contacts
        n = c.n
        nrm = _xyz(c.normal) if n else np.zeros((0, 3))
        force = _xyz(c.force) if n else np.zeros((0, 3))
        fn = np.einsum("ij,ij->i", force, nrm)
        st = np.full(n, -1, np.int64) if status is None else np.asarray(status, np.int64)
        cm = meshio.Mesh(_xyz(c.point) if n else np.zeros((0, 3)),
                         [("vertex", np.arange(n)[:, None])] if n else [],
                         point_data={"normal": nrm, "normal_force": fn, "tangential_force": force - fn[:, None] * nrm,
                                     "force": force, "status": st, "gap": np.asarray(c.gap, float),
                                     "body_i": c.pairs[:, 0].astype(np.int64),
                                     "body_j": c.pairs[:, 1].astype(np.int64)})
        fc = f"contacts_{k:05d}.vtu"
        meshio.write(self.dir / fc, cm, binary=True)
        self.entries.append((float(frame.t), fb, fc))
        self._write_pvd()

    def _write_pvd(self) -> Path:
        from ..cones import ContactStatus

        names = ", ".join(f"{s.value}={s.name.lower()}" for s in ContactStatus)
        lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 f"  <!-- contact status: -1=unknown, {names} -->", "  <Collection>"]
        for t, fb, fc in self.entries:
            for part, f in enumerate((fb, fc, "obstacles.vtu")):
                lines.append(f'    <DataSet timestep="{t:.9g}" group="" part="{part}" file={quoteattr(f)}/>')
        lines += ["  </Collection>", "</VTKFile>", ""]
        path = self.dir / f"{self.name}.pvd"
        path.write_text("\n".join(lines))
        return path


def read_pvd(path) -> list[tuple[float, int, Path]]:
    """``(timestep, part, file)`` entries of a ``.pvd`` index (files resolved next to it)."""
    import xml.etree.ElementTree as ET

    path = Path(path)
    root = ET.parse(path).getroot()
    return [(float(e.get("timestep")), int(e.get("part", 0)), path.parent / e.get("file"))
            for e in root.iter("DataSet")]


__all__ = ["VtkSeries", "read_pvd"]
