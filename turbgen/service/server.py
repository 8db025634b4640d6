"""Running `turbgen serve`: the service's own dask cluster and the HTTP server (uvicorn) with its limits."""

from __future__ import annotations


def service_cluster(workers: int):
    """The LocalCluster of a server without --scheduler: ``workers`` threads of this process (a killed server leaves
    no orphan worker writing into its root), no listening socket (dask's HTTP servers stopped at once)."""
    from turbgen.runs.local_cluster import loopback_cluster

    cluster = loopback_cluster(1, workers, processes=False)
    try:
        cluster.sync(_stop_http_servers, cluster)
    except BaseException:
        cluster.close()
        raise
    return cluster


async def _stop_http_servers(cluster) -> None:
    """Stop the HTTP servers of the in-process ``cluster``'s nodes (on its event loop)."""
    for node in (cluster.scheduler, *cluster.workers.values()):
        server = getattr(node, "http_server", None)
        if server is not None:
            server.stop()


def listening_socket(host: str, port: int):
    """A socket bound (not listening) to ``host``:``port`` as uvicorn binds, made first so a port in use is refused
    before the catalog or cluster exist; ParameterError when the address cannot be bound."""
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
    """Serve ``app`` on the bound socket ``sock`` (address ``host``) until interrupted, with :func:`server_config`."""
    import uvicorn

    uvicorn.Server(server_config(app, host, sock.getsockname()[1])).run(sockets=[sock])


HEADER_TIMEOUT_S = 5.0  # a connection must deliver a complete request head within this (then it is closed)
KEEP_ALIVE_S = 5  # an idle keep-alive connection is closed after this
MAX_CONNECTIONS = 256  # connections and requests at once; beyond, uvicorn answers 503 at once
MAX_HEADER_BYTES = 16 * 1024  # an incomplete request head larger than this is refused (h11's buffer)


def header_timeout_protocol(header_timeout_s: float):
    """uvicorn's h11 protocol class with a deadline for the request head (uvicorn has none): a connection idle or
    stuck in a head at two checks ``header_timeout_s`` [s] apart is closed."""
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
    """The ``uvicorn.Config`` of `turbgen serve`: head deadline [s], keep-alive and connection limits."""
    import uvicorn

    return uvicorn.Config(app, host=host, port=port, log_level="warning",
                          http=header_timeout_protocol(header_timeout_s), timeout_keep_alive=KEEP_ALIVE_S,
                          limit_concurrency=MAX_CONNECTIONS, h11_max_incomplete_event_size=MAX_HEADER_BYTES)
