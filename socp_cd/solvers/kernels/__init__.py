"""Compiled (numba) mathematics shared by the solvers, written once.

* :mod:`.cone` — per-contact cone operations (projection on ``K_mu`` and
  ``K*_mu``, an element of the generalized Jacobian of the projection, De
  Saxcé's velocity) and Siconos' relative error over a whole stacked vector.
  The readable NumPy references are :mod:`socp_cd.cones` and
  :mod:`socp_cd.residuals`; ``tests/test_kernels.py`` holds them equal.
* :mod:`.dense` — dense linear algebra without BLAS (LU with partial
  pivoting, mat-vec, ``W`` split, condensation of a small global problem).
* :mod:`.newton_ac` — the Alart–Curnier function and its generalized Jacobian (Newton solver).
* :mod:`.newton_dense` — the proximal Newton loop on a small dense ``W`` (the
  compiled twin of :func:`socp_cd.solvers.newton.prox_newton`).
* :mod:`.sparse_lu` — a left-looking sparse LU with threshold partial pivoting (the
  local Newton matrices of low fill; :class:`socp_cd.solvers.sparse_lu.NewtonLU` chooses it).
* :mod:`.entry` — a kernel's compiled entry point for fixed argument types (a
  call without numba's per-call type dispatch).

Modules here import nothing from ``socp_cd`` outside this package.
"""
