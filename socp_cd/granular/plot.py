"""Matplotlib drawing of a 2D granular state: grains and the contact force network."""
from __future__ import annotations

import numpy as np

from .state import GranularState

__all__ = ["draw_grains", "draw_force_network"]


def draw_grains(ax, state: GranularState, bodies=None, **kw):
    """Draw disks (from ``radii``) or polygons (from ``shapes``) of ``bodies``."""
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Circle, Polygon as MPoly

    idx = range(state.n_bodies) if bodies is None else np.asarray(bodies)
    patches = []
    for b in idx:
        if state.shapes is not None and state.shapes[b] is not None:
            patches.append(MPoly(state.shapes[b], closed=True))
        elif state.radii is not None:
            patches.append(Circle(state.centers[b], state.radii[b]))
    opts = dict(facecolor="0.88", edgecolor="0.55", linewidth=0.4)
    opts.update(kw)
    ax.add_collection(PatchCollection(patches, **opts))


def draw_force_network(ax, state: GranularState, max_width: float = 4.0, walls: bool = True,
                       color="crimson", threshold: float = 1e-3):
    """Draw each contact's branch segment with line width ∝ ``|f|``.

    Grain–grain contacts join the two centres; obstacle contacts join the
    grain centre to the contact point.  Forces below ``threshold`` × max are
    omitted.
    """
    from matplotlib.collections import LineCollection

    f = np.linalg.norm(state.forces, axis=1)
    if f.size == 0 or f.max() == 0:
        return
    keep = f > threshold * f.max()
    if not walls:
        keep &= state.pairs[:, 1] >= 0
    i, j = state.pairs[keep, 0], state.pairs[keep, 1]
    a = state.centers[i]
    b = np.where((j >= 0)[:, None], state.centers[np.maximum(j, 0)], state.points[keep])
    ax.add_collection(LineCollection(np.stack([a, b], axis=1), linewidths=max_width * f[keep] / f.max(),
                                     colors=color, capstyle="round"))
