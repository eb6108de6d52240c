"""Tasks on the cluster: submitted a few at a time, collected in block order.

At most as many tasks run at once as the cluster has worker threads (plus
one queued per thread), so the windows of the volume in flight stay bounded;
results come back in the order of the items, whatever worker made them.
"""

from __future__ import annotations

import logging
import time
import uuid
from collections.abc import Callable, Sequence
from typing import Any

log = logging.getLogger("rdmesh")

#: Tasks in flight per worker thread.
PER_THREAD = 2


def run_all(
    client: Any,
    fn: Callable,
    items: Sequence[Any],
    stage: str,
    names: Sequence[str],
    prepare: Callable[[Any], Any] | None = None,
) -> list[Any]:
    """``fn(item)`` for every item on the cluster; the results in item order.

    ``prepare(item)``, if given, makes the argument just before it is
    submitted (the windows of the volume are read then, not all at once). An
    exception in a task is raised here with a note naming the item and the
    stage; a worker that died raises RuntimeError saying so.
    """
    import dask
    from distributed import KilledWorker, wait

    token = uuid.uuid4().hex[:10]
    results: list[Any] = [None] * len(items)
    pending = list(range(len(items)))[::-1]
    running: dict[Any, int] = {}
    t0 = time.perf_counter()
    try:
        while pending or running:
            cap = max(1, sum(client.nthreads().values())) * PER_THREAD
            # Windows of the volume travel with their tasks; they are meant to.
            with dask.config.set({"distributed.admin.large-graph-warning-threshold": "4GiB"}):
                while pending and len(running) < cap:
                    i = pending.pop()
                    arg = items[i] if prepare is None else prepare(items[i])
                    fut = client.submit(fn, arg, key=f"rdmesh-{stage}-{token}-{i}", pure=False)
                    del arg
                    running[fut] = i
            done, _ = wait(list(running), return_when="FIRST_COMPLETED")
            for fut in done:
                i = running.pop(fut)
                try:
                    results[i] = fut.result()
                except KilledWorker as exc:
                    raise RuntimeError(
                        f"{names[i]} ({stage}): its worker process died while running it "
                        "(out of memory, or a crash)"
                    ) from exc
                except Exception as exc:
                    exc.add_note(f"rdmesh.mesh_volume_blocks: in {names[i]} ({stage})")
                    raise
    finally:
        if running:
            client.cancel(list(running))
    log.info("blocks: %s: %d tasks in %.2f s", stage, len(items), time.perf_counter() - t0)
    return results
