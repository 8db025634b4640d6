"""`turbgen serve`'s application in this process (uvicorn in a thread, dask threads), for tests that replace a
part of it (a slow fake validation) or inspect its state. Loopback only; always stopped."""

from __future__ import annotations

import threading
import time

import uvicorn

from service_server import Server, free_port


class InProcessServer:
    """create_app over ``root`` on a loopback port with the service's own dask cluster; ``call`` and ``wait`` as
    :class:`service_server.Server`."""

    call = Server.call
    wait = Server.wait

    def __init__(self, root, **options):
        from distributed import Client

        from turbgen.service.app import create_app
        from turbgen.service.server import server_config, service_cluster

        self.root = root
        self.cluster = service_cluster(1)
        self.client = Client(self.cluster)
        options = {"memory_budget": 2**30, "max_queue": 8, **options}
        self.app = create_app(root, self.client, **options)
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.server = uvicorn.Server(server_config(self.app, "127.0.0.1", self.port))  # as `turbgen serve`
        self.thread = threading.Thread(target=self.server.run, daemon=True)
        self.thread.start()
        deadline = time.monotonic() + 30
        while not self.server.started:
            if time.monotonic() > deadline or not self.thread.is_alive():
                self.stop()
                raise RuntimeError("the in-process server did not start")
            time.sleep(0.05)

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)
        self.client.close()
        self.cluster.close()
