"""`turbgen serve`: an HTTP face over runs/, sweep/, export/ and validate/ (no science here).

app (the FastAPI application) ties together run_ids, catalog, jobs (dask queue), limits, state, derived products
and the routers of ``routes``; server runs it (uvicorn, the service's own dask cluster). docs/service.md."""
