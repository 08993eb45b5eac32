"""Reading and writing frictional contact problem files.

Two formats are read, detected from the file content (never from the
extension: some Siconos text files are named ``*.hdf5.dat``):

* FCLib HDF5 (magic bytes ``\\x89HDF``), see :mod:`socp_cd.io.fclib`;
* Siconos numerics text files, see :mod:`socp_cd.io.siconos_dat`.

Problems are written in FCLib HDF5 by :func:`write_fclib`.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputTooLargeError, ProblemFormatError
from .fclib import read_fclib, write_fclib
from .paths import as_path, source_name
from .siconos_dat import read_siconos_dat

#: Signature at the start of every HDF5 file without user block.
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


def detect_format(path) -> str:
    """Return ``"fclib-hdf5"`` or ``"siconos-dat"`` from the content of *path*.

    Raises
    ------
    ProblemFormatError
        If the file does not exist, is not a regular file or is empty.
    """
    p = as_path(path)
    source = source_name(path)
    if not p.exists():
        raise ProblemFormatError("file", "does not exist", source)
    if not p.is_file():
        raise ProblemFormatError("file", "is not a regular file", source)
    try:
        with open(p, "rb") as fh:
            head = fh.read(len(HDF5_MAGIC))
    except OSError as exc:
        raise ProblemFormatError("file", f"cannot be read ({exc})", source) from None
    if not head:
        raise ProblemFormatError("file", "is empty", source)
    if head[:4] == HDF5_MAGIC[:4]:
        return "fclib-hdf5"
    try:  # HDF5 with a user block: signature at 512, 1024, ...
        import h5py
        if h5py.is_hdf5(source):
            return "fclib-hdf5"
    except Exception:  # noqa: BLE001 - any failure here means "not HDF5"
        pass
    return "siconos-dat"


def read_problem(path, *, global_problem: bool | None = None):
    """Read a frictional contact problem file, detecting its format.

    Parameters
    ----------
    path : str or path-like
        FCLib HDF5 file or Siconos text file.
    global_problem : bool, optional
        For Siconos text files only: force the global layout (default: file
        names starting with ``GFC`` are global problems).

    Returns
    -------
    FrictionContactProblem or GlobalFrictionContactProblem
        ``source`` is *path*, ``name`` the file name; ``solution`` and
        ``guesses`` are filled when the file stores them.

    Raises
    ------
    InvalidArgumentError
        *path* is not a path (``None``, a number, non-UTF-8 bytes).
    ProblemFormatError
        Missing, empty, truncated or malformed file; the message names the
        file and the field.  :class:`~socp_cd.errors.InputTooLargeError` (a
        subclass) when reading runs out of memory.
    InvalidProblemError
        Inconsistent data (NaN/Inf, negative mu, ...), also naming the file.
    """
    fmt = detect_format(path)
    path = source_name(path)
    try:
        if fmt == "fclib-hdf5":
            return read_fclib(path)
        return read_siconos_dat(path, global_problem=global_problem)
    except MemoryError as exc:
        if isinstance(exc, InputTooLargeError):
            raise
        raise InputTooLargeError("file", "does not fit in the memory available for reading it "
                                         f"({Path(path).stat().st_size} bytes on disk)",
                                 str(path)) from None


__all__ = ["read_problem", "as_path", "write_fclib", "detect_format", "read_fclib", "read_siconos_dat",
           "HDF5_MAGIC"]
