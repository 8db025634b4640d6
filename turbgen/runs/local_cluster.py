"""The dask LocalCluster turbgen starts itself (sweeps, out-of-core runs, `turbgen serve`): loopback only, no dashboard.

dask's HTTP servers (/metrics etc., no token) would otherwise listen on every interface: here all bind 127.0.0.1."""

from __future__ import annotations

import logging

LOOPBACK = "127.0.0.1"


def loopback_cluster(n_workers: int, threads_per_worker: int, processes: bool):
    """A quiet, started dask LocalCluster of ``n_workers`` x ``threads_per_worker`` listening on 127.0.0.1 only
    (``processes``: worker processes, else threads of this process); close it or use it as a context manager."""
    from distributed import LocalCluster

    extra = {"host": LOOPBACK} if processes else {}  # in-process workers talk over inproc:// (no host to give)
    return LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker, processes=processes,
                        dashboard_address=f"{LOOPBACK}:0", worker_dashboard_address=f"{LOOPBACK}:0",
                        scheduler_kwargs={"dashboard": False}, silence_logs=logging.ERROR, **extra)  # fmt: skip
