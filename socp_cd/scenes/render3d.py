"""Off-screen PNG rendering of 3D frames with matplotlib's mplot3d (Agg backend).

Bodies are shaded triangle meshes (see :mod:`socp_cd.scenes.meshes`), fixed
obstacles grey, planes a square patch; contact normal forces are red segments
from each contact point along the normal, of length proportional to the force.
mplot3d sorts faces per collection, not per pixel, so interpenetrating or
nested meshes may be drawn in the wrong order: this is a quick look, use
ParaView (``--vtk``) for real inspection.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .meshes import BodyMeshes, hull_faces, obstacle_meshes


class Renderer3D:
    """Renders frames of one run with fixed axes (so frames make a movie).

    Parameters
    ----------
    bodies, obstacles : lists of ``socp_cd.dynamics`` 3D objects
    first_frame : Frame
        Sets the axis limits (bodies' bounding box, padded).
    """

    def __init__(self, bodies, obstacles, first_frame, *, elev: float = 22.0, azim: float = -58.0):
        self.meshes = BodyMeshes.of(bodies, 3)
        # draw polyhedral bodies by their planar faces (quads for boxes): mplot3d sorts whole
        # polygons by depth, and long thin triangles sort badly
        self.polys = [None if len(F) > 40 else hull_faces(V) for V, F in zip(self.meshes.local, self.meshes.faces)]
        # limits: the bodies, the finite obstacles and the anchor points of half-spaces
        P = [np.vstack(self.meshes.world(first_frame))]
        P += [V for V, _, _ in obstacle_meshes([o for o in obstacles if not hasattr(o, "normal")], 3, 0.0)]
        P += [np.asarray(o.point, dtype=np.float64)[None] for o in obstacles if hasattr(o, "normal")]
        P = np.vstack(P)
        lo, hi = P.min(0), P.max(0)
        pad = 0.1 * float(np.max(hi - lo)) + 1e-9
        self.lo, self.hi = lo - pad, hi + pad
        ext = float(np.max(self.hi - self.lo))
        self.obstacles = obstacle_meshes(obstacles, 3, ext)
        self.elev, self.azim = elev, azim

    def render(self, frame, path=None, title: str | None = None):
        """Draw ``frame``; write a PNG to ``path`` when given. Returns the figure."""
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.colors import LightSource
        from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

        fig = plt.figure(figsize=(6.4, 6.0), dpi=110)
        ax = fig.add_subplot(projection="3d")
        ls = LightSource(azdeg=225, altdeg=45)
        for V, F, _ in self.obstacles:
            V = np.clip(V, self.lo, self.hi)
            ax.add_collection3d(Poly3DCollection(V[F], facecolor="#c8c8c8", edgecolor="none", alpha=0.5))
        faces = []
        for V, F, P in zip(self.meshes.world(frame), self.meshes.faces, self.polys):
            faces += list(V[F]) if P is None else [V[f] for f in P]
        ax.add_collection3d(Poly3DCollection(faces, facecolors="#d9a066", edgecolors="#5a3d1e", linewidths=0.15,
                                             shade=True, lightsource=ls))
        c = frame.contacts
        if c.n:
            fn = c.normal_force
            big = float(np.max(np.abs(fn)))
            if big > 0:
                L = 0.15 * float(np.max(self.hi - self.lo)) * np.abs(fn) / big
                seg = np.stack([c.point, c.point + L[:, None] * c.normal], axis=1)
                ax.add_collection3d(Line3DCollection(seg, colors="#c0392b", linewidths=1.2))
        ax.set_xlim(self.lo[0], self.hi[0])
        ax.set_ylim(self.lo[1], self.hi[1])
        ax.set_zlim(self.lo[2], self.hi[2])
        ax.set_box_aspect(self.hi - self.lo)
        ax.view_init(elev=self.elev, azim=self.azim)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
        ax.set_title(title or f"t = {frame.t:.4g} s, {c.n} contacts")
        if path is not None:
            fig.savefig(Path(path))
            plt.close(fig)
        return fig


__all__ = ["Renderer3D"]
