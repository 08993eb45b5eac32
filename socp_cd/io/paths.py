"""Validation of the file-path arguments of the readers."""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import InvalidArgumentError


def as_path(path) -> Path:
    """Check that *path* names a file: ``str``, ``os.PathLike`` or UTF-8 ``bytes``.

    Raises
    ------
    InvalidArgumentError
        Any other type (``None``, a number...), bytes that are not UTF-8, or a
        string holding a NUL character.
    """
    if isinstance(path, (bytes, bytearray)):
        try:
            path = bytes(path).decode("utf-8")
        except UnicodeDecodeError:
            raise InvalidArgumentError("path", f"bytes path {bytes(path)[:60]!r} is not valid UTF-8; "
                                               "pass a str") from None
    try:
        path = os.fspath(path)
    except TypeError:
        raise InvalidArgumentError("path", f"expected a file path (str or os.PathLike), got "
                                           f"{type(path).__name__}") from None
    if isinstance(path, bytes):  # os.PathLike returning bytes
        return as_path(path)
    if not path or "\0" in path:
        raise InvalidArgumentError("path", f"{path!r} is not a file path")
    return Path(path)



def source_name(path) -> str:
    """The name of *path* used in messages (``str(path)``), after :func:`as_path` checked it."""
    checked = as_path(path)
    return str(path) if isinstance(path, (str, os.PathLike)) else str(checked)


__all__ = ["as_path", "source_name"]
