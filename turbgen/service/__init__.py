"""`turbgen serve`: an HTTP face over runs/, sweep/, export/ and validate/ (no science here).

run_ids   run requests and ids (hash of model, canonical parameters, grid, seed, turbgen version)
catalog   the on-disk catalog of runs
jobs      the job queue on dask.distributed (dedupe, progress, restart)
limits    body size, memory budget, queue length, bearer token, bound on derived computations
state     settings and shared state of a server, and the FastAPI dependencies handing them to routes
bodies    JSON request bodies (size, nesting, content type)
status    a run's status as clients see it (errors without server paths)
derived   exports, validation, lidar reports: computed once, published atomically, never for a deleted run
cleanup   start-up removal of dead processes' temporaries; the stencil cache's size cap
routes    the routers: runs, sweeps, products (exports/validation/lidar/plots), pages (/, /docs, /health)
pages     the server-rendered web page at / and the API reference at /docs
app       the ASGI application (FastAPI) tying them together
server    the service's own dask cluster (no HTTP servers) and uvicorn's limits
"""
