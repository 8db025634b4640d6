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


def listening_socket(host: str, port: int):
    """A socket bound to ``host``:``port`` (as uvicorn binds: SO_REUSEADDR, the first address of ``host``), made
    before anything else of the server, so that a port in use is refused before the catalog directory or the cluster
    exist and before "listening on" is printed.

    Parameters
    ----------
    host : str
        Address to bind.
    port : int
        TCP port (0: a free one).

    Returns
    -------
    socket.socket
        Bound, not yet listening (uvicorn listens on it); close it if the server does not start.

    Raises
    ------
    ParameterError
        When the address cannot be bound (in use, not an address of this machine, a privileged port).
    """
    import socket

    from turbgen.errors import ParameterError

    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM,
                                                             flags=socket.AI_PASSIVE)[0]  # fmt: skip
        sock = socket.socket(family, kind, proto)
    except OSError as exc:
        raise ParameterError(f"--host {host}: not an address to listen on ({exc.strerror or exc})") from None
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
    except OSError as exc:
        sock.close()
        raise ParameterError(f"--port {port}: cannot listen on {host}:{port} ({exc.strerror or exc}; another server "
                             "there? choose another --port)") from None  # fmt: skip
    return sock


def run_server(app, sock, host: str) -> None:
    """Serve ``app`` on the bound socket ``sock`` until interrupted (uvicorn with :func:`server_config`).

    Parameters
    ----------
    app : fastapi.FastAPI
        The application (:func:`turbgen.service.app.create_app`).
    sock : socket.socket
        The socket of :func:`listening_socket`.
    host : str
        Its address (for uvicorn's configuration).
    """
    import uvicorn

    uvicorn.Server(server_config(app, host, sock.getsockname()[1])).run(sockets=[sock])


HEADER_TIMEOUT_S = 5.0  # a connection must deliver a complete request head within this (then it is closed)
KEEP_ALIVE_S = 5  # an idle keep-alive connection is closed after this
MAX_CONNECTIONS = 256  # connections and requests at once; beyond, uvicorn answers 503 at once
MAX_HEADER_BYTES = 16 * 1024  # an incomplete request head larger than this is refused (h11's buffer)


def header_timeout_protocol(header_timeout_s: float):
    """uvicorn's h11 protocol with a deadline for the request head: a connection that has not sent a complete
    request head ``header_timeout_s`` after it opened (or after its last response) is closed.

    uvicorn has a keep-alive timeout but none for a connection that sends nothing or half a request head: those were
    held for ever. The deadline is checked every ``header_timeout_s``: a
    connection whose request is being answered is left alone, one idle or stuck in a head since the last check is
    closed (so within one to two periods).

    Parameters
    ----------
    header_timeout_s : float
        The deadline [s].

    Returns
    -------
    type
        The protocol class for ``uvicorn.Config(http=...)``.
    """
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class HeaderTimeoutH11Protocol(H11Protocol):
        def connection_made(self, transport):
            super().connection_made(transport)
            self._head_timer = None
            self._arm_head_timer()

        def _arm_head_timer(self):
            self._cycle_at_arming = self.cycle
            self._head_timer = self.loop.call_later(header_timeout_s, self._head_deadline)

        def _head_deadline(self):
            answering = self.cycle is not None and not self.cycle.response_complete
            if self.cycle is self._cycle_at_arming and not answering and not self.transport.is_closing():
                self.transport.close()  # no new request head within the period, none being answered
                return
            self._arm_head_timer()

        def connection_lost(self, exc):
            if self._head_timer is not None:
                self._head_timer.cancel()
            super().connection_lost(exc)

    return HeaderTimeoutH11Protocol


def server_config(app, host: str, port: int, *, header_timeout_s: float = HEADER_TIMEOUT_S):
    """The uvicorn configuration of `turbgen serve`: the head deadline, keep-alive and connection limits.

    Parameters
    ----------
    app : fastapi.FastAPI
        The application.
    host : str
        Address to bind.
    port : int
        TCP port.
    header_timeout_s : float, optional
        Deadline for a request head [s] (:func:`header_timeout_protocol`).

    Returns
    -------
    uvicorn.Config
    """
    import uvicorn

    return uvicorn.Config(app, host=host, port=port, log_level="warning",
                          http=header_timeout_protocol(header_timeout_s), timeout_keep_alive=KEEP_ALIVE_S,
                          limit_concurrency=MAX_CONNECTIONS, h11_max_incomplete_event_size=MAX_HEADER_BYTES)
