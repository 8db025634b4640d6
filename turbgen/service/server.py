"""Running `turbgen serve`: the service's own dask cluster and the HTTP server (uvicorn) with its limits."""

from __future__ import annotations


def service_cluster(workers: int):
    """The dask cluster of a server without --scheduler: ``workers`` threads of this process, no listening socket.

    Threads, not processes: a killed server leaves no orphan worker writing into its root. The scheduler and the
    workers talk over inproc://; dask starts an HTTP server on each (health, /json/identity.json, /metrics, which
    answer without the server's Host check or token) and has no option to leave them off, so they are stopped
    right after the start: the server then listens on its own port only.

    Parameters
    ----------
    workers : int
        Runs computed at once.

    Returns
    -------
    distributed.LocalCluster
        Started; close it.
    """
    from turbgen.runs.local_cluster import loopback_cluster

    cluster = loopback_cluster(1, workers, processes=False)
    try:
        cluster.sync(_stop_http_servers, cluster)
    except BaseException:
        cluster.close()
        raise
    return cluster


async def _stop_http_servers(cluster) -> None:
    """Stop listening on the HTTP servers of the scheduler and the workers of the in-process ``cluster`` (on its
    event loop; the nodes' own close stops them again, which does nothing)."""
    for node in (cluster.scheduler, *cluster.workers.values()):
        server = getattr(node, "http_server", None)
        if server is not None:
            server.stop()


def run_server(app, host: str, port: int) -> None:
    """Serve ``app`` on ``host``:``port`` until interrupted (uvicorn).

    Parameters
    ----------
    app : fastapi.FastAPI
        The application (:func:`turbgen.service.app.create_app`).
    host : str
        Address to bind.
    port : int
        TCP port.
    """
    import uvicorn

    uvicorn.run(app, host=host, port=port, log_level="warning")
