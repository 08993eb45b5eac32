"""Small problems shared by several test modules."""
from __future__ import annotations

import numpy as np

from socp_cd import FrictionContactProblem


def coupled_pair() -> FrictionContactProblem:
    """Two strongly coupled 3D contacts (``W_03 = 0.9995``, nnz(W) = 36): NSGS converges
    linearly and slowly (hundreds of sweeps to 1e-10), plain Newton in a few steps."""
    m = 6
    W = np.full((m, m), 1e-4) + np.eye(m) * (1 - 1e-4)
    W[0, 3] = W[3, 0] = 0.9995
    q = np.zeros(m)
    q[0::3], q[1::3] = -1.0, 0.05
    return FrictionContactProblem(W, q, 0.3, 3)
