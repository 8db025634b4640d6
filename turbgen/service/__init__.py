"""`turbgen serve`: an HTTP face over runs/, sweep/, export/ and validate/ (no science here).

catalog   run ids (hash of model, canonical parameters, grid, seed, turbgen version) and the on-disk catalog
jobs      the job queue on dask.distributed (dedupe, progress, restart)
limits    body size, memory budget, queue length, bearer token
pages     the server-rendered web page at /
app       the ASGI application (FastAPI) tying them together
"""
