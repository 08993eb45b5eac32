"""Exception types of socp_cd.

Every error raised on bad input derives from :class:`SocpCdError`, so user code
can catch one type.  Messages name the *source* (file or argument), the *field*
(e.g. ``"W"``, ``"/fclib_local/vectors/q"``) and the *reason*.
"""
from __future__ import annotations


#: Longest reason kept in a message (input echoed by a library can be megabytes).
MAX_REASON = 500


def clip(text: str, limit: int = MAX_REASON) -> str:
    """*text* cut to *limit* characters, saying how long it was."""
    text = str(text)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


class SocpCdError(Exception):
    """Base class of every socp_cd exception."""


class InvalidProblemError(SocpCdError, ValueError):
    """A problem's data are inconsistent (shapes, NaN/Inf, negative mu, dim...).

    Parameters
    ----------
    field : str
        Name of the offending field (``"W"``, ``"q"``, ``"mu"``, ``"dim"``...).
    reason : str
        Human-readable explanation.
    source : str, optional
        File the data came from, when known.
    """

    def __init__(self, field: str, reason: str, source: str | None = None):
        self.field = field
        self.reason = reason = clip(reason)
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}field '{field}': {reason}")


class ProblemFormatError(InvalidProblemError):
    """A file is malformed, truncated, or misses a required group/field."""


class InvalidArgumentError(SocpCdError, TypeError, ValueError):
    """A function argument of the wrong type or value (not problem data).

    Parameters
    ----------
    argument : str
        Name of the argument (``"path"``, ``"tol"``...).
    reason : str
        Human-readable explanation.
    """

    def __init__(self, argument: str, reason: str):
        self.argument = argument
        self.reason = reason = clip(reason)
        super().__init__(f"argument '{argument}': {reason}")


class InputTooLargeError(ProblemFormatError, MemoryError):
    """A file whose content does not fit in the memory available for reading it."""


class UnsupportedError(SocpCdError, ValueError):
    """A solver/formulation combination, or an option, that is not available."""


class SolverError(SocpCdError, RuntimeError):
    """A backend failed in a way that is not a normal solver outcome."""


__all__ = [
    "SocpCdError",
    "InvalidProblemError",
    "ProblemFormatError",
    "InvalidArgumentError",
    "InputTooLargeError",
    "UnsupportedError",
    "SolverError",
]
