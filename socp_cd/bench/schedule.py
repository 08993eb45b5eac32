"""The order in which a comparison runs our solvers and a peer's: interleaved by chunks.

A benchmark that times every problem with our solvers and then every problem with the peer's
(Siconos, in its own worker process) measures the two sides tens of minutes apart, and a
slow or fast spell of the machine then falls on one side only.  Validation runs showed such
spells: issue #10's benchmark of session 27, our side first and Siconos ~30 min later, had
stretches of our pass at ×1.05–1.43 and ×0.77–1.00 of an earlier run's times while the
Siconos side stayed within ×0.93–1.08.  Interleaving the two sides by chunks of problems
puts them within minutes of each other; alternating which side goes first leaves neither
always right after the other's work.  Used by :func:`socp_cd.bench.campaign.run_tasks` and
``validation/newton_vs_siconos.py``.
"""
from __future__ import annotations

#: problems per chunk (each chunk: both sides, before the next chunk)
CHUNK = 10

#: the two sides, in the order of the first chunk
SIDES = ("ours", "peer")


def interleaved(n: int, size: int = CHUNK) -> list[tuple[list[int], str]]:
    """Problems ``0 … n-1`` in consecutive chunks of ``size``, each with the side that goes
    first on it: ``"ours"`` and ``"peer"`` in turn, starting with ``"ours"``.

    Parameters
    ----------
    n : int
        Number of problems (0: no chunk).
    size : int
        Problems per chunk, at least 1.

    Returns
    -------
    list of (list of int, str)

    Raises
    ------
    ValueError
        ``size < 1`` or ``n < 0``.
    """
    if size < 1:
        raise ValueError(f"chunk size must be at least 1, got {size}")
    if n < 0:
        raise ValueError(f"number of problems must be at least 0, got {n}")
    return [(list(range(i, min(i + size, n))), SIDES[(i // size) % 2])
            for i in range(0, n, size)]


__all__ = ["CHUNK", "SIDES", "interleaved"]
