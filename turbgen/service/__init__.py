"""`turbgen serve`: an HTTP face over runs/, sweep/, export/ and validate/ (no science here).

run_ids   run requests and ids (hash of model, canonical parameters, grid, seed, turbgen version)
catalog   the on-disk catalog of runs
jobs      the job queue on dask.distributed (dedupe, progress, restart)
limits    body size, memory budget, queue length, bearer token
pages     the server-rendered web page at /
app       the ASGI application (FastAPI) tying them together
"""
