"""The dask scheduler a sweep runs on (``--scheduler``): refused in one line when nothing answers as one."""

from __future__ import annotations

from turbgen.errors import ParameterError


def check_scheduler_address(address: str, timeout_s: float = 3.0, connect: bool = True) -> str:
    """``address`` if a dask scheduler answers there now ('tcp://host:port' or tls://; tcp:// assumed); ParameterError
    within ``timeout_s`` [s] otherwise (dask retries 30 s, then a traceback). ``connect`` False checks the form only."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host = port = None
    if parts.scheme not in ("tcp", "tls") or not host or not port:
        raise ParameterError(f"scheduler = {address!r} is not an address like tcp://HOST:PORT")
    if not connect:
        return address
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise ParameterError(f"scheduler = {address!r}: cannot connect ({reason}); is the scheduler running?") from None
    if not _answers_as_scheduler(address, timeout_s):
        raise ParameterError(f"scheduler = {address!r}: something listens there but no dask scheduler answered "
                             f"within {timeout_s:g} s; check the port")
    return address


def _answers_as_scheduler(address: str, timeout_s: float) -> bool:
    """True if a dask scheduler at ``address`` answers an identity request within ``timeout_s`` [s]."""
    import asyncio

    from distributed.comm import connect

    async def identity():
        comm = await connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            await comm.close()

    try:
        reply = asyncio.run(asyncio.wait_for(identity(), timeout_s))
    except Exception:  # whatever another server's bytes make of dask's framing (e.g. MemoryError
        return False  # for a reply read as a 3 EiB frame length): not a scheduler
    return isinstance(reply, dict) and reply.get("type") == "Scheduler"
