"""Problem references of a benchmark: files, or members of generated families.

A :class:`ProblemRef` is small and picklable (it crosses process boundaries);
:func:`load_problem` reads or rebuilds the problem in whichever process needs
it, through the builder registry :data:`BUILDERS`.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from ..data import shared_problems_dir
from ..errors import UnsupportedError
from ..io import read_problem
from .extreme_cases import build
from .generators import generate

PROBLEM_SUFFIXES = (".hdf5", ".h5", ".dat")

FAMILY_PATTERNS = (
    (r"^Rover", "Rover"),
    (r"^Capsules", "Capsules"),
    (r"^(BoxesStack|Box_Stacks|KaplasTower|OneObject|LMGC_100_PR)", "stacks"),
    (r"^(FC3D_Example|FrictionContact3D_|Confeti|NESpheres)", "small3d"),
    (r"^(FC2D|fc2d|FrictionContactProblem)", "2d"),
    (r"^(GFC3D|CubeH8|LMGC_Global)", "global"),
)


def file_family(name: str) -> str:
    """Family of a problem file (see :data:`FAMILY_PATTERNS`; else its first word)."""
    for pat, fam in FAMILY_PATTERNS:
        if re.search(pat, name):
            return fam
    return re.split(r"[-_.0-9]", name, maxsplit=1)[0] or name


@dataclass(frozen=True)
class ProblemRef:
    """A loadable problem: a file, or a member of a generated family.

    Attributes
    ----------
    name : str
        Identifier used in records.
    family : str
    path : str, optional
        Problem file (FCLib HDF5 or Siconos ``.dat``).
    generator : str, optional
        JSON of the keyword arguments of the builder.
    builder : str
        Name of the builder in :data:`BUILDERS` (default ``"generate"``:
        :func:`socp_cd.bench.generators.generate`; ``"extremes"``:
        :func:`socp_cd.bench.extreme_cases.build`).
    """

    name: str
    family: str
    path: str | None = None
    generator: str | None = None
    builder: str = "generate"

    def load(self):
        """Read or build the problem (cached per process)."""
        return load_problem(self)


#: builder name -> function(**kwargs) -> problem (see :func:`register_builder`)
BUILDERS = {"generate": generate, "extremes": build}


def register_builder(name: str, func) -> None:
    """Make ``func(**kwargs)`` available to :class:`ProblemRef` as ``builder=name``."""
    BUILDERS[name] = func


@lru_cache(maxsize=8)
def load_problem(ref: ProblemRef):
    """Read (file) or build (builder + JSON arguments) the problem of ``ref``, cached per process."""
    if ref.path is not None:
        return read_problem(ref.path)
    if ref.builder not in BUILDERS:
        raise UnsupportedError(f"problem {ref.name!r}: unknown builder {ref.builder!r}; "
                               f"known: {sorted(BUILDERS)}")
    return BUILDERS[ref.builder](**json.loads(ref.generator))


def file_problems(paths) -> list[ProblemRef]:
    """Problem refs for files and directories (directories: every problem file inside)."""
    out = []
    for p in paths:
        p = Path(p)
        files = sorted(f for f in p.iterdir() if f.suffix in PROBLEM_SUFFIXES) if p.is_dir() else [p]
        out += [ProblemRef(f.name, file_family(f.name), path=str(f)) for f in files]
    return out


def generated_problems(family: str = "manufactured", sizes=(1, 10, 100), dims=(2, 3),
                       seeds=(0,), **params) -> list[ProblemRef]:
    """Problem refs for a generated family over sizes × dims × seeds."""
    out = []
    for dim in dims:
        for n in sizes:
            for seed in seeds:
                kw = dict(family=family, n_contacts=int(n), dim=int(dim), seed=int(seed), **params)
                out.append(ProblemRef(f"{family}-{dim}d-{n}-s{seed}", f"{family}-{dim}d",
                                      generator=json.dumps(kw, sort_keys=True)))
    return out


def shared_problems() -> list[ProblemRef]:
    """The shared real problems (``socp_cd.data.shared_problems_dir()``); [] if absent."""
    d = shared_problems_dir()
    return file_problems([d]) if d is not None and d.is_dir() else []


__all__ = ["ProblemRef", "BUILDERS", "register_builder", "load_problem", "file_problems",
           "generated_problems", "shared_problems", "file_family", "PROBLEM_SUFFIXES"]
