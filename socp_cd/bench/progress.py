"""The one progress reporter of the bench (tqdm): a bar, or one line per run when verbose."""
from __future__ import annotations

from tqdm.auto import tqdm


class Progress:
    """Progress over ``n`` runs.

    Parameters
    ----------
    n : int
        Number of runs.
    verbose : bool
        Show the bar and write one line per finished run (problem, solver,
        tolerance, status, error, time); silent otherwise.
    """

    def __init__(self, n: int, verbose: bool = False):
        self.bar = tqdm(total=n, disable=not verbose, unit="run", leave=False)

    def update(self, rec: dict) -> None:
        """Count one finished run (its record)."""
        if not self.bar.disable:
            self.bar.write(f"{rec['problem'][:38]:38s} {rec['solver'][:22]:22s} "
                           f"tol={rec['tol']:.0e} {rec['status']:15s} err={rec['error']:.2e} "
                           f"t={rec['time']:.3g}s")
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


__all__ = ["Progress"]
