"""Locate the shared collection of real frictional contact problems.

The collection (31 problems from Siconos test data and FCLib) lives outside
the package, in ``<repo>/../shared/data/problems``, with a ``MANIFEST.tsv``
(in that directory or its parent) listing format, kind, dimension, number of
contacts and friction coefficients.  The environment variable
``SOCP_CD_DATA`` overrides the location of the problems directory.
"""
from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from .errors import ProblemFormatError

#: Environment variable naming the problems directory.
DATA_ENV = "SOCP_CD_DATA"


def shared_problems_dir() -> Optional[Path]:
    """Directory of the shared problems, or None when it cannot be found.

    Looks at ``$SOCP_CD_DATA`` first, then at ``<repo>/../shared/data/problems``
    relative to the installed package (``<repo>/socp_cd/data.py``).
    """
    env = os.environ.get(DATA_ENV)
    if env:
        p = Path(env).expanduser()
        return p if p.is_dir() else None
    repo = Path(__file__).resolve().parent.parent
    p = repo.parent / "shared" / "data" / "problems"
    return p if p.is_dir() else None


@dataclass(frozen=True)
class SharedProblem:
    """One MANIFEST entry.  Usable wherever a path is expected (``os.fspath``).

    Attributes
    ----------
    path : Path
    file : str
        File name.
    format : str
        ``"fclib-hdf5"`` or ``"siconos-dat (dense|sparse-block|csparse)"``.
    kind : str
        ``"local"`` or ``"global"``.
    dim : int
    contacts : int
    mu : tuple of float or None
        (min, max) friction coefficient when the manifest gives it.
    has_solution : bool
        The file stores a reference solution.
    """

    path: Path
    file: str
    format: str
    kind: str
    dim: int
    contacts: int
    mu: Optional[tuple]
    has_solution: bool

    def __fspath__(self) -> str:
        return str(self.path)

    def __str__(self) -> str:
        return str(self.path)


def _manifest(directory: Path) -> Optional[Path]:
    for cand in (directory / "MANIFEST.tsv", directory.parent / "MANIFEST.tsv"):
        if cand.is_file():
            return cand
    return None


def _parse_mu(text: str):
    text = (text or "").strip()
    if not text:
        return None
    lo, _, hi = text.partition("..")
    return (float(lo), float(hi or lo))


def shared_problems(kind: Optional[str] = None, dim: Optional[int] = None) -> list:
    """List the shared problems from MANIFEST.tsv, optionally filtered.

    Parameters
    ----------
    kind : {"local", "global"}, optional
    dim : {2, 3}, optional

    Returns
    -------
    list of SharedProblem
        Sorted by file name; empty when the data directory is absent.

    Raises
    ------
    ProblemFormatError
        A manifest row lacks a column or holds a non-numeric dim/contacts/mu.
    """
    directory = shared_problems_dir()
    if directory is None:
        return []
    manifest = _manifest(directory)
    if manifest is None:
        return []
    out = []
    with open(manifest, newline="", encoding="utf-8", errors="replace") as fh:
        for line, row in enumerate(csv.DictReader(fh, delimiter="\t"), start=2):
            try:
                kind_text = row["kind"].strip()
                entry = SharedProblem(
                    path=directory / row["file"], file=row["file"], format=row["format"].strip(),
                    kind=kind_text.split()[0], dim=int(row["dim"]), contacts=int(row["contacts"]),
                    mu=_parse_mu(row.get("mu", "")), has_solution="solution" in kind_text)
            except (KeyError, ValueError, IndexError, AttributeError, TypeError) as exc:
                raise ProblemFormatError(f"line {line}", f"malformed manifest row ({type(exc).__name__}: "
                                                         f"{exc})", str(manifest)) from None
            if kind is not None and entry.kind != kind:
                continue
            if dim is not None and entry.dim != dim:
                continue
            out.append(entry)
    return sorted(out, key=lambda e: e.file)


__all__ = ["shared_problems_dir", "shared_problems", "SharedProblem", "DATA_ENV"]
