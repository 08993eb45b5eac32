"""Import every backend module so that it registers itself.

``cvxpy_backend`` and ``proxsuite_backend`` register even when their library
is missing and then raise a clear error when called.
"""
from . import clarabel_backend, cvxpy_backend, nsgs, proxsuite_backend  # noqa: F401
from . import newton  # noqa: F401
