"""An evaluation set that no solver parameter was tuned on.

The 31 real problems of ``shared/`` are a sample, not the target.  This module
builds problems *around* them that a method tuned on the sample has never
seen, each with a deterministic identifier and a ``split`` label:

``real-manufactured``
    Exact solutions manufactured on every **real** operator of ``shared/``:
    keep ``W`` (local) or ``M, H, f`` (global) of the file, choose a pair
    ``(r*, u*)`` obeying the Coulomb–Signorini law contact by contact (a mix of
    separated, sticking, sliding and grazing contacts, see
    :func:`socp_cd.bench.generators.coulomb_pairs`) with a new ``mu``, and set
    ``q = u* - W r*`` (local) or ``w = u* - Hᵀ M⁻¹ (H r* + f)`` (global).
    Then ``(r*, u*)`` solves the problem exactly whatever the rank, symmetry
    or conditioning of the real operator.  ``r*`` is scaled so that
    ``||W r*|| = ||u*||``: both parts of ``u`` matter.
``real-scaled``
    Copies of seed-0 manufactured problems with ``q × λ`` and ``(W, q) × λ``
    for ``λ = 1e±6``: the law is positively homogeneous, so the exact
    solution is known (``r* λ``, ``u* λ`` for ``q × λ``; ``r*``, ``u* λ`` for
    ``(W, q) × λ``).  A solver that depends on units fails these.
``real-reframed``
    Copies of ``real-manufactured`` problems (``mu`` in :data:`REFRAMED_MUS`,
    every seed) with the contacts renumbered (``order``) or each contact's
    tangent basis turned about its normal (``frames``), both drawn at random
    from the case identifier (:func:`socp_cd.bench.transforms.reframed`).
    The law is isotropic and does not depend on the numbering, so the base
    case's exact solution, mapped, is an exact solution of the copy.  A solver
    whose outcome depends on how the same problem is written down differs on
    these from its base case.  A copy takes its base case's split.
``sim-*``
    Step problems dumped from socp_cd's own Moreau–Jean simulations (see
    :func:`simulation_collection`), written as FCLib HDF5 collections.

Split.  Every case carries ``split = "tune"`` or ``"holdout"``, decided by a
hash of its identifier (about 30 % tune).  Parameters may be chosen looking at
``tune`` cases only; results are reported on ``holdout`` (and on both, side by
side).  A ``real-reframed`` copy is in its base case's split (tuning on a copy
is tuning on the case it copies).  Simulation dumps are always ``holdout``.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator

import numpy as np

from ..errors import InvalidProblemError
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem, Solution
from . import transforms
from .generators import STATES, coulomb_pairs

#: Friction coefficients of the manufactured family.
MUS = (0.1, 0.5, 1.0, 2.0)
#: Contact-state mixes (separated, sticking, sliding, grazing), one per seed:
#: all four states, then one dominant state each (the others still present).
MIXES = {
    "mixed": (0.25, 0.35, 0.3, 0.1),
    "sticking": (0.1, 0.7, 0.1, 0.1),
    "sliding": (0.1, 0.1, 0.7, 0.1),
    "grazing": (0.1, 0.1, 0.1, 0.7),
}
#: Scale factors of the ``real-scaled`` family.
SCALES = (1e-6, 1e6)
#: Friction coefficients of the ``real-reframed`` family's base cases.
REFRAMED_MUS = (0.5, 2.0)
#: The ``real-reframed`` copies: contacts renumbered, or tangent bases turned.
REFRAMINGS = ("order", "frames")
#: Fraction of cases labelled ``tune``.
TUNE_FRACTION = 0.3


def _hash_seed(text: str) -> int:
    """A 64-bit integer from the SHA-256 of ``text`` (stable across runs and machines)."""
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


def split_of(case_id: str) -> str:
    """``"tune"`` or ``"holdout"``, a deterministic function of ``case_id``."""
    h = _hash_seed(case_id)
    return "tune" if (h % 1000) < TUNE_FRACTION * 1000 else "holdout"


def case_split(case_id: str) -> str:
    """The split of a ``real-*`` case from its identifier alone: :func:`split_of` of the
    identifier, or for a ``real-reframed`` copy of its base case's (:func:`reframed_cases`)."""
    prefix = "real-reframed/"
    if case_id.startswith(prefix):
        return split_of("real-manufactured/" + case_id[len(prefix):].rsplit("/", 1)[0])
    return split_of(case_id)


@dataclass(frozen=True)
class EvalCase:
    """One problem of the evaluation set, built on demand.

    Attributes
    ----------
    case_id : str
        Unique, stable identifier (``family/source/parameters``).
    family : str
    source : str
        The real file (or simulation) it derives from.
    split : str
        ``"tune"`` or ``"holdout"``.
    n_contacts, dim : int
    is_global : bool
    params : dict
        The generating parameters (``mu``, ``seed``, ``mix``, ``scale`` ...).
    """

    case_id: str
    family: str
    source: str
    split: str
    n_contacts: int
    dim: int
    is_global: bool
    build: Callable[[], object] = field(repr=False, compare=False)
    params: dict = field(default_factory=dict, compare=False)

    def problem(self):
        """Build the problem (with ``problem.solution`` when it is exact)."""
        p = self.build()
        p.name = self.case_id
        return p


# ----------------------------------------------------------------- manufacture
def _pairs(nc: int, dim: int, mu: float, mix, seed: int):
    rng = np.random.default_rng(seed)
    mu_arr = np.full(nc, float(mu))
    r, u, states = coulomb_pairs(nc, dim, mu_arr, mix, rng)
    return mu_arr, r, u, states


def _balance(r: np.ndarray, u: np.ndarray, Wr: np.ndarray) -> float:
    """Factor ``c`` with ``||W (c r)|| = ||u||`` (1 when either side vanishes)."""
    nw, nu = float(np.linalg.norm(Wr)), float(np.linalg.norm(u))
    return nu / nw if nw > 0 and nu > 0 else 1.0


def manufacture_local(problem: FrictionContactProblem, mu: float, mix, seed: int
                      ) -> FrictionContactProblem:
    """A local problem with ``problem.W`` and a known exact solution.

    Parameters
    ----------
    problem : FrictionContactProblem
        Supplies ``W`` and ``dim`` (its ``q`` and ``mu`` are replaced).
    mu : float
        New friction coefficient of every contact.
    mix : sequence of 4 floats
        Proportions of separated, sticking, sliding, grazing contacts.
    seed : int

    Returns
    -------
    FrictionContactProblem
        ``q = u* - W r*`` and ``solution = Solution(r*, u*)``.
    """
    nc, dim, W = problem.n_contacts, problem.dim, problem.W
    mu_arr, r, u, states = _pairs(nc, dim, mu, mix, seed)
    c = _balance(r, u, W @ r)
    r = r * c
    q = u - W @ r
    counts = {s: int(np.sum(states == i)) for i, s in enumerate(STATES)}
    return FrictionContactProblem(W, q, mu_arr, dim, info=f"manufactured on real W; states={counts}",
                                  solution=Solution(r=r, u=u))


def manufacture_global(problem: GlobalFrictionContactProblem, mu: float, mix, seed: int
                       ) -> GlobalFrictionContactProblem:
    """A global problem with the real ``M, H, f`` and a known exact solution.

    ``v* = M⁻¹ (H r* + f)`` and ``w = u* - Hᵀ v*``, so that ``(r*, u*, v*)``
    solves the problem exactly.
    """
    nc, dim = problem.n_contacts, problem.dim
    mu_arr, r, u, states = _pairs(nc, dim, mu, mix, seed)
    Hr = problem.H @ r
    c = _balance(r, u, problem.H.T @ problem.solve_M(Hr))
    r = r * c
    v = problem.solve_M(problem.H @ r + problem.f)
    w = u - problem.H.T @ v
    counts = {s: int(np.sum(states == i)) for i, s in enumerate(STATES)}
    return GlobalFrictionContactProblem(problem.M, problem.H, problem.f, w, mu_arr, dim,
                                        info=f"manufactured on real M, H, f; states={counts}",
                                        solution=Solution(r=r, u=u, v=v))


def manufacture(problem, mu: float, mix, seed: int):
    """:func:`manufacture_local` or :func:`manufacture_global` by the problem's kind."""
    if problem.is_global:
        return manufacture_global(problem, mu, mix, seed)
    return manufacture_local(problem, mu, mix, seed)


def rescaled(problem, factor: float, what: str):
    """``q × factor`` (``what="q"``) or ``(W, q) × factor`` (``what="Wq"``), solution mapped.

    Local problems go through :func:`socp_cd.bench.transforms.rescaled`.
    Global problems scale ``(f, w)`` (``what="q"``) or ``(M⁻¹, w)`` through
    ``M / factor, f / factor`` (``what="Wq"``), which scales ``W`` and ``q``
    alike.
    """
    if what not in ("q", "Wq"):
        raise InvalidProblemError("what", f"must be 'q' or 'Wq', got {what!r}")
    lam = float(factor)
    if problem.is_global:
        sol = problem.solution
        r_s = None if sol is None or sol.r is None else sol.r * (lam if what == "q" else 1.0)
        u_s = None if sol is None or sol.u is None else sol.u * lam
        if what == "q":
            M, f, w = problem.M, problem.f * lam, problem.w * lam
        else:
            M, f, w = problem.M / lam, problem.f / lam, problem.w * lam
        v_s = None if sol is None or sol.v is None else sol.v * lam
        return GlobalFrictionContactProblem(M, problem.H, f, w, problem.mu, problem.dim,
                                            info=f"{problem.info}; {what} x {lam:g}",
                                            solution=Solution(r=r_s, u=u_s, v=v_s))
    copy, _ = transforms.rescaled(problem, alpha=lam if what == "Wq" else 1.0, beta=lam)
    return copy


# ----------------------------------------------------------------- the set
def _real_files(data_dir) -> list[Path]:
    d = Path(data_dir)
    return sorted(p for p in d.iterdir() if p.is_file() and p.name != "MANIFEST.tsv")


def _real_bases(data_dir, max_contacts):
    """``(path, problem)`` of every real file, leaving out those of more than ``max_contacts``
    contacts (None: none left out)."""
    from ..io import read_problem
    for path in _real_files(data_dir):
        base = read_problem(path)
        if max_contacts is None or base.n_contacts <= max_contacts:
            yield path, base


def _draws(seeds, mus):
    """``(seed, mu, mix name, mix)`` of the manufactured cases: seed ``k`` takes the ``k``-th
    mix of :data:`MIXES` (cyclically), with every ``mu``."""
    mixes = list(MIXES.items())
    for seed in seeds:
        mix_name, mix = mixes[seed % len(mixes)]
        for mu in mus:
            yield seed, mu, mix_name, mix


def manufactured_cases(data_dir, *, mus: Iterable[float] = MUS, seeds: Iterable[int] = range(4),
                       scales: Iterable[float] = SCALES, max_contacts: int | None = None
                       ) -> list[EvalCase]:
    """The ``real-manufactured`` and ``real-scaled`` cases on every real file.

    Parameters
    ----------
    data_dir : path
        The folder of real problems (``shared/data/problems``).
    mus, seeds : iterables
        Friction coefficients and seeds; seed ``k`` uses the ``k``-th mix of
        :data:`MIXES` (cyclically).
    scales : iterable of float
        Factors of the ``real-scaled`` copies (of seed 0, ``mu = 0.5``).
    max_contacts : int, optional
        Leave out files with more contacts.

    Returns
    -------
    list of EvalCase
    """
    cases: list[EvalCase] = []
    for path, base in _real_bases(data_dir, max_contacts):
        nc, dim, glob = base.n_contacts, base.dim, base.is_global
        for seed, mu, mix_name, mix in _draws(seeds, mus):
            cid = f"real-manufactured/{path.name}/mu{mu:g}-{mix_name}-s{seed}"

            def build(base=base, mu=mu, mix=mix, seed=seed):
                return manufacture(base, mu, mix, seed)
            cases.append(EvalCase(cid, "real-manufactured", path.name, split_of(cid), nc, dim,
                                  glob, build, dict(mu=mu, mix=mix_name, seed=seed)))
        for lam in scales:
            for what in ("q", "Wq"):
                cid = f"real-scaled/{path.name}/{what}x{lam:g}"

                def build(base=base, lam=lam, what=what):
                    return rescaled(manufacture(base, 0.5, MIXES["mixed"], 0), lam, what)
                cases.append(EvalCase(cid, "real-scaled", path.name, split_of(cid), nc, dim, glob, build,
                                      dict(mu=0.5, mix="mixed", seed=0, scale=lam, what=what)))
    return cases


def reframing(n_contacts: int, how: str, seed: int):
    """The draw of :func:`reframe`: what :func:`socp_cd.bench.transforms.contact_map` takes.

    Parameters
    ----------
    n_contacts : int
    how : {"order", "frames"}
        A random permutation and no turn, or no renumbering and angles uniform
        in ``[0, 2π)``.
    seed : int

    Returns
    -------
    perm : ndarray of int (n_contacts,)
    angles : ndarray (n_contacts,)
    """
    if how not in REFRAMINGS:
        raise InvalidProblemError("how", f"must be one of {REFRAMINGS}, got {how!r}")
    rng = np.random.default_rng(seed)
    if how == "order":
        return rng.permutation(n_contacts), np.zeros(n_contacts)
    return np.arange(n_contacts), rng.uniform(0.0, 2.0 * np.pi, n_contacts)


def reframe(problem, how: str, seed: int):
    """``problem`` with its contacts renumbered or their tangent bases turned.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    how, seed
        As :func:`reframing`.

    Returns
    -------
    FrictionContactProblem or GlobalFrictionContactProblem
        :func:`socp_cd.bench.transforms.reframed`'s copy, its stored solution mapped.
    """
    perm, angles = reframing(problem.n_contacts, how, seed)
    copy, _ = transforms.reframed(problem, perm, angles)
    return copy


def reframed_cases(data_dir, *, mus: Iterable[float] = REFRAMED_MUS,
                   seeds: Iterable[int] = range(4), hows: Iterable[str] = REFRAMINGS,
                   max_contacts: int | None = None) -> list[EvalCase]:
    """The ``real-reframed`` cases: copies of ``real-manufactured`` cases written differently.

    Case ``real-reframed/<file>/<base parameters>/<how>`` is the
    ``real-manufactured/<file>/<base parameters>`` case through :func:`reframe`,
    its random draw (:func:`reframing`) seeded by a hash of its own identifier,
    ``params["draw"]``; ``params["base"]`` names the base case, whose split it
    takes.

    Parameters
    ----------
    data_dir, max_contacts
        As :func:`manufactured_cases`.
    mus, seeds : iterables
        The base cases' friction coefficients and seeds (as :func:`manufactured_cases`).
    hows : iterable of str
        Among :data:`REFRAMINGS`.

    Returns
    -------
    list of EvalCase
        Two per base case with the default ``hows``, in the order of the files, seeds,
        ``mus`` and ``hows``.
    """
    cases: list[EvalCase] = []
    for path, base in _real_bases(data_dir, max_contacts):
        nc, dim, glob = base.n_contacts, base.dim, base.is_global
        for seed, mu, mix_name, mix in _draws(seeds, mus):
            tail = f"{path.name}/mu{mu:g}-{mix_name}-s{seed}"
            for how in hows:
                cid = f"real-reframed/{tail}/{how}"
                draw = _hash_seed(cid)
                base_id = f"real-manufactured/{tail}"

                def build(base=base, mu=mu, mix=mix, seed=seed, how=how, draw=draw):
                    return reframe(manufacture(base, mu, mix, seed), how, draw)
                cases.append(EvalCase(cid, "real-reframed", path.name, case_split(cid), nc,
                                      dim, glob, build, dict(mu=mu, mix=mix_name, seed=seed,
                                                             how=how, draw=draw, base=base_id)))
    return cases


def collection_cases(folder) -> list[EvalCase]:
    """Cases read from an FCLib collection folder (``*.hdf5``), all ``holdout``."""
    from ..io import read_problem
    out = []
    for path in sorted(Path(folder).glob("*.hdf5")):
        p = read_problem(path)
        cid = f"{Path(folder).name}/{path.name}"
        out.append(EvalCase(cid, Path(folder).name, path.name, "holdout", p.n_contacts, p.dim,
                            p.is_global, (lambda p=p: p), {}))
    return out


def iter_problems(cases: Iterable[EvalCase], split: str | None = None) -> Iterator[tuple[EvalCase, object]]:
    """``(case, problem)`` pairs, optionally of one ``split`` only."""
    for c in cases:
        if split is None or c.split == split:
            yield c, c.problem()


def exact_error(problem, r) -> float:
    """Relative distance of ``u(r)`` to the manufactured ``u*`` (``r`` need not be unique; with
    strong friction ``u`` need not be either: another solution is then far from ``u*``)."""
    sol = problem.solution
    if sol is None or sol.u is None:
        return float("nan")
    u = problem.velocity(r)
    return float(np.linalg.norm(u - sol.u) / max(np.linalg.norm(sol.u), np.finfo(float).tiny))


__all__ = ["MUS", "MIXES", "SCALES", "TUNE_FRACTION", "EvalCase", "split_of", "case_split",
           "manufacture", "manufacture_local", "manufacture_global", "rescaled", "manufactured_cases",
           "REFRAMED_MUS", "REFRAMINGS", "reframing", "reframe", "reframed_cases",
           "collection_cases", "iter_problems", "exact_error"]
