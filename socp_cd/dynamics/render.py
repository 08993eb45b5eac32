"""Quick matplotlib rendering of 2D frames (Agg backend, PNG).

Bodies are drawn as outlines, fixed obstacles in grey, and each contact's
normal force as a red segment between the two body centres (from the body
centre to the contact point for obstacles) whose width is proportional to the
normal force.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UnsupportedError


def _geometry_and_frame(source, index):
    from .trajectory import Trajectory
    if isinstance(source, Trajectory):
        return source.geometry, source.frames[index]
    traj = Trajectory.start(source)          # a Simulation
    return traj.geometry, traj.frames[0]


def render_frame(source, path=None, *, index: int = -1, ax=None, forces: bool = True,
                 max_width: float = 4.0, title: str | None = None, bounds=None):
    """Draw one 2D frame.

    Parameters
    ----------
    source : Trajectory or Simulation
    path : str or Path, optional
        PNG written when given.
    index : int
        Frame of a trajectory (ignored for a simulation: its current state).
    ax : matplotlib Axes, optional
    forces : bool
        Draw normal contact forces (width ∝ force, the largest gets ``max_width`` points).
    bounds : (xmin, xmax, ymin, ymax), optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle
    from matplotlib.patches import Polygon as MplPolygon

    geom, fr = _geometry_and_frame(source, index)
    if fr.pos.shape[1] != 2:
        raise UnsupportedError("render_frame draws 2D scenes only")
    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(7, 5), dpi=110)
    else:
        fig = ax.figure
    pos, ang = fr.pos, fr.angle
    patches, fixed = [], []
    is_poly = geom["is_poly"].astype(bool)
    for b in np.flatnonzero(~is_poly):
        patches.append(Circle(pos[b], geom["radius"][b]))
    PL, NV, row = geom["poly_vertices"], geom["poly_nv"], geom["poly_of_body"]
    for b in np.flatnonzero(is_poly):
        k = row[b]
        V = PL[k, :NV[k]]
        c, s = np.cos(ang[b]), np.sin(ang[b])
        patches.append(MplPolygon(V @ np.array([[c, s], [-s, c]]) + pos[b], closed=True))
    for cen, rad in zip(geom["fixed_round_center"], geom["fixed_round_radius"]):
        fixed.append(Circle(cen, rad))
    for V, nv in zip(geom["fixed_poly_vertices"], geom["fixed_poly_nv"]):
        fixed.append(MplPolygon(V[:nv], closed=True))
    ax.add_collection(PatchCollection(patches, facecolor="#cfe0f3", edgecolor="#1f4e79", linewidth=0.6))
    if fixed:
        ax.add_collection(PatchCollection(fixed, facecolor="#bbbbbb", edgecolor="#555555", linewidth=0.5))
    if bounds is None:
        pts = [pos - geom["radius"][:, None], pos + geom["radius"][:, None]]
        if len(geom["fixed_round_center"]):
            pts.append(geom["fixed_round_center"])
        if len(geom["fixed_poly_vertices"]):
            pts.append(geom["fixed_poly_vertices"].reshape(-1, 2))
        P = np.vstack(pts)
        lo, hi = P.min(0), P.max(0)
        pad = 0.08 * float(max(hi - lo)) + 1e-9
        bounds = (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad)
    xmin, xmax, ymin, ymax = bounds
    L = 2 * max(xmax - xmin, ymax - ymin)
    for p, n in zip(geom["halfspace_point"], geom["halfspace_normal"]):
        t = np.array([-n[1], n[0]])
        ax.plot(*np.c_[p - L * t, p + L * t], color="k", lw=1.2)
    cf = fr.contacts
    if forces and cf.n:
        fn = cf.normal_force
        big = float(np.max(np.abs(fn))) if fn.size else 0.0
        if big > 0:
            i, j = cf.pairs[:, 0], cf.pairs[:, 1]
            a = pos[i]
            b = np.where((j >= 0)[:, None], pos[np.maximum(j, 0)], cf.point)
            segs = np.stack([a, b], axis=1)
            lw = max_width * np.abs(fn) / big
            keep = lw > 0.02
            ax.add_collection(LineCollection(segs[keep], linewidths=lw[keep], colors="#c0392b"))
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")
    ax.set_title(title or f"t = {fr.t:.4g} s, {cf.n} contacts")
    if path is not None:
        fig.savefig(Path(path))
        if own:
            plt.close(fig)
    return fig


__all__ = ["render_frame"]
