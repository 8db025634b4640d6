"""The sweep route: a `turbgen sweep` config submitted as one request, its runs queued by id."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from starlette.concurrency import run_in_threadpool

from turbgen.errors import ParameterError
from turbgen.service.bodies import read_json
from turbgen.service.limits import RETRY_AFTER_S, LimitError, check_constrained_memory, check_memory
from turbgen.service.run_ids import canonical_mapping, constraint_keys, run_id
from turbgen.spec.constraints import CONSTRAINT_KEYS
from turbgen.service.state import ServiceState, get_state, require_token

router = APIRouter()

# keys of `turbgen sweep` files the service does not take: a server file, a network address, a path or a worker
# count named by the client (refused rather than silently ignored)
REFUSED_KEYS = {
    "preset_file": "give user_presets inline",
    "lidar": "GET /runs/<id>/lidar?lidar=PRESET per run",
    "scheduler": "the server's own cluster runs every run",
    "workers": "the server's own cluster runs every run",
    "out": "runs are stored in the server's catalog: GET /runs/<id>/store",
    "fit": "a sweep's presets set L, gamma and the energy level; replay with POST /runs and fit, a run per seed",
}


@router.post("/sweeps", status_code=202, dependencies=[Depends(require_token)])
async def sweeps(request: Request, state: ServiceState = Depends(get_state)):
    """Submit a sweep config (schemas/sweep.schema.json without out, workers, scheduler, lidar, preset_file;
    ``constrain`` names uploads by id): the run ids."""
    body = await read_json(request)
    if not isinstance(body, dict):
        raise ParameterError("request body: expected a JSON object with the sweep config")
    from turbgen.sweep.plan_file import plan_from_mapping

    for key, instead in REFUSED_KEYS.items():
        if key in body:
            raise ParameterError(f"{key}: not accepted by the service ({instead})")
    # constrain names uploads by id (turbgen.service.uploads): the plan reads the server's own copies
    constraints = constraint_keys({key: body[key] for key in CONSTRAINT_KEYS if key in body})
    files = [str(p) for p in state.catalog.uploads.paths(constraints.get("constrain", ()))]
    mapping = {**body, "out": "unused", **({"constrain": files} if files else {})}
    plan = await run_in_threadpool(plan_from_mapping, mapping)  # a constrained plan places the data on every grid
    rids = [run_id(pr.model, canonical_mapping(pr.run, constraints)) for pr in plan.runs]
    new = [pr for pr, rid in zip(plan.runs, rids) if not state.catalog.is_complete(rid)]  # complete runs are served
    for pr in new:
        if constraints:
            await run_in_threadpool(check_constrained_memory, pr.run, files, constraints,
                                    state.settings.memory_budget_bytes)  # fmt: skip
        else:
            check_memory(pr.model, pr.run, state.settings.memory_budget_bytes)
    with state.jobs.lock:
        free = state.jobs.max_queue - state.jobs.busy()
    if len(new) > free:
        raise LimitError(429, f"the sweep has {len(new)} runs to compute, the queue has room for {free}",
                         {"Retry-After": str(RETRY_AFTER_S)})  # fmt: skip
    ids = []
    for pr, rid in zip(plan.runs, rids):
        state.jobs.submit(rid, pr.model, pr.run, pr.preset, constraints)
        ids.append({"id": rid, "model": pr.model, "preset": pr.preset, "U_m_s": pr.U_m_s, "seed": pr.seed})
    return {"runs": ids}
