"""The extreme cases of the stability suite and their problem builder (no campaign import).

Besides problems at the edges of the data range, the suite holds copies of
the default manufactured problem that must get the same answer
(:mod:`socp_cd.bench.transforms`): other units (``q`` and ``W, q`` times
``1e±8``), renumbered contacts, duplicated contacts.

:mod:`socp_cd.bench.campaign` rebuilds a referenced extreme problem inside a
worker through :func:`build`; :mod:`socp_cd.bench.extremes` runs the suite.
"""
from __future__ import annotations

import numpy as np

from ..data import shared_problems_dir
from ..errors import UnsupportedError
from ..io import read_problem
from ..problem import FrictionContactProblem
from .generators import manufactured
from .transforms import duplicated, permuted, rescaled

#: name -> (description, keyword arguments of :func:`manufactured`).
CASES = {
    "mu=0": ("frictionless (mu = 0)", dict(mu=0.0)),
    "mu=1e-8": ("almost frictionless (mu = 1e-8)", dict(mu=1e-8)),
    "mu=10": ("high friction (mu = 10)", dict(mu=10.0)),
    "mu=1e3": ("extreme friction (mu = 1e3)", dict(mu=1e3)),
    "mass_ratio=1e6": ("body masses spanning 1 .. 1e6", dict(mass_ratio=1e6)),
    "redundant": ("4 contacts per body: rank-deficient W",
                  dict(structure="redundant", bodies_per_contact=0.25)),
    "badly_scaled": ("W entries spanning 1e-6 .. 1e6, q scaled by 1e4",
                     dict(contact_scale=1e6, q_scale=1e4)),
    "grazing": ("70% grazing contacts (r = 0 and u = 0)", dict(mix=(0.1, 0.1, 0.1, 0.7))),
    "all_grazing": ("every contact grazing: q = 0, solution r = 0", dict(mix=(0, 0, 0, 1))),
    "default": ("the default problem (mu = 0.3, mass ratio 10): base of the copies below", dict()),
    "q*1e8": ("q × 1e8: impulses and velocities in other units", dict(transform=("rescaled", 1.0, 1e8))),
    "q*1e-8": ("q × 1e-8", dict(transform=("rescaled", 1.0, 1e-8))),
    "Wq*1e8": ("W and q × 1e8: velocities in other units, same impulses",
               dict(transform=("rescaled", 1e8, 1e8))),
    "Wq*1e-8": ("W and q × 1e-8", dict(transform=("rescaled", 1e-8, 1e-8))),
    "permuted": ("contacts renumbered at random", dict(transform=("permuted",))),
    "duplicated": ("every 3rd contact twice (rank-deficient W, same u)",
                   dict(transform=("duplicated",))),
    "zero_contacts": ("no contact at all (must be rejected)", None),
    "large": ("10^4 contacts", dict()),
}


#: cases that are copies of ``"default"`` (other units, order, duplicates): same answer expected
COPIES = ("q*1e8", "q*1e-8", "Wq*1e8", "Wq*1e-8", "permuted", "duplicated")

#: shared problems whose copies the suite also runs (issue 14: Clarabel claimed a false
#: success on the first at W, q x 1e8, and failed or stalled on the second at q x 1e+-8)
SHARED_BASES = ("fc2d_granularflowonwall_00667_00000.dat", "FrictionContactProblem00237.dat")


def _shared_base(source: str):
    d = shared_problems_dir()
    if d is None or not (d / source).is_file():
        raise UnsupportedError(f"shared problem {source!r} not found (see socp_cd.data)")
    return read_problem(d / source)


def build(case: str, n_contacts: int = 50, dim: int = 3, seed: int = 0,
          source: str | None = None) -> FrictionContactProblem:
    """Build the problem of an extreme case (see :data:`CASES`).

    With ``source`` (a shared problem's file name), ``case`` must be
    ``"default"`` or one of :data:`COPIES`: that copy of the shared problem
    (``n_contacts`` and ``dim`` are then the file's).

    Raises
    ------
    InvalidProblemError
        For ``"zero_contacts"``, from the problem constructor itself.
    """
    if case not in CASES:
        raise ValueError(f"unknown extreme case {case!r}; known: {sorted(CASES)}")
    kw = CASES[case][1]
    if source is not None and case not in ("default",) + COPIES:
        raise ValueError(f"case {case!r} is not a copy: it cannot be applied to {source!r}")
    if kw is None:
        return FrictionContactProblem(np.zeros((0, 0)), np.zeros(0), np.zeros(0), dim,
                                      name="zero_contacts")
    kw = dict(kw)
    mu = kw.pop("mu", 0.3)
    transform = kw.pop("transform", None)
    if source is not None:
        p = _shared_base(source)
    else:
        p = manufactured(n_contacts, dim, mu, seed=seed, name=f"extreme[{case}]-{dim}d-{n_contacts}",
                         **kw)
    if transform is None:
        return p
    kind = transform[0]
    if kind == "rescaled":
        return rescaled(p, *transform[1:])[0]
    if kind == "permuted":
        return permuted(p, np.random.default_rng(seed).permutation(p.n_contacts))[0]
    return duplicated(p, np.arange(0, p.n_contacts, 3))[0]


__all__ = ["CASES", "COPIES", "SHARED_BASES", "build"]
