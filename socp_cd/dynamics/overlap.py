"""Initial-overlap check: bodies interpenetrating at ``t = 0`` are reported.

A scene whose bodies already overlap is usually a modelling mistake (wrong
positions or sizes); the stepper would push them apart, injecting energy.
:func:`warn_initial_overlaps` emits one :class:`OverlapWarning` naming the
deepest overlapping pairs and their depth.  Filter it like any warning::

    import warnings
    from socp_cd.dynamics import OverlapWarning
    warnings.simplefilter("ignore", OverlapWarning)
"""
from __future__ import annotations

import warnings

import numpy as np

from .detection import Contacts, detect


class OverlapWarning(UserWarning):
    """Bodies of a scene overlap at the start of a simulation."""


def _name(scene, i: int, j: int, obstacle: int) -> tuple[str, str]:
    a = f"bodies[{i}] ({type(scene.bodies[i]).__name__})"
    if j >= 0:
        return a, f"bodies[{j}] ({type(scene.bodies[j]).__name__})"
    return a, f"obstacles[{obstacle}] ({type(scene.obstacles[obstacle]).__name__})"


def initial_overlaps(sys, tol: float) -> Contacts:
    """Contacts of ``sys`` whose gap is below ``-tol``, deepest first."""
    C = detect(sys, 0.0)
    C = C.subset(C.gap < -tol)
    return C.subset(np.argsort(C.gap, kind="stable"))


def warn_initial_overlaps(scene, sys, tol: float, show: int = 5) -> Contacts:
    """Warn (:class:`OverlapWarning`) when bodies overlap by more than ``tol``; returns the overlaps.

    The message lists the ``show`` deepest pairs (one line per body pair) with
    their overlap depth ``-gap``.
    """
    C = initial_overlaps(sys, tol)
    if C.n == 0:
        return C
    seen, lines = set(), []
    for c in range(C.n):
        key = (int(C.i[c]), int(C.j[c]), int(C.obstacle[c]))
        if key in seen:
            continue
        seen.add(key)
        if len(lines) < show:
            a, b = _name(scene, *key)
            lines.append(f"{a} and {b} overlap by {-C.gap[c]:.3g}")
    more = len(seen) - len(lines)
    msg = "; ".join(lines) + (f"; and {more} more pair(s)" if more > 0 else "")
    warnings.warn(f"initial overlap: {msg}", OverlapWarning, stacklevel=4)
    return C


__all__ = ["OverlapWarning", "initial_overlaps", "warn_initial_overlaps"]
