"""Running `turbgen serve`: the service's own dask cluster and the HTTP server (uvicorn) with its limits."""

from __future__ import annotations


def service_cluster(workers: int):
    """The dask cluster of a server without --scheduler: ``workers`` threads of this process, loopback only.

    Threads, not processes: a killed server leaves no orphan worker writing into its root.

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

    return loopback_cluster(1, workers, processes=False)


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
