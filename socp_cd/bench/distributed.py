"""Run campaign tasks on dask.distributed, one dask task per run.

Each dask task calls ``run_one`` (the caller passes
:func:`socp_cd.bench.campaign.run_one`), which loads (or
regenerates, deterministically from its seed) the problem inside the worker
and isolates the solve with the same time limit as a serial campaign, so the
records agree with a serial run except for the timing columns.
"""
from __future__ import annotations

from .progress import Progress


def _client(spec, n_workers: int = 2, threads: bool = False):
    """``(client, cluster, owned)`` from ``True`` (LocalCluster), an address, or a Client.

    ``owned``: the client (and cluster, if any) was created here and must be closed.
    """
    import dask
    from dask.distributed import Client, LocalCluster
    if isinstance(spec, Client):
        return spec, None, False
    if isinstance(spec, str):
        return Client(spec), None, True
    # non-daemonic worker processes may fork the per-run child that enforces the time limit
    with dask.config.set({"distributed.worker.daemon": False}):
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=not threads,
                               dashboard_address=None)
    return Client(cluster), cluster, True


def run_tasks_dask(tasks, run_one, dask=True, *, n_workers: int = 2, threads: bool = False,
                   verbose: bool = False) -> list[dict]:
    """Run :class:`~socp_cd.bench.tasks.RunTask` objects on dask; records in task order.

    Parameters
    ----------
    tasks : list of RunTask
    run_one : callable
        ``run_one(task) -> record`` (:func:`socp_cd.bench.campaign.run_one`).
    dask : True, str or distributed.Client
        ``True``: a LocalCluster with ``n_workers`` workers (processes unless
        ``threads``); a string: scheduler address; a Client: used as is.
    n_workers : int
    threads : bool
        Thread-based LocalCluster (solves are still isolated per run).
    verbose : bool
    """
    client, cluster, owned = _client(dask, n_workers, threads)
    try:
        futures = client.map(run_one, list(tasks), pure=False)
        records = client.gather(futures)
    finally:
        if owned:
            client.close()
        if cluster is not None:
            cluster.close()
    progress = Progress(len(records), verbose)
    for rec in records:
        progress.update(rec)
    progress.close()
    return list(records)


__all__ = ["run_tasks_dask"]
