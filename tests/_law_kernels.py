"""The kernels of the equations of the law (``kernels/newton_*.py``' ``*_blocks``) as the
tests call them: one call with fresh outputs, and the check of their Jacobian blocks
against central differences, shared by the natural-map and Fischer–Burmeister tests."""
from __future__ import annotations

import numpy as np


def run_blocks(kernel, r, u, mu, rho, dim, jac=True):
    """``(||F||, F, Dr, Du, branch)`` of ``kernel`` (one parameter per contact: ``rho``)."""
    nc = mu.shape[0]
    F = np.empty(nc * dim)
    Dr, Du = np.empty((nc, dim, dim)), np.empty((nc, dim, dim))
    br = np.empty(nc, np.int64)
    nF = kernel(r, u, mu, rho, rho, dim, jac, F, Dr, Du, br)
    return nF, F, Dr, Du, br


def assert_blocks_are_central_differences(kernel, r, u, mu, rho, dim, Dr, Du):
    """The one-contact blocks ``Dr``, ``Du`` equal central differences of ``F`` (step
    ``1e-7`` of the largest entry; tolerance 1e-6, ``Du``'s times ``max(1, rho)``)."""
    h = 1e-7 * max(1.0, np.abs(np.r_[r, u]).max())
    for j in range(dim):
        e = np.zeros(dim)
        e[j] = h
        fd_r = (run_blocks(kernel, r + e, u, mu, rho, dim, False)[1]
                - run_blocks(kernel, r - e, u, mu, rho, dim, False)[1]) / (2 * h)
        fd_u = (run_blocks(kernel, r, u + e, mu, rho, dim, False)[1]
                - run_blocks(kernel, r, u - e, mu, rho, dim, False)[1]) / (2 * h)
        np.testing.assert_allclose(Dr[0, :, j], fd_r, atol=1e-6)
        np.testing.assert_allclose(Du[0, :, j], fd_u, atol=1e-6 * max(1.0, rho[0]))
