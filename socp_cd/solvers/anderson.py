"""Type-II Anderson acceleration of a fixed-point map ``x -> T(x)``, with restart safeguard.

Used by the De Saxcé outer loop (:mod:`socp_cd.solvers.desaxce`) on the shift
vector.  With the last ``memory + 1`` iterates ``x_j`` and residuals
``g_j = T(x_j) - x_j``, the step is ``x + g - (ΔX + ΔG) γ`` where ``γ``
minimizes ``||g - ΔG γ||`` (Tikhonov-regularized normal equations).  The
accelerated point is kept only while ``||g||`` decreases; otherwise the memory
is cleared (a "restart") and a plain step ``T(x)`` is taken.
"""
from __future__ import annotations

import numpy as np


class Anderson:
    """Type-II Anderson acceleration with restart safeguard.

    Parameters
    ----------
    memory : int
        Number of differences kept.
    reg : float
        Tikhonov regularization, relative to ``trace(ΔGᵀΔG)``.
    """

    def __init__(self, memory: int, reg: float = 1e-12):
        self.memory = memory
        self.reg = reg
        self.X, self.G = [], []
        self.last_res = np.inf
        self.restarts = 0

    def step(self, x: np.ndarray, Tx: np.ndarray) -> np.ndarray:
        """Next iterate from ``x`` and ``T(x)``."""
        g = Tx - x
        res = float(np.linalg.norm(g))
        if res > self.last_res and self.X:  # safeguard: the extrapolation did not help
            self.X, self.G = [], []
            self.restarts += 1
        self.last_res = res
        self.X.append(x.copy())
        self.G.append(g.copy())
        if len(self.X) > self.memory + 1:
            self.X.pop(0)
            self.G.pop(0)
        if len(self.X) < 2:
            return Tx
        dX = np.diff(np.array(self.X), axis=0).T
        dG = np.diff(np.array(self.G), axis=0).T
        A = dG.T @ dG
        A += self.reg * max(np.trace(A), 1e-300) * np.eye(A.shape[0])
        try:
            gamma = np.linalg.solve(A, dG.T @ g)
        except np.linalg.LinAlgError:
            self.X, self.G = [self.X[-1]], [self.G[-1]]
            return Tx
        return x + g - (dX + dG) @ gamma


__all__ = ["Anderson"]
