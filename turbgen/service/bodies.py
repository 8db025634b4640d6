"""Request bodies of `turbgen serve`: JSON only, bounded in size and nesting."""

from __future__ import annotations

import asyncio
import json

from fastapi import Request

from turbgen.service.limits import MAX_BODY_BYTES, MAX_JSON_DEPTH, LimitError, check_json_depth

BODY_TIMEOUT_S = 10.0  # a request body (at most MAX_BODY_BYTES) must arrive within this: a trickle holds no task


async def read_json(request: Request):
    """The request body parsed as JSON, at most MAX_BODY_BYTES; only ``Content-Type: application/json`` (a form or
    text/plain needs no CORS preflight, so any web page could post it). LimitError 415, 413, 408 or 422."""
    data = (await read_upload(request, ("application/json",), MAX_BODY_BYTES))[1]
    try:
        value = json.loads(data)
    except RecursionError:  # the decoder itself recurses: thousands of nested arrays
        raise LimitError(422, f"request body: arrays and objects nested deeper than {MAX_JSON_DEPTH} levels") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise LimitError(422, f"request body: not valid JSON ({' '.join(str(exc).split())})") from None
    check_json_depth(value)
    return value


async def read_upload(request: Request, types, max_bytes: int) -> tuple[str, bytes]:
    """(content type, body) of an upload whose content type is one of ``types`` (never a form encoding or text/plain:
    :func:`read_json`), at most ``max_bytes``; LimitError 415, 413 or 408."""
    media = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if media not in types:
        raise LimitError(415, f"request body: Content-Type must be {'one of ' if len(types) > 1 else ''}"
                         f"{', '.join(types)}, not {media or 'missing'!r}")  # fmt: skip
    return media, bytes(await _bounded_body(request, max_bytes))


async def _bounded_body(request: Request, max_bytes: int) -> bytearray:
    length = request.headers.get("content-length")
    if length is not None and (not length.isdigit() or int(length) > max_bytes):
        raise LimitError(413, f"request body over {max_bytes} bytes")
    waited = [0.0]  # the client's time [s] so far, over all chunks
    data = bytearray()
    chunks = request.stream().__aiter__()
    while (chunk := await _next_within(chunks, waited)) is not None:
        data += chunk
        if len(data) > max_bytes:
            raise LimitError(413, f"request body over {max_bytes} bytes")
    return data


async def _next_within(chunks, waited: list) -> bytes | None:
    """The next chunk of the body (None at its end), or 408 once the client has had BODY_TIMEOUT_S in all (counted
    in ticks of nominal length: time the server held its event loop is not charged to the client)."""
    tick = BODY_TIMEOUT_S / 20
    read = asyncio.ensure_future(_next_chunk(chunks))
    while True:
        await asyncio.wait({read}, timeout=tick)
        if read.done():
            return read.result()
        waited[0] += tick
        if waited[0] >= BODY_TIMEOUT_S:
            read.cancel()
            raise LimitError(408, f"request body not received within {BODY_TIMEOUT_S:g} s", {"Connection": "close"})


async def _next_chunk(chunks) -> bytes | None:
    try:
        return await chunks.__anext__()
    except StopAsyncIteration:
        return None
