"""The dask LocalCluster that turbgen starts itself (sweeps, out-of-core runs, `turbgen serve`): every socket on
loopback, no dashboard.

dask's scheduler and workers always start an HTTP server (health, metrics, and the dashboard when enabled). With
``dashboard_address=None`` the scheduler's listens on port 8787 on the host of its own address, and with in-process
workers (``processes=False``, the service) that address is ``inproc://`` with no host: the server then listened on
every interface, so a `turbgen serve` bound to 127.0.0.1 answered /json/identity.json, /info/main/workers.html and
/metrics from the network without a token. Here the scheduler and the workers, and their HTTP servers, bind
127.0.0.1 (random ports) and the dashboard is off.
"""

from __future__ import annotations

import logging

LOOPBACK = "127.0.0.1"


def loopback_cluster(n_workers: int, threads_per_worker: int, processes: bool):
    """A quiet dask LocalCluster whose scheduler, workers and their HTTP servers listen on 127.0.0.1 only.

    Parameters
    ----------
    n_workers : int
        Worker count.
    threads_per_worker : int
        Threads of each worker.
    processes : bool
        Worker processes (True) or threads of this process (False).

    Returns
    -------
    distributed.LocalCluster
        Started; close it (or use it as a context manager).
    """
    from distributed import LocalCluster

    extra = {"host": LOOPBACK} if processes else {}  # in-process workers talk over inproc:// (no host to give)
    return LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=processes,
                        dashboard_address=f"{LOOPBACK}:0", worker_dashboard_address=f"{LOOPBACK}:0",
                        scheduler_kwargs={"dashboard": False}, silence_logs=logging.ERROR, **extra)  # fmt: skip
