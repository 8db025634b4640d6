"""The LocalCluster turbgen starts itself (sweeps, out-of-core runs, `turbgen serve`) listens on loopback only."""

from __future__ import annotations

import psutil
import pytest
from distributed import Client

from turbgen.runs.local_cluster import loopback_cluster


def _listening(pids) -> set[tuple[str, int]]:
    """(address, port) of the TCP sockets listening in these processes."""
    return {(c.laddr.ip, c.laddr.port) for c in psutil.net_connections("tcp")
            if c.status == psutil.CONN_LISTEN and c.pid in pids}


@pytest.mark.parametrize("processes", [False, True])
def test_every_socket_of_the_cluster_is_on_loopback(processes):
    """dask starts an HTTP server in the scheduler and in every worker even without a dashboard; with in-process
    workers (the service's cluster) the scheduler's listened on 0.0.0.0:8787 before (network-readable
    /json/identity.json, /metrics). Now all of them, and the scheduler and workers, bind 127.0.0.1."""
    me = psutil.Process()
    before = _listening({me.pid})
    with loopback_cluster(2, 1, processes) as cluster, Client(cluster) as client:
        assert client.submit(sum, [1, 2]).result() == 3
        pids = {me.pid} | {p.pid for p in me.children(recursive=True)}
        opened = _listening(pids) - before
    assert opened, "the cluster opened no socket: the check would prove nothing"
    assert {ip for ip, _ in opened} == {"127.0.0.1"}, opened
