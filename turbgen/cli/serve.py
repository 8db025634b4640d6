"""`turbgen serve`: the HTTP job service (turbgen.service) on a dask LocalCluster or an existing scheduler."""

from __future__ import annotations

import os
from pathlib import Path

import click

from turbgen.cli.options import FiniteFloatRange
from turbgen.errors import ParameterError
from turbgen.service.limits import DEFAULT_MAX_QUEUE, DEFAULT_MEMORY_BUDGET_BYTES, is_loopback, read_token


@click.command("serve")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to bind; a non-loopback address needs --token-file.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True, help="TCP port.")
@click.option("--root", type=click.Path(file_okay=False), default="turbgen-service", show_default=True,
              help="Catalog directory (stores, exports, validation); survives restarts.")
@click.option("--workers", type=click.IntRange(1, 256), default=1, show_default=True,
              help="Runs computed at once on the local dask cluster.")
@click.option("--scheduler", help="Address of an existing dask scheduler (its workers must see --root).")
@click.option("--token-file", type=click.Path(dir_okay=False, exists=True),
              help="File whose first line is the bearer token every mutating request (POST, DELETE) must carry.")
@click.option("--memory-budget", "memory_gb", type=FiniteFloatRange(0.01, 4096), default=DEFAULT_MEMORY_BUDGET_BYTES / 2**30,
              show_default=True, help="Largest memory estimate [GiB] a submitted run may have (413 above).")  # fmt: skip
@click.option("--max-queue", type=click.IntRange(1, 100000), default=DEFAULT_MAX_QUEUE, show_default=True,
              help="Runs queued or running at once (429 with Retry-After above).")
@click.option("--stencil-cache-size", "stencil_cache_size", default="4GiB", show_default=True,
              help="Size cap of the Mann stencil cache --root/stencils (e.g. 512MiB, 20GiB); the least recently used "
                   "stencils are removed beyond it.")
def serve(host, port, root, workers, scheduler, token_file, memory_gb, max_queue, stencil_cache_size):
    """Serve turbulence fields over HTTP: POST /runs, GET /runs/<id>, zarr at /runs/<id>/store, web page at /.

    A field served is the one `turbgen mann|kaimal` writes for the same config, bit for bit."""
    try:  # the service's libraries are the `service` extra, not in the base install
        import fastapi  # noqa: F401
        import uvicorn  # noqa: F401
    except ImportError as exc:
        raise ParameterError(f'turbgen serve needs {exc.name or "the service libraries"}: '
                             'pip install "turbgen[service]"') from None
    from turbgen.resources import parse_size

    stencil_cache_bytes = parse_size(stencil_cache_size, "--stencil-cache-size")
    token = None
    if token_file:
        try:
            token = read_token(token_file)
        except (OSError, ValueError) as exc:
            raise ParameterError(str(exc)) from None
        if os.stat(token_file).st_mode & 0o077:  # a secret others on this machine can read
            click.echo(f"turbgen serve: warning: token file {token_file} is readable by other users (chmod 600 it)",
                       err=True)
    elif not is_loopback(host):
        raise ParameterError(f"--host {host} is not a loopback address: give --token-file so mutating requests "
                             "need a bearer token")  # fmt: skip
    if scheduler:  # in one line within 3 s (dask's Client retries for 30 s, then an OSError without a reason)
        from turbgen.sweep.scheduler import check_scheduler_address

        check_scheduler_address(scheduler)
    from turbgen.service.server import listening_socket, run_server, service_cluster

    sock = listening_socket(host, port)  # a port in use: refused before --root, the cluster or any output
    try:
        from dask.distributed import Client

        from turbgen.service.app import create_app

        client = Client(scheduler) if scheduler else Client(service_cluster(workers))
        app = create_app(Path(root), client, token=token, memory_budget=int(memory_gb * 2**30), max_queue=max_queue,
                         loopback_only=is_loopback(host), stencil_cache_bytes=stencil_cache_bytes,
                         own_cluster=not scheduler)  # fmt: skip
        requeued = app.state.jobs.resume()
        click.echo(f"turbgen serve: catalog {Path(root).absolute()}, {len(requeued)} interrupted run(s) re-queued, "
                   f"{len(app.state.removed)} temporary file(s) of stopped processes or evicted stencil(s) removed")
        url_host = f"[{host}]" if ":" in host else host  # an IPv6 literal in a URL needs brackets
        click.echo(f"turbgen serve: listening on http://{url_host}:{sock.getsockname()[1]}/ (API docs at /docs)")
        run_server(app, sock, host)
        client.close()
    finally:
        sock.close()
